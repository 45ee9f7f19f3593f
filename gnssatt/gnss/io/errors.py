"""The one parse error every reader raises, and the structured warnings readers collect.

A reader refuses what is broken with `ParseError(path, line_no, column, expected, found)`; its message
prints what was expected above the offending line (as sgp4's TLE reader does), so a user can fix the file.
Header quirks that are legal or tolerable become `ParseWarning`s in the summary, never silent skips.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass


class ParseError(ValueError):
    """A file that cannot be read as the format it claims to be.

    Args:
        path: file name as the user knows it (the name inside an upload, not a temp path).
        line_no: 1-based line number of the offending line, or None when not line-oriented.
        column: 1-based column where the problem starts, or None.
        expected: what the format requires there, in words (e.g. "F14.3 observation in columns 4-17").
        found: the offending text (the line, possibly shortened), or a description of what was found.
    """

    def __init__(self, path: str, line_no: int | None, expected: str, found: str = "", column: int | None = None):
        self.path = str(path)
        self.line_no = line_no
        self.column = column
        self.expected = expected
        self.found = found[:200] if isinstance(found, str) else str(found)[:200]
        super().__init__(self._message())

    def _message(self) -> str:
        where = self.path
        if self.line_no is not None:
            where += f", line {self.line_no}"
        if self.column is not None:
            where += f", column {self.column}"
        msg = f"{where}: expected {self.expected}"
        if self.found:
            msg += f"\n    found: {self.found.rstrip()!r}"
        return msg

    def to_dict(self) -> dict:
        """JSON-ready fields for an RFC 9457 problem body."""
        return {"file": self.path, "line": self.line_no, "column": self.column,
                "expected": self.expected, "found": self.found, "detail": str(self)}


def warning_code(code: str) -> str:
    """The one warning-code style of every reader (docs/reader_policy.md): lower-case words joined by '-'
    ('truncated-last-epoch'), then optionally ':' and a detail kept as written ('unsupported-record:EPH S')."""
    head, sep, detail = code.partition(":")
    return head.strip().lower().replace("_", "-").replace(" ", "-") + sep + detail


@dataclass(frozen=True)
class ParseWarning:
    """A tolerated quirk (missing MARKER NAME, wrong TIME OF LAST OBS, ...) reported to the user; `code` is put
    in the one style of `warning_code` whatever the reader wrote."""

    code: str
    message: str
    line_no: int | None = None

    def __post_init__(self):
        object.__setattr__(self, "code", warning_code(self.code))

    def to_dict(self) -> dict:
        return asdict(self)
