"""Issue 24 first run, the CLI: one clear line for connection and auth errors, job type and config checked before
any upload, unique id prefixes accepted, `submit` ending with the quality summary. The client talks to the real
app in-process (TestClient's transport) with an immediate queue, so a job runs inside the submit call."""
from __future__ import annotations

import json
import subprocess
import sys

from core.models import ApiKey, Job
from tests.client.conftest import run_cli
from tests.conftest import REPO_ROOT


def test_unreachable_server_is_one_line():
    out = subprocess.run([sys.executable, "-m", "client.cli", "status", "--url", "http://127.0.0.1:9", "--key", "k"],
                         cwd=REPO_ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 1
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "cannot connect to the service at http://127.0.0.1:9" in lines[0], out.stderr


def test_refused_key_is_one_line(service, capsys):
    code, _, err = run_cli(capsys, "status", "--key", "not-a-key")
    assert code == 1 and len(err.strip().splitlines()) == 1 and "refused the API key (401" in err, err


def test_type_and_config_checked_before_upload(service, capsys, tmp_path):
    f = tmp_path / "a.rnx"
    f.write_text("not uploaded\n")
    code, _, err = run_cli(capsys, "submit", "--key", service.key, "--type", "attitud", str(f))
    assert code != 0 and "unknown job type 'attitud'" in err and "attitude" in err
    cfg = tmp_path / "cfg.json"
    cfg.write_text(json.dumps({"mode": "sideways"}))
    code, _, err = run_cli(capsys, "submit", "--key", service.key, "--type", "attitude", "--config", str(cfg), str(f))
    assert code != 0 and "config refused before upload (field config.mode)" in err, err
    cfg.write_text("{\n  \"mode\": kinematic\n}")
    code, _, err = run_cli(capsys, "submit", "--key", service.key, "--type", "attitude", "--config", str(cfg), str(f))
    assert code != 0 and "line 2, column" in err
    assert service.get("/v1/observation-sets").json()["total"] == 0, "nothing may be uploaded"
    with service.rt.Session() as s:
        assert s.query(Job).count() == 0


def test_unique_prefix_accepted_ambiguous_refused(service, capsys):
    with service.rt.Session.begin() as s:
        team_id = s.query(ApiKey).first().team_id
        for i in (1, 2):
            s.add(Job(id=f"abcd{i}" + "0" * 27, team_id=team_id, type="inspect", state="succeeded",
                      config={}, set_ids=[]))
    code, out, _ = run_cli(capsys, "status", "--key", service.key, "abcd1")
    assert code == 0 and json.loads(out)["id"] == "abcd1" + "0" * 27
    code, _, err = run_cli(capsys, "status", "--key", service.key, "abcd")
    assert code != 0 and "ambiguous" in err
    code, _, err = run_cli(capsys, "status", "--key", service.key, "ffff")
    assert code != 0 and "no job of your team" in err


def test_submit_ends_with_the_quality_summary(service, capsys, tmp_path):
    from gnssatt.sim import simulate_scenario

    d = tmp_path / "sim"
    simulate_scenario("earth-pointing", d, overrides={"duration_s": 120})
    files = [str(p) for p in sorted(d.rglob("*")) if p.is_file() and "truth" not in p.relative_to(d).parts]
    code, out, err = run_cli(capsys, "submit", "--key", service.key, "--type", "attitude", "--out",
                             str(tmp_path / "products"), *files)
    assert code == 0, err
    lines = out.strip().splitlines()
    at = next(i for i, l in enumerate(lines) if l.startswith("quality: "))
    summary = json.loads((tmp_path / "products" / "summary.json").read_text())
    assert lines[at] == f"quality: {summary['quality']['verdict'].upper()}"
    assert len(lines) - at - 1 == len(summary["quality"]["items"])
    assert any("fix rate" in l and "%" in l for l in lines[at:])
