"""`gnssatt run` locally (no server): job types that need no input set, ttff on simulated starts and calibration of
several `--set` directories write their products, which parse and hold sane figures; the API
can serve /v1/job-types without the numerics (numba, scipy, matplotlib, the science packages) in its process."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
import zipfile

import pytest

from client.cli import main as cli_main
from tests.conftest import REPO_ROOT


@pytest.mark.parametrize("job_type, products", [("selftest", {"selftest.json", "early.json"}),
                                                ("simulate", {"summary.json", "simulated_set.zip"})])
def test_local_run_without_sets(tmp_path, capsys, job_type, products):
    cli_main(["run", job_type, "--quiet", "--out", str(tmp_path / "out")])
    written = {p.name for p in (tmp_path / "out").iterdir()}
    assert products <= written
    for name in written:
        path = tmp_path / "out" / name
        if name.endswith(".json"):
            assert isinstance(json.loads(path.read_text()), dict)
        elif name.endswith(".zip"):
            assert zipfile.ZipFile(path).testzip() is None and zipfile.ZipFile(path).namelist()


def test_unknown_job_type_is_named(tmp_path):
    with pytest.raises(SystemExit) as exc:
        cli_main(["run", "no-such-type", "--quiet", "--out", str(tmp_path)])
    assert "no-such-type" in str(exc.value)


# numpy is allowed: the upload path identifies files (gnssatt.gnss.io.sniff) and parses PCV maps with it
NUMERICS = ("numba", "scipy", "matplotlib")
# allowed: the attitude settings (plain dataclasses, no numerics) the attitude job's config model is generated from,
# and the package that holds them
SETTINGS_ONLY = ("gnssatt.attitude", "gnssatt.attitude.settings")
SCIENCE = ("gnssatt.attitude", "gnssatt.estimation", "gnssatt.calibration", "gnssatt.ttff", "gnssatt.sim",
           "gnssatt.plots")


def test_api_does_not_import_the_numerics():
    code = ("import sys\nfrom fastapi.testclient import TestClient\nfrom app.main import create_app\n"
            "from worker.jobs.registry import job_types\ncreate_app(); job_types()\n"
            f"print(','.join(sorted(m for m in sys.modules if m.split('.')[0] in {NUMERICS!r} "
            f"or (m.startswith({SCIENCE!r}) and m not in {SETTINGS_ONLY!r}))))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO_ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == ""


def _products(out_dir) -> dict:
    """{name: parsed JSON, or the bytes} of every product `gnssatt run` wrote; each JSON product parses."""
    return {p.name: json.loads(p.read_text()) if p.suffix == ".json" else p.read_bytes() for p in out_dir.iterdir()}


def test_local_ttff_on_simulated_starts(tmp_path):
    """`gnssatt run ttff` with three starts simulated on the fly (fan-out run in-process): the Table 5 products
    exist and parse, and every first fix is right and within the set's duration."""
    config = {"simulate": {"count": 3, "seed": 4}, "duration_s": 15.0, "configurations": ["L1"],
              "methods": ["filter", "epoch-constrained"], "single_epoch_step_s": 5.0}
    (tmp_path / "cfg.json").write_text(json.dumps(config))
    cli_main(["run", "ttff", "--quiet", "--config", str(tmp_path / "cfg.json"), "--out", str(tmp_path / "out")])
    products = _products(tmp_path / "out")
    assert {"runs.csv", "runs.json", "summary.json", "table5.html", "table5_filter.csv", "report.html"} <= set(products)
    assert products["summary.json"]["sets"] == 3
    runs = products["runs.json"]["runs"]
    assert len(runs) == 3 * 2 * 2  # sets x baselines x methods, one configuration
    assert not any(r["fix_right"] is False for r in runs)
    ttff_s = [r["ttff_s"] for r in runs if r.get("ttff_s") is not None]
    assert ttff_s and all(0.0 <= t <= config["duration_s"] for t in ttff_s), ttff_s


def test_local_calibration_of_simulated_sets(tmp_path):
    """`gnssatt run calibration --set DIR --set DIR`: two 10-minute benign simulated passes without PCV; the
    products exist and parse, and the calibrated baselines land within 1 mm of the injected ones per axis (the a
    priori is several mm off: seed 000 Table 3 offsets; with PCV and noise off only the L1/L2 PCO difference and two
    passes' worth of geometry are left)."""
    import numpy as np

    from gnssatt.calibration.simulated import simulate_campaign, truth_of

    dirs = simulate_campaign(tmp_path / "sets", 2, 600.0, seed=5,
                             overrides={"noise": False, "multipath": False, "cn0_jitter_db": 0.0, "pcv": False})
    config = {"azimuth_step_deg": 10.0, "elevation_step_deg": 5.0, "min_count": 10}
    (tmp_path / "cfg.json").write_text(json.dumps(config))
    argv = ["run", "calibration", "--quiet", "--config", str(tmp_path / "cfg.json"), "--out", str(tmp_path / "out")]
    # each set as a user would hand it over: the simulator's files without its truth/ folder
    uploads = [shutil.copytree(d, tmp_path / "upload" / d.name, ignore=shutil.ignore_patterns("truth")) for d in dirs]
    cli_main(argv + [a for d in uploads for a in ("--set", str(d))])
    products = _products(tmp_path / "out")
    assert {"baselines.json", "baselines.csv", "residual_statistics.json", "calibration_summary.json",
            "report.html"} <= set(products)
    assert products["calibration_summary.json"]["sets"] == 2
    # each --set its own set (numbered in order), not the first one twice
    assert [s["set"] for s in products["calibration_summary.json"]["per_set"]] == ["set-1", "set-2"]
    truth = truth_of(dirs[0])
    baselines = products["baselines.json"]["baselines"]
    assert len(baselines) == 2
    for b in baselines:
        t = truth["baselines"][(b["from"], b["to"])]
        err_mm = (np.asarray(b["calibrated_m"]) - t["mean_m"]) * 1e3
        assert np.max(np.abs((np.asarray(b["a_priori_m"]) - t["mean_m"]) * 1e3)) > 4.0
        assert np.all(np.abs(err_mm) < 1.0), err_mm
