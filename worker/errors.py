"""Errors a pipeline raises, and the problem document (RFC 9457) a failed job stores.

`JobInputError`: the user's input cannot be processed (a parse error, a missing file, an impossible
configuration). Not retried. Any other exception is a fault of ours or of the machine and is retried
up to the job's max_attempts.
"""
from __future__ import annotations

import traceback
from typing import Any

from gnssatt.gnss.io.errors import ParseError

PROBLEM_TYPE_BASE = "https://gnssatt.dev/problems/"


class JobInputError(Exception):
    def __init__(self, title: str, detail: str, *, file: str | None = None, line: int | None = None,
                 field: str | None = None):
        super().__init__(detail)
        self.title = title
        self.detail = detail
        self.file = file
        self.line = line
        self.field = field


class JobCancelled(Exception):
    """Raised inside a pipeline (at a progress call) once a cancel was requested."""


class LeaseLost(Exception):
    """This worker no longer holds the job's lease: another attempt owns it; stop without writing."""


def problem_for_exception(exc: BaseException, job_id: str, attempt: int) -> dict[str, Any]:
    """The problem document stored on a failed job."""
    doc: dict[str, Any] = {"status": 422, "job_id": job_id, "attempt": attempt}
    if isinstance(exc, ParseError):
        doc.update(type=PROBLEM_TYPE_BASE + "parse-error", title="An input file could not be parsed",
                   detail=str(exc), file=exc.path, line=exc.line_no)
    elif isinstance(exc, JobInputError):
        doc.update(type=PROBLEM_TYPE_BASE + "job-input-error", title=exc.title, detail=exc.detail)
        for key in ("file", "line", "field"):
            if getattr(exc, key) is not None:
                doc[key] = getattr(exc, key)
    else:
        doc.update(status=500, type=PROBLEM_TYPE_BASE + "job-internal-error",
                   title="The job failed inside the worker",
                   detail=f"{type(exc).__name__}: {exc}",
                   traceback="".join(traceback.format_exception(exc))[-4000:])
    return doc


def is_permanent(exc: BaseException) -> bool:
    """True for errors that another attempt cannot fix (bad input)."""
    return isinstance(exc, (ParseError, JobInputError))
