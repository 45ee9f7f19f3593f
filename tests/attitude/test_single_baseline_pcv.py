"""PCV maps on a one-baseline platform (issue 21 item 6): the antennas' frame from the baseline and the reference
frame's z axis (gnssatt.attitude.process.single_baseline_attitude_fn), so a single baseline's differential PCV map
applies as on a multi-baseline platform."""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from gnssatt.attitude.process import load_inputs, process, single_baseline_attitude_fn
from gnssatt.attitude.settings import AttitudeSettings
from gnssatt.gnss import rotations as rot
from tests.attitude.conftest import _simulate, set_files
from tests.attitude.test_pcv_correction import PCV_PASS, true_maps


@pytest.fixture(scope="module")
def one_baseline_pcv_pass(tmp_path_factory):
    """The PCV test pass (40 mm p-p PCV per antenna, otherwise clean) with platform.json cut to GPS-2>GPS-0."""
    d = _simulate(tmp_path_factory, "pcv1", "earth-pointing", 11, PCV_PASS)
    plat = json.loads((d / "platform.json").read_text())
    plat["baselines"] = [["GPS-2", "GPS-0"]]
    plat["antennas"] = {k: v for k, v in plat["antennas"].items() if k in ("GPS-2", "GPS-0")}
    plat["observation_files"] = {k: v for k, v in plat["observation_files"].items() if k in ("GPS-2", "GPS-0")}
    (d / "platform.json").write_text(json.dumps(plat))
    (d / "obs" / "GPS-1.rnx").unlink()
    return d


def _direction_errors_deg(d, sol):
    """Angle (deg) between the solution's fixed baselines and the truth's (truth/attitude.csv, body vector)."""
    rows = {r["time_gps"]: r for r in csv.DictReader(open(d / "truth" / "attitude.csv"))}
    bt = sol.baseline_table
    iso = np.asarray(sol.pobs.time.iso(3))[bt["epoch"]]
    q = np.array([[float(rows[t][k]) for k in ("qe_w", "qe_x", "qe_y", "qe_z")] for t in iso])
    b_true = np.einsum("nji,j->ni", rot.quat_to_dcm(q), sol.body_baselines_m[0])     # R^T b_body
    b = bt["b"]
    cos = np.sum(b * b_true, 1) / np.linalg.norm(b, axis=1) / np.linalg.norm(b_true, axis=1)
    return np.degrees(np.arccos(np.clip(cos, -1, 1)))[bt["fixed"]]


def test_a_single_baseline_applies_its_pcv_map(one_baseline_pcv_pass):
    """Without the map the 40 mm p-p PCV tilts the 1 m baseline by ~0.5-1 deg; with the simulator's true map
    (exact: parallel antenna frames) the median direction error drops by >= half and below 0.3 deg."""
    d = one_baseline_pcv_pass
    maps = {k: v for k, v in true_maps(d).items() if k[:2] == ("GPS-2", "GPS-0")}
    assert len(maps) == 2
    inputs = load_inputs(set_files(d))
    err = {}
    for name, st in (("raw", AttitudeSettings.preset("seed000")),
                     ("maps", AttitudeSettings.preset("seed000", calibration={"pcv_maps": maps}))):
        sol = process(inputs, st)
        assert len(sol.baselines) == 1 and sol.baseline_table["fixed"].mean() > 0.9, name
        err[name] = np.median(_direction_errors_deg(d, sol))
    assert err["raw"] > 0.3, err
    assert err["maps"] < 0.5 * err["raw"] and err["maps"] < 0.3, err


def test_single_baseline_attitude_is_level_about_the_baseline():
    """The TRIAD attitude: the baseline exact, the body z axis in the plane of the reference z and the baseline
    (no rotation about the baseline); a vertical baseline gives no attitude function."""
    R_ref = np.eye(3)[None]                       # reference frame = ECEF here, one epoch
    fn = single_baseline_attitude_fn(np.array([1.0, 0.0, 0.0]), R_ref)
    yaw = np.radians(30.0)
    b_ecef = np.array([[np.cos(yaw), np.sin(yaw), 0.0]])
    R = fn(b_ecef, np.array([True]), 0)
    assert np.allclose(R @ b_ecef[0], [1.0, 0.0, 0.0], atol=1e-12)
    assert np.allclose(R @ np.array([0.0, 0.0, 1.0]), [0.0, 0.0, 1.0], atol=1e-12)
    assert single_baseline_attitude_fn(np.array([0.0, 0.0, 1.0]), R_ref) is None
