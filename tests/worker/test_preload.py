"""What the fork server loads before its first fork (worker.zygote: the pipelines' PRELOAD modules, the kernels, one
figure drawn, gc.freeze) is all an attitude job needs: a job run after it imports no module of gnssatt, matplotlib
or PIL (each job child of the service would import it again: ~0.1-0.4 s per job), and its products are byte for
byte those of a job run in a fresh interpreter without any preload (creation times aside)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: run in a fresh interpreter: argv[1] the simulated set, argv[2] "preload" or "plain"; prints one JSON line
JOB_SCRIPT = r"""
import gc, hashlib, json, re, sys
from pathlib import Path
d, how = Path(sys.argv[1]), sys.argv[2]
if how == "preload":
    from worker.main import preload_pipelines
    from gnssatt.plots.common import warm_up
    preload_pipelines()
    warm_up(draw=True)
    gc.freeze()
from bench.local_jobs import files_set, job_context, product_bytes
from worker.jobs.attitude import AttitudeConfig, run
files = [(f"obs/{p.name}", "rinex_obs", p) for p in sorted((d / "obs").glob("*.rnx"))]
files += [("nav/brdc.rnx", "rinex_nav", d / "nav/brdc.rnx"), ("platform.json", "platform", d / "platform.json"),
          ("platform.sp3", "sp3", d / "platform.sp3"),
          ("reference_attitude.csv", "reference_attitude", d / "reference_attitude.csv")]
ctx = job_context(d.parent / f"work-{how}", [files_set(files, name="pass")], job_id="preload-test")
before = set(sys.modules)
run(ctx, AttitudeConfig(mode="kinematic"))
new = sorted(m for m in set(sys.modules) - before if m.split(".")[0] in ("gnssatt", "matplotlib", "PIL"))
def stable(name, data):
    if name == "attitude.aem":
        data = re.sub(rb"CREATION_DATE = [^\n]*", b"", data)
    if name == "report.html":
        data = re.sub(rb"generated [0-9-]+ [0-9:]+ UTC", b"", data)
    return hashlib.sha256(data).hexdigest()
print(json.dumps({"new_modules": new,
                  "products": {k: stable(k, v) for k, v in sorted(product_bytes(ctx).items())}}))
"""


@pytest.fixture(scope="module")
def short_pass(tmp_path_factory) -> Path:
    from gnssatt.sim import simulate_scenario

    out = tmp_path_factory.mktemp("preload") / "pass"
    simulate_scenario("earth-pointing", out, seed=3, overrides={"duration_s": 240.0})
    return out


def _job(d: Path, how: str) -> dict:
    proc = subprocess.run([sys.executable, "-c", JOB_SCRIPT, str(d), how], cwd=ROOT, capture_output=True,
                          text=True, timeout=600,
                          env={**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1"})
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_an_attitude_job_after_the_preload_imports_nothing_and_makes_the_same_products(short_pass):
    preloaded, plain = _job(short_pass, "preload"), _job(short_pass, "plain")
    assert preloaded["new_modules"] == []
    assert plain["new_modules"], "the plain run imports the pipeline's modules (else the check above is empty)"
    assert set(preloaded["products"]) >= {"attitude.csv", "residuals.csv", "euler.png", "skyplot.png", "report.html"}
    assert preloaded["products"] == plain["products"]
