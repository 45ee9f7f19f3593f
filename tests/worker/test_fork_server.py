"""Job children come from the fork server (worker.isolation), not from the threaded worker: the child's parent is
the fork server, which had one Python thread when it forked, and a child still starts and imports while another
thread of the worker is in the middle of importing the same module (a child forked from the worker itself
inherits that module's import lock, held by a thread it does not have, and hangs until the time budget)."""
from __future__ import annotations

import importlib
import os
import threading
import time

import pytest

from core.settings import Settings
from worker import runner
from worker.context import JobContext
from worker.isolation import run_budgeted
from worker.main import build_runtime

SLOW_IMPORT_S = 6.0


def where_am_i(child_rt, names) -> dict:
    """In the child: its parent's command line and the fork server's Python thread count when it was ready."""
    import worker.zygote

    with open(f"/proc/{os.getppid()}/cmdline", "rb") as fh:
        cmdline = fh.read().replace(b"\0", b" ").decode()
    return {"ppid": os.getppid(), "parent_cmdline": cmdline, "threads": worker.zygote.PYTHON_THREADS,
            "preloaded": "worker.jobs.calibration" in __import__("sys").modules}


def import_module_named(name: str, child_rt, names) -> dict:
    """In the child: import `name` (a module another thread of the worker is importing right now)."""
    return {"value": importlib.import_module(name).VALUE}


@pytest.fixture
def rt(tmp_path, fork_server):
    settings = Settings(data_dir=tmp_path / "var", job_memory_mb=200, job_time_s=SLOW_IMPORT_S - 1.0,
                        job_isolation="process")
    rt = build_runtime(settings, name="fork-server-test")
    yield rt
    runner.set_runtime(None)
    rt.engine.dispose()


def _ctx(tmp_path) -> JobContext:
    return JobContext(job_id="forkserver", attempt=1, sets=[], workdir=tmp_path, _store_blob=lambda p: ("", 0))


def test_the_child_comes_from_a_single_threaded_fork_server_with_the_pipelines_loaded(rt, tmp_path):
    threading.Thread(target=time.sleep, args=(2.0,), daemon=True).start()  # the worker has threads: no matter
    out = run_budgeted(rt, _ctx(tmp_path), where_am_i)
    assert out["ppid"] != os.getpid() and "multiprocessing.forkserver" in out["parent_cmdline"]
    assert out["threads"] == 1 and out["preloaded"]


def test_a_child_imports_a_module_another_worker_thread_is_importing(rt, tmp_path, monkeypatch):
    from functools import partial

    name = f"slow_import_{os.getpid()}_{time.monotonic_ns()}"
    # slow only in this process: the child imports it in no time, unless it is stuck on this process's lock
    (tmp_path / f"{name}.py").write_text(f"import os, time\nif os.getpid() == {os.getpid()}:\n"
                                         f"    time.sleep({SLOW_IMPORT_S})\nVALUE = 42\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    importer = threading.Thread(target=importlib.import_module, args=(name,), daemon=True)
    importer.start()
    time.sleep(0.5)  # the importer now holds the module's import lock, for SLOW_IMPORT_S
    t0 = time.monotonic()
    out = run_budgeted(rt, _ctx(tmp_path), partial(import_module_named, name))
    assert out == {"value": 42} and time.monotonic() - t0 < SLOW_IMPORT_S - 1.5
    importer.join(timeout=SLOW_IMPORT_S + 5)


@pytest.mark.parametrize("spec_name, file, want", [
    ("client.cli", "/repo/client/cli.py", ("client.cli",)),   # python -m client.cli worker
    (None, "/venv/bin/gnssatt", ("__main__",)),              # the console script: its file, as multiprocessing runs it
    ("pytest.__main__", "/x/pytest/__main__.py", ()),         # a package's __main__: multiprocessing does not re-run it
    (None, None, ()),                                         # interactive / -c
])
def test_the_fork_server_preloads_the_main_module_its_children_run_again(monkeypatch, spec_name, file, want):
    """multiprocessing re-runs the worker's main module in every child of the fork server; preloaded there, the
    re-run finds the CLI's imports loaded instead of importing them per job (~80 ms each)."""
    import sys
    import types
    from importlib.machinery import ModuleSpec

    from worker.isolation import main_module_preload

    main = types.ModuleType("__main__")
    main.__spec__ = ModuleSpec(spec_name, None) if spec_name else None
    if file:
        main.__file__ = file
    monkeypatch.setitem(sys.modules, "__main__", main)
    assert main_module_preload() == want
