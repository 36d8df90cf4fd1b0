"""Typed access to a parsed TOML document (or a form's mapping) with one-line errors.

Each accessor takes the table, the key and the dotted field name used in messages
(``conditions[2].model``) and raises :class:`~app.errors.InputError` naming the source and the
field: ``study.toml: seed: expected an integer, got '7'``. Booleans are never accepted as
integers (TOML keeps them apart; Python's ``bool`` is an ``int``).
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Final

from app.errors import InputError

MISSING: Final = object()
"""Default meaning "required": a missing key is an error."""

NAME_PATTERN: Final = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,63}$")
"""Names of conditions and clips: safe as file names, URL parts and CSV values."""


class FieldReader:
    """Typed, validated access to the fields of one source (a file name, or "form").

    Relative paths resolve against ``base_dir``; ``check_files`` requires them to exist;
    ``confine`` refuses absolute paths and paths that leave ``base_dir`` (for uploaded files,
    whose paths must not reach the server's own files); ``by_name`` resolves every path to the
    file of the same name in ``base_dir`` (uploads arrive as a flat folder of files, so the
    study file written for a checkout, ``../demo/speech.wav``, names its upload
    ``speech.wav``; the folder part is dropped, so nothing outside ``base_dir`` is reached).
    """

    def __init__(
        self,
        source: str,
        base_dir: Path,
        *,
        check_files: bool = True,
        confine: bool = False,
        by_name: bool = False,
    ) -> None:
        self.source = source
        self.base_dir = base_dir
        self.check_files = check_files
        self.confine = confine
        self.by_name = by_name

    def error(self, name: str, message: str) -> InputError:
        return InputError(message, path=self.source, field=name)

    def table(self, data: Any, name: str, keys: tuple[str, ...]) -> Mapping[str, Any]:
        if not isinstance(data, Mapping):
            raise self.error(name, f"expected a table, got {describe(data)}")
        for key in data:
            if key not in keys:
                where = f"{name}.{key_text(key)}" if name else key_text(key)
                raise self.error(where, f"unknown key (expected one of {', '.join(keys)})")
        return data

    def get(
        self,
        data: Mapping[str, Any],
        key: str,
        name: str,
        types: tuple[type, ...],
        expected: str,
        default: Any = MISSING,
    ) -> Any:
        value = data.get(key, MISSING)
        if value is MISSING:
            if default is MISSING:
                raise self.error(name, "missing (required)")
            return default
        if isinstance(value, bool) and bool not in types or not isinstance(value, types):
            raise self.error(name, f"expected {expected}, got {describe(value)}")
        return value

    def text(
        self,
        data: Mapping[str, Any],
        key: str,
        name: str,
        default: Any = MISSING,
        *,
        nonempty: bool = False,
    ) -> Any:
        value = self.get(data, key, name, (str,), "a string", default)
        if nonempty and isinstance(value, str) and not value.strip():
            raise self.error(name, "must not be empty")
        return value

    def integer(
        self,
        data: Mapping[str, Any],
        key: str,
        name: str,
        default: Any,
        minimum: int,
        maximum: int = 2**63 - 1,
    ) -> int:
        """An integer in ``minimum .. maximum`` (default: what a signed 64-bit column holds)."""
        value = self.get(data, key, name, (int,), "an integer", default)
        if value < minimum:
            raise self.error(name, f"must be >= {minimum}, got {value}")
        if value > maximum:
            raise self.error(name, f"must be <= {maximum}, got {value}")
        return int(value)

    def choice(
        self,
        data: Mapping[str, Any],
        key: str,
        name: str,
        options: tuple[str, ...],
        default: Any = MISSING,
    ) -> str:
        value = self.get(data, key, name, (str,), "a string", default)
        if value not in options:
            raise self.error(name, f"expected one of {', '.join(options)}, got {value!r}")
        return str(value)

    def identifier(self, data: Mapping[str, Any], key: str, name: str) -> str:
        value = self.text(data, key, name)
        if not NAME_PATTERN.match(value):
            raise self.error(
                name,
                f"expected a name of letters, digits, _ . - (at most 64, not "
                f"starting with . or -), got {value!r}",
            )
        return str(value)

    def file(
        self,
        data: Mapping[str, Any],
        key: str,
        name: str,
        suffixes: tuple[str, ...],
        default: Any = MISSING,
    ) -> Any:
        value = self.text(data, key, name, default, nonempty=True)
        if value is None:
            return None
        path = Path(value)
        if path.suffix.lower() not in suffixes:
            raise self.error(name, f"expected a {' or '.join(suffixes)} file, got {value!r}")
        if self.by_name:
            uploaded = upload_name(value)
            resolved = Path(os.path.abspath(self.base_dir / uploaded))
            if self.check_files and (not uploaded or not resolved.is_file()):
                raise self.error(
                    name, f"no uploaded file named {uploaded!r}; upload it with the study file"
                )
            return resolved
        resolved = Path(os.path.abspath(self.base_dir / path))
        if self.confine:
            root = Path(os.path.abspath(self.base_dir))
            if path.is_absolute() or not resolved.is_relative_to(root):
                raise self.error(name, f"must be a path inside the study's folder, got {value!r}")
        if self.check_files and not resolved.is_file():
            raise self.error(name, f"no such file: {str(resolved)!r}")
        return resolved


def upload_name(path: str) -> str:
    r"""The file name an uploaded file has for ``path`` (its last part, either slash).

    >>> upload_name("../demo/speech.wav"), upload_name("C:\\audio\\s2.wav")
    ('speech.wav', 's2.wav')
    """
    name = path.replace("\\", "/").rsplit("/", 1)[-1]
    return "" if name in (".", "..") else name


def describe(value: Any) -> str:
    """How a TOML value reads in an error message."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, list):
        return "an array"
    if isinstance(value, Mapping):
        return "a table"
    return type(value).__name__


def key_text(key: object) -> str:
    """A key as TOML writes it: bare if it may be, else quoted (so a message stays one line)."""
    text = str(key)
    if text and all(c.isascii() and (c.isalnum() or c in "_-") for c in text):
        return text
    return json.dumps(text)
