"""Summaries that need a whole file in memory (navigation, SP3, clock and ANTEX files are read by their full
readers, about ten times their size in memory) run in a separate process, not in the API's: the API's own
memory stays bounded whatever such a file holds, and the helper process has a data limit of its own
(GNSSATT_SUMMARIZER_MEMORY_MB); a file it cannot summarise within that is refused with 413.

One spawned helper per API process, started on first use (it imports the readers; the API itself imports
no numerics) and started again if it dies.
"""
from __future__ import annotations

import multiprocessing
import resource
import threading
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from app.problems import ProblemError
from gnssatt.gnss.io.errors import ParseError

_POOL: ProcessPoolExecutor | None = None
_POOL_LOCK = threading.Lock()
TIMEOUT_S = 300.0


def _limit(memory_bytes: int) -> None:
    try:
        soft, hard = resource.getrlimit(resource.RLIMIT_DATA)
        resource.setrlimit(resource.RLIMIT_DATA, (memory_bytes, hard))
    except (ValueError, OSError):
        pass


def _identify(path: str, name: str) -> tuple:
    """In the helper: ("ok", kind, summary), ("parse", ParseError fields) or ("error", type, message)."""
    try:
        from gnssatt.gnss.io.sniff import identify

        kind, summary = identify(Path(path), name)
        return "ok", kind, summary
    except ParseError as exc:
        return "parse", exc.path, exc.line_no, exc.expected, exc.found, exc.column
    except MemoryError:
        return "memory", "", ""
    except Exception as exc:  # noqa: BLE001 - typed back to the API as a 422
        return "error", type(exc).__name__, str(exc)[:300]


def _pool(memory_bytes: int) -> ProcessPoolExecutor:
    global _POOL
    with _POOL_LOCK:
        if _POOL is None:
            _POOL = ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn"),
                                        initializer=_limit, initargs=(memory_bytes,))
        return _POOL


def _reset() -> None:
    global _POOL
    with _POOL_LOCK:
        if _POOL is not None:
            _POOL.shutdown(wait=False, cancel_futures=True)
        _POOL = None


def identify_elsewhere(path: Path, name: str, memory_mb: int) -> tuple[str, dict]:
    """identify() in the helper process; ParseError / ProblemError as if it had run here."""
    try:
        result = _pool(memory_mb * 2**20).submit(_identify, str(path), name).result(timeout=TIMEOUT_S)
    except (BrokenProcessPool, MemoryError, ImportError):
        _reset()
        result = ("memory", "", "")
    except TimeoutError:
        _reset()
        raise ProblemError(422, "file-rejected", f"{name} rejected",
                           f"{name}: could not be summarised within {TIMEOUT_S:g} s", file=name) from None
    if result[0] == "ok":
        return result[1], result[2]
    if result[0] == "parse":
        raise ParseError(result[1], result[2], result[3], result[4], column=result[5])
    if result[0] == "memory":
        raise ProblemError(413, "file-too-large", f"{name} too large",
                           f"{name}: summarising this file needs more than the {memory_mb} MB the service allows "
                           "(GNSSATT_SUMMARIZER_MEMORY_MB); split it or ask the operator to raise the limit.",
                           file=name)
    raise ProblemError(422, "unreadable-file", f"{name} could not be read", f"{name}: {result[1]}: {result[2]}",
                       file=name)


def shutdown() -> None:
    _reset()
