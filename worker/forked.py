"""A function run in a forked child process while the job goes on, its result collected later.

The attitude job draws part of its plots this way while it writes its CSV products (the worker has two cores and
matplotlib holds the GIL): the child inherits the solution's arrays by fork (nothing pickled on the way in) and
sends back only its result (PNG bytes). Where fork is not available the function runs in this process, when the
result is asked for.
"""
from __future__ import annotations

import multiprocessing
import os
import traceback
from typing import Any, Callable

__all__ = ["Forked", "ForkedError"]


class ForkedError(RuntimeError):
    """The forked function raised; the message holds its traceback."""


def _child(conn, fn: Callable[[], Any]) -> None:
    try:
        result = ("ok", fn())
    except BaseException:          # noqa: BLE001 - everything goes back to the parent, which raises it
        result = ("error", traceback.format_exc())
    conn.send(result)
    conn.close()


class Forked:
    """`Forked(fn)` starts fn() in a forked child; `result()` waits for it and returns its value (ForkedError
    with the child's traceback if it raised or died); `cancel()` ends the child. CPU of the child counts in
    os.times() children fields of this process once result() or cancel() has waited for it."""

    def __init__(self, fn: Callable[[], Any]):
        self._fn = fn
        self._proc = None
        if "fork" in multiprocessing.get_all_start_methods():
            ctx = multiprocessing.get_context("fork")
            self._conn, child_conn = ctx.Pipe(duplex=False)
            self._proc = ctx.Process(target=_child, args=(child_conn, fn), daemon=True)
            self._proc.start()
            child_conn.close()

    def result(self) -> Any:
        if self._proc is None:
            return self._fn()
        try:
            status, value = self._conn.recv()
        except EOFError:
            self._proc.join()
            raise ForkedError(f"the forked process ended with exit code {self._proc.exitcode} and no result") \
                from None
        finally:
            self._conn.close()
        self._proc.join()
        if status != "ok":
            raise ForkedError(value)
        return value

    def cancel(self) -> None:
        if self._proc is not None and self._proc.is_alive():
            self._proc.terminate()
            self._proc.join()


def cpu_s() -> float:
    """CPU seconds of this process and of its children waited for (os.times)."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system
