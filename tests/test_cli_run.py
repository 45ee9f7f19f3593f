"""`gnssatt run` locally (no server): job types that need no input set write their products, which parse; the API
can serve /v1/job-types without the numerics (numba, scipy, matplotlib, the science packages) in its process."""
from __future__ import annotations

import json
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
