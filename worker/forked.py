"""A function run in a forked child process while the job goes on, its result collected later.

The attitude job draws part of its plots this way while it writes its CSV products (the worker has two cores and
matplotlib holds the GIL): the child inherits the solution's arrays by fork (nothing pickled on the way in) and
sends back only its result (PNG bytes) through a pipe.

The child is made by `os.fork`, not `multiprocessing.Process`: a job attempt itself runs in a daemonic
multiprocessing child (worker/isolation.py), and multiprocessing refuses children of a daemonic process. A child
that dies or sends nothing within `timeout_s` (a lock some other thread held at fork time, say) is killed and the
function runs in this process instead, so the job never waits on it for ever. Where fork is not available the
function runs in this process when the result is asked for.
"""
from __future__ import annotations

import gc
import logging
import os
import pickle
import select
import signal
import sys
import traceback
from typing import Any, Callable

__all__ = ["Forked", "ForkedError", "cpu_s"]

log = logging.getLogger(__name__)

#: how long result() waits for the child before it kills it and runs the function here (the attitude job's
#: forked plots take ~1-3 s on a quiet machine, ~10x that on a loaded one)
DEFAULT_TIMEOUT_S = 300.0


class ForkedError(RuntimeError):
    """The forked function raised; the message holds its traceback."""


def _die_with(parent_pid: int) -> None:
    """In the child (Linux): be killed when the process that forked us ends (prctl PR_SET_PDEATHSIG), so a job
    child killed by its worker (cancel, lost lease, time limit) leaves no plot or reading child running on.
    Elsewhere a no-op: such a child still ends by itself when its work is done."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL, 0, 0, 0)   # 1 = PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        return
    if os.getppid() != parent_pid:     # the parent died before the prctl took effect
        os._exit(1)


def _child(write_fd: int, fn: Callable[[], Any]) -> None:
    """In the child: run fn, write the pickled ("ok", value) or ("error", traceback) and leave at once."""
    code = 0
    try:
        # every object inherited is frozen out of the cyclic collector: fn's collections traverse only what fn
        # made and write no inherited page (the attitude job's plot children: ~0.15 s of collections and ~8000
        # copy-on-write faults fewer per child on the 106-min pass)
        gc.freeze()
        try:
            payload = pickle.dumps(("ok", fn()), protocol=pickle.HIGHEST_PROTOCOL)
        except BaseException:          # noqa: BLE001 - everything goes back to the parent, which raises it
            payload = pickle.dumps(("error", traceback.format_exc()))
        with os.fdopen(write_fd, "wb") as out:
            out.write(payload)
    except BaseException:              # noqa: BLE001 - a broken pipe: the parent sees no result
        code = 1
    finally:
        os._exit(code)                 # no atexit handlers, no flushing of the parent's inherited buffers


class Forked:
    """`Forked(fn)` starts fn() in a forked child; `result()` waits for it and returns its value (ForkedError with
    the child's traceback if it raised; fn() run here if the child died or timed out); `cancel()` ends the child.
    CPU of the child counts in os.times() children fields of this process once it has been waited for."""

    def __init__(self, fn: Callable[[], Any], *, timeout_s: float = DEFAULT_TIMEOUT_S):
        self._fn = fn
        self._timeout_s = timeout_s
        self._pid: int | None = None
        self._read_fd: int | None = None
        if hasattr(os, "fork"):
            read_fd, write_fd = os.pipe()
            parent_pid = os.getpid()
            pid = os.fork()
            if pid == 0:               # the child
                os.close(read_fd)
                _die_with(parent_pid)
                _child(write_fd, fn)
            os.close(write_fd)
            self._pid, self._read_fd = pid, read_fd

    def _read_all(self) -> bytes | None:
        """The child's whole output, or None if it sent nothing complete within the timeout."""
        chunks = []
        remaining_s = self._timeout_s
        while True:
            ready, _, _ = select.select([self._read_fd], [], [], max(remaining_s, 0.0))
            if not ready:
                return None
            chunk = os.read(self._read_fd, 1 << 20)
            if not chunk:
                return b"".join(chunks) or None
            chunks.append(chunk)

    def result(self) -> Any:
        if self._pid is None:
            return self._fn()
        try:
            data = self._read_all()
        finally:
            os.close(self._read_fd)
            self._read_fd = None
        if data is None:
            self.cancel()
            log.warning("forked function sent no result (died or timed out after %.0f s); running it here",
                        self._timeout_s)
            return self._fn()
        self._reap()
        try:
            status, value = pickle.loads(data)
        except Exception:              # noqa: BLE001 - cut short: the child died while writing
            log.warning("forked function's result was cut short; running it here")
            return self._fn()
        if status != "ok":
            raise ForkedError(value)
        return value

    def _reap(self) -> None:
        if self._pid is not None:
            try:
                os.waitpid(self._pid, 0)
            except ChildProcessError:
                pass
            self._pid = None

    def cancel(self) -> None:
        if self._read_fd is not None:
            try:
                os.close(self._read_fd)
            except OSError:
                pass                   # result() closed it already
            self._read_fd = None
        if self._pid is not None:
            try:
                os.kill(self._pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            self._reap()


def cpu_s() -> float:
    """CPU seconds of this process and of its children waited for (os.times)."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system
