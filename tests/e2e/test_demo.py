"""`make demo` as a new user runs it (`python -m client.demo`, what the Makefile target calls): the API and a worker
started in the background on the embedded default, a simulated set uploaded over real HTTP, the attitude job
followed to the end, its products downloaded, the accuracy printed; then `--stop` (issue 16: every step that may
take over 5 s says what it is doing before it starts). Run from a fresh copy of the repository's tracked files with
no ../shared beside it (issue 24: a new user's clone has none), so the demo needs nothing outside the repository;
its worker compiles the filter kernels cold there (~60-100 s), as on a new user's machine."""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import httpx
import pytest

from client.local_service import _free_port
from tests.conftest import REPO_ROOT

pytestmark = pytest.mark.e2e

STEPS = ("==> starting the API", "==> simulating an observation set, scenario earth-pointing", "==> uploading",
         "==> running the attitude job", "==> downloading the products")


def _fresh_copy(dest: Path) -> Path:
    """The repository's tracked files as they are in the working tree, copied to `dest` (what a clone holds)."""
    names = subprocess.run(["git", "ls-files", "-z"], cwd=REPO_ROOT, capture_output=True, check=True).stdout
    for name in filter(None, names.decode().split("\0")):
        src = REPO_ROOT / name
        if src.is_file():
            (dest / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / name)
    return dest


def test_make_demo_runs_the_attitude_job_and_says_what_it_does(tmp_path):
    clone = _fresh_copy(tmp_path / "fresh" / "gnssatt")
    assert not (clone.parent / "shared").exists()
    data_dir = tmp_path / "var"
    port = _free_port()
    cmd = [sys.executable, "-m", "client.demo", "--port", str(port), "--data-dir", str(data_dir),
           "--duration-s", "120"]
    try:
        run = subprocess.run(cmd, cwd=clone, capture_output=True, text=True, timeout=900)
        # the clone's API serves the offline docs (their rendering in Chromium: tests/ui/test_docs_offline.py)
        docs = httpx.get(f"http://127.0.0.1:{port}/docs", timeout=30)
        conventions = httpx.get(f"http://127.0.0.1:{port}/docs/conventions", timeout=30)
    finally:
        stop = subprocess.run([sys.executable, "-m", "client.demo", "--stop", "--data-dir", str(data_dir)],
                              cwd=clone, capture_output=True, text=True, timeout=60)
    out = run.stdout
    assert run.returncode == 0, out + run.stderr
    lines = out.splitlines()
    # each long step announced before it starts, in order, and closed with its time
    at = [next(i for i, ln in enumerate(lines) if ln.startswith(s)) for s in STEPS]
    assert at == sorted(at), out
    for i in at:
        closing = next(ln for ln in lines[i + 1:] if ln.startswith("    done in ") or ln.startswith("==> "))
        assert closing.startswith("    done in "), f"step {lines[i]!r} has no 'done in' line:\n{out}"
    # while the job runs, its state / stage lines with the progress
    running = [ln for ln in lines[at[3] + 1:at[4]] if ln.rstrip().endswith("%")]
    assert running and any("succeeded" in ln for ln in running), out
    assert "succeeded after" in out and "Accuracy against the simulator's truth" in out, out
    assert list((data_dir / "demo-products").glob("*/attitude.csv")), "attitude.csv not downloaded"
    assert "stopped 2 process(es)" in stop.stdout, stop.stdout + stop.stderr
    assert docs.status_code == 200 and "/static/vendor/swagger-ui/swagger-ui-bundle.js" in docs.text
    assert conventions.status_code == 200 and 'id="conventions"' in conventions.text
    # issue 24: the quality verdict, then the last three lines: job page (sign-in link, key in the fragment),
    # report, products folder
    assert "quality: " in out, out
    page, report, products = lines[-3:]
    assert page.startswith("job page: http://127.0.0.1:") and "/ui/login?next=%2Fui%2Fjobs%2F" in page
    assert "#key=" in page
    assert report.startswith("report:   ") and report.endswith("report.html")
    assert products.startswith("products: ") and (Path(products.split(": ", 1)[1]) / "attitude.csv").is_file()
