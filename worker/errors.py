"""Errors a pipeline raises, and the problem document (RFC 9457) a failed job stores.

`JobInputError`: the user's input cannot be processed (a parse error, a missing file, an impossible
configuration). Not retried. Any other exception is a fault of ours or of the machine and is retried
up to the job's max_attempts.
"""
from __future__ import annotations

import re
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


class JobBudgetExceeded(Exception):
    """The job used more memory or time than the worker allows one job (GNSSATT_JOB_MEMORY_MB / _TIME_S)."""

    def __init__(self, title: str, detail: str):
        super().__init__(detail)
        self.title = title
        self.detail = detail


_ABSOLUTE_PATH = re.compile(r"(?<![\w.:/])/(?:[^\s'\"/:]+/)+([^\s'\"/:]*)")


def scrub_paths(text: str, names: dict[str, str] | None = None) -> str:
    """`text` with every input's blob path replaced by the file's name in its set, and any other absolute
    path by its last component: a job's error tells the problem, never the server's layout."""
    for path, name in sorted((names or {}).items(), key=lambda kv: -len(kv[0])):
        text = text.replace(path, name)
    return _ABSOLUTE_PATH.sub(lambda m: m.group(1) or "<path>", text)


def problem_for_exception(exc: BaseException, job_id: str, attempt: int,
                          names: dict[str, str] | None = None) -> dict[str, Any]:
    """The problem document stored on a failed job (no traceback, no server path: those go to the log)."""
    doc: dict[str, Any] = {"status": 422, "job_id": job_id, "attempt": attempt}
    if isinstance(exc, ParseError):
        doc.update(type=PROBLEM_TYPE_BASE + "parse-error", title="An input file could not be parsed",
                   detail=scrub_paths(str(exc), names), file=scrub_paths(str(exc.path), names), line=exc.line_no)
    elif isinstance(exc, JobInputError):
        doc.update(type=PROBLEM_TYPE_BASE + "job-input-error", title=exc.title,
                   detail=scrub_paths(exc.detail, names))
        for key in ("file", "line", "field"):
            if getattr(exc, key) is not None:
                value = getattr(exc, key)
                doc[key] = scrub_paths(value, names) if isinstance(value, str) else value
    elif isinstance(exc, JobBudgetExceeded):
        doc.update(type=PROBLEM_TYPE_BASE + "job-budget-exceeded", title=exc.title, detail=exc.detail)
    else:
        doc.update(status=500, type=PROBLEM_TYPE_BASE + "job-internal-error",
                   title="The job failed inside the worker",
                   detail=scrub_paths(f"{type(exc).__name__}: {exc}", names)[:1000])
    return doc


def log_text_for_exception(exc: BaseException) -> str:
    """The traceback, for the worker's log only."""
    return "".join(traceback.format_exception(exc))[-4000:]


def is_permanent(exc: BaseException) -> bool:
    """True for errors that another attempt cannot fix (bad input)."""
    return isinstance(exc, (ParseError, JobInputError, JobBudgetExceeded))
