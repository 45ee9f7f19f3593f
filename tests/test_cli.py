"""The `gnssatt` command: simulate, and the client's errors when no key is given."""
from __future__ import annotations

import subprocess
import sys

from tests.conftest import REPO_ROOT


def gnssatt(*args, env=None):
    return subprocess.run([sys.executable, "-m", "client.cli", *args], cwd=REPO_ROOT, capture_output=True,
                          text=True, timeout=120, env=env)


def test_simulate_writes_a_set_and_takes_overrides(tmp_path):
    out = gnssatt("simulate", "--scenario", "cubesat", "--duration-s", "20", "--seed", "7",
                  "--set", "interval_s=2", "--out", str(tmp_path / "s"))
    assert out.returncode == 0, out.stderr
    obs = sorted((tmp_path / "s" / "obs").glob("*.rnx"))
    assert [p.name for p in obs] == ["ANT-A.rnx", "ANT-B.rnx", "ANT-C.rnx"]
    assert "     2.000" in obs[0].read_text().split("END OF HEADER")[0]  # INTERVAL overridden
    again = gnssatt("simulate", "--scenario", "cubesat", "--duration-s", "20", "--seed", "7",
                    "--set", "interval_s=2", "--out", str(tmp_path / "t"))
    assert again.returncode == 0
    assert (tmp_path / "t" / "obs" / "ANT-A.rnx").read_bytes() == obs[0].read_bytes()


def test_simulate_refuses_unknown_parameter(tmp_path):
    out = gnssatt("simulate", "--scenario", "slew", "--set", "warp_factor=9", "--out", str(tmp_path / "s"))
    assert out.returncode != 0 and "warp_factor" in out.stderr


def test_client_commands_need_a_key(tmp_path):
    import os
    env = {k: v for k, v in os.environ.items() if k not in ("GNSSATT_API_KEY",)}
    out = gnssatt("status", "--url", "http://127.0.0.1:9", env=env)
    assert out.returncode != 0 and "GNSSATT_API_KEY" in out.stderr
