"""worker.forked.Forked: a function run in a forked child, its result collected later (the attitude job's plots).

It must work where the job runs: inside a job attempt, which is a daemonic multiprocessing child
(worker/isolation.py) that multiprocessing forbids to have children of its own.
"""
from __future__ import annotations

import multiprocessing
import os
import time

import pytest

from worker.forked import Forked, ForkedError


def _big_result() -> bytes:
    return bytes(range(256)) * 40_000      # 10 MB: more than a pipe buffer, read in pieces


def _in_daemon(queue) -> None:
    try:
        queue.put(("ok", len(Forked(_big_result).result())))
    except BaseException as exc:          # noqa: BLE001 - reported to the test
        queue.put(("error", repr(exc)))


def test_result_comes_back_from_a_child_of_a_daemonic_job_process():
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    proc = ctx.Process(target=_in_daemon, args=(queue,), daemon=True)
    proc.start()
    status, value = queue.get(timeout=60)
    proc.join(10)
    assert (status, value) == ("ok", len(_big_result()))


def test_the_child_runs_in_another_process_and_its_exception_comes_back():
    parent = os.getpid()
    assert Forked(os.getpid).result() != parent

    def boom():
        raise ValueError("bad table")

    with pytest.raises(ForkedError, match="ValueError: bad table"):
        Forked(boom).result()


def test_the_child_freezes_what_it_inherits_and_the_parent_does_not():
    """gc.freeze in the child: its collections skip the parent's objects (no copy-on-write of their pages)."""
    import gc

    parent_frozen = gc.get_freeze_count()
    made_here = [[i] for i in range(10_000)]       # tracked objects the child inherits
    assert Forked(gc.get_freeze_count).result() >= parent_frozen + len(made_here)
    assert gc.get_freeze_count() == parent_frozen


def test_a_child_that_hangs_is_killed_and_the_function_runs_here():
    parent = os.getpid()

    def hangs_in_the_child():
        if os.getpid() != parent:
            time.sleep(3600)               # e.g. a lock another thread held at fork time
        return "drawn here"

    t0 = time.monotonic()
    assert Forked(hangs_in_the_child, timeout_s=1.0).result() == "drawn here"
    assert time.monotonic() - t0 < 30      # the 1 s timeout, not the child's hour


def test_a_child_that_dies_is_replaced_by_running_here():
    parent = os.getpid()

    def dies_in_the_child():
        if os.getpid() != parent:
            os._exit(3)
        return 7

    assert Forked(dies_in_the_child).result() == 7


def _start_a_long_child(queue) -> None:
    """In a job-like process: start a forked child that would run 60 s, report its pid, then wait to be killed."""
    forked = Forked(lambda: time.sleep(60))
    queue.put(forked._pid)
    time.sleep(120)


def test_a_killed_job_process_takes_its_forked_child_with_it():
    """A job child killed by its worker (cancel, lost lease, time limit) must not leave its plot or reading child
    running on (it would hold a core for the rest of its work): the child dies with the process that forked it."""
    import signal

    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    proc = ctx.Process(target=_start_a_long_child, args=(queue,), daemon=True)
    proc.start()
    grandchild = queue.get(timeout=60)
    os.kill(grandchild, 0)                        # running
    os.kill(proc.pid, signal.SIGKILL)
    proc.join(10)
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        try:
            os.kill(grandchild, 0)
        except ProcessLookupError:
            return
        if _is_zombie(grandchild):                # dead, its reaper (init) not yet there
            return
        time.sleep(0.05)
    os.kill(grandchild, signal.SIGKILL)
    pytest.fail(f"forked child {grandchild} still running 10 s after its parent was killed")


def _is_zombie(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] == "Z"
    except FileNotFoundError:
        return True
