"""The multi-antenna simulator's option windup_antenna (gnssatt/sim/vector_windup.py): default output unchanged,
the ideal RHCP antenna reproducing today's Wu wind-up exactly, and a real antenna's wind-up cancelling in single
differences between identical, aligned antennas (issue 20 item 3)."""
import csv

import numpy as np

from gnssatt.sim import simulate_set


def _windup(truth_dir, antenna):
    rows = list(csv.DictReader(open(truth_dir / f"observations_{antenna}.csv")))
    return {(r["time_gps"], r["sat"]): float(r["windup_cyc"]) for r in rows}


def _sd(truth_dir, first, second):
    a, b = _windup(truth_dir, first), _windup(truth_dir, second)
    keys = sorted(set(a) & set(b))
    return np.array([b[k] - a[k] for k in keys]), keys


def test_ideal_rhcp_option_writes_the_same_files_as_the_default(tmp_path):
    base = simulate_set("earth-pointing", tmp_path / "a", duration_s=40.0)
    rhcp = simulate_set("earth-pointing", tmp_path / "b", duration_s=40.0, windup_antenna={"model": "rhcp-patch"})
    for ant, path in base.obs.items():
        assert path.read_bytes() == rhcp.obs[ant].read_bytes(), ant      # RINEX phases to the written 1e-3 cycle
    w_base, w_rhcp = _windup(base.truth_dir, "GPS-0"), _windup(rhcp.truth_dir, "GPS-0")
    assert max(abs(w_base[k] - w_rhcp[k]) for k in w_base) < 1e-6        # the truth's wind-up column


def test_real_antenna_windup_cancels_in_single_differences(tmp_path):
    base = simulate_set("earth-pointing", tmp_path / "a", duration_s=120.0)
    real = simulate_set("earth-pointing", tmp_path / "b", duration_s=120.0,
                        windup_antenna={"model": "asymmetric-patch", "asymmetry": 0.3, "harmonic": 2})
    w_base, w_real = _windup(base.truth_dir, "GPS-2"), _windup(real.truth_dir, "GPS-2")
    diff = np.array([w_real[k] - w_base[k] for k in w_base])
    diff -= np.round(np.median(diff))
    assert np.max(np.abs(diff)) > 0.01          # the real antenna's wind-up is not Wu's (0.01 cycle = 2 mm)
    for second in ("GPS-0", "GPS-1"):
        sd_real, _ = _sd(real.truth_dir, "GPS-2", second)
        sd_base, _ = _sd(base.truth_dir, "GPS-2", second)
        # identical antennas, one boresight: only the ~1 m baseline's parallax of the line of sight (1e-7 rad)
        # separates them, so the single difference keeps < 1e-5 cycles (2 um) of either wind-up
        assert np.max(np.abs(sd_real - np.round(sd_real))) < 1e-5
        assert np.max(np.abs(sd_base - np.round(sd_base))) < 1e-5
