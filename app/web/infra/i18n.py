"""The participant pages in the study's language (Flask-Babel).

Every fixed string of the participant side goes through gettext; the catalogues are
``app/web/translations/<language>/LC_MESSAGES/messages.po``. They are compiled by Babel's own
compiler when a process first needs a language and kept in memory (keyed by the file's
modification time), so a fresh clone, an installed wheel and a read-only container need no
build step and never serve a stale ``.mo`` file.

A participant page chooses its language with :func:`use_language` (the study's ``language``,
:mod:`app.trials.participation`); everything else (the experimenter's side, the API's
``error`` fields read by scripts) stays English. ``<html lang dir>`` follow the chosen
language (:func:`page_language`, :func:`page_direction`).
"""

from __future__ import annotations

import io
import os
from functools import cached_property, lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

from babel import Locale, UnknownLocaleError
from babel.messages.mofile import write_mo
from babel.messages.pofile import read_po
from babel.support import NullTranslations, Translations
from flask import g, has_request_context
from flask_babel import Babel, Domain, get_locale, refresh

if TYPE_CHECKING:
    from flask import Flask

#: The shipped catalogues (one folder per language).
TRANSLATIONS = Path(__file__).resolve().parent.parent / "translations"
DEFAULT_LANGUAGE = "en"


@lru_cache(maxsize=64)
def _compiled(path: str, mtime_ns: int) -> Translations:
    """The catalogue ``path`` compiled as ``msgfmt`` would (fuzzy entries left out)."""
    with open(path, "rb") as source:
        catalog = read_po(source)
    buffer = io.BytesIO()
    write_mo(buffer, catalog)
    buffer.seek(0)
    return Translations(fp=buffer)


def catalogue(directory: str | Path, locale: Locale) -> Translations | None:
    """The compiled catalogue of ``locale`` in ``directory`` (``pt_BR``, then ``pt``), or None."""
    for name in dict.fromkeys((str(locale), locale.language)):
        path = Path(directory) / name / "LC_MESSAGES" / "messages.po"
        try:
            mtime = os.stat(path).st_mtime_ns
        except OSError:
            continue
        return _compiled(str(path), mtime)
    return None


class CatalogueDomain(Domain):
    """Flask-Babel's domain, reading ``.po`` catalogues (compiled in memory) instead of ``.mo``
    files; later folders of ``BABEL_TRANSLATION_DIRECTORIES`` override earlier ones. The
    merged catalogue is kept for the request (every gettext call asks for it)."""

    def get_translations(self) -> NullTranslations:
        locale = get_locale()
        if locale is None or not has_request_context():
            return NullTranslations()
        kept = g.get("_catalogue")
        if kept is not None and kept[0] == str(locale):
            return kept[1]  # type: ignore[no-any-return]
        merged = Translations()
        for directory in self.translation_directories:
            found = catalogue(directory, locale)
            if found is not None:
                merged.merge(found)
                merged.plural = found.plural
        g._catalogue = (str(locale), merged)
        return merged


class _Babel(Babel):
    @cached_property
    def domain_instance(self) -> Domain:
        return CatalogueDomain()


babel = _Babel()


def _selected_language() -> str:
    return str(g.get("page_language") or DEFAULT_LANGUAGE)


def locale_of(tag: str) -> Locale:
    """The Babel locale of a BCP 47 tag (``fr-CA`` -> ``fr_CA``); English if Babel does not
    know it."""
    try:
        return Locale.parse(tag, sep="-")
    except (UnknownLocaleError, ValueError):
        return Locale.parse(DEFAULT_LANGUAGE)


def use_language(tag: str) -> None:
    """The rest of this request speaks ``tag`` (a study's ``language``)."""
    g.page_language = tag
    refresh()


def page_language() -> str:
    """The ``lang`` of the page being rendered (a BCP 47 tag)."""
    return _selected_language() if has_request_context() else DEFAULT_LANGUAGE


def page_direction() -> str:
    """``rtl`` for a right-to-left language (Arabic, Hebrew...), else ``ltr``."""
    return locale_of(page_language()).text_direction


def init_i18n(app: Flask) -> None:
    app.config.setdefault("BABEL_DEFAULT_LOCALE", DEFAULT_LANGUAGE)
    app.config.setdefault("BABEL_TRANSLATION_DIRECTORIES", str(TRANSLATIONS))
    babel.init_app(app, locale_selector=lambda: str(locale_of(_selected_language())))
    app.jinja_env.globals.update(page_language=page_language, page_direction=page_direction)
