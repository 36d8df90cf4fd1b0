"""The one error type for bad input, shared by every pure package and the CLI.

A user's mistake (a malformed file, an impossible parameter) is reported as one line that names
the file, the line or the field and what was expected; the CLI turns it into exit code 2.
"""

from __future__ import annotations

from pathlib import Path


class InputError(ValueError):
    """Bad input from the user: one clear line, never a traceback.

    >>> str(InputError("expected 68 or 69 mask values, got 12", path="a.fap", line=3))
    'a.fap:3: expected 68 or 69 mask values, got 12'
    """

    def __init__(
        self,
        message: str,
        *,
        path: str | Path | None = None,
        line: int | None = None,
        field: str | None = None,
    ) -> None:
        self.message = message
        self.path = None if path is None else str(path)
        self.line = line
        self.field = field
        super().__init__(str(self))

    def __str__(self) -> str:
        where = ""
        if self.path is not None:
            where = self.path + (f":{self.line}" if self.line is not None else "") + ": "
        elif self.line is not None:
            where = f"line {self.line}: "
        if self.field is not None:
            where += f"{self.field}: "
        # names taken from the input (keys, file names) may hold line breaks: keep one line
        return (where + self.message).replace("\r", "\\r").replace("\n", "\\n")
