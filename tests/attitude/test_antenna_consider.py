"""The antennas' consider covariance (gnssatt.attitude.antenna_consider): its attitude term against an independent
Monte Carlo of QUEST with perturbed phase-centre baselines, where it applies and vanishes, the declared fields of
platform.json, and its constants against the simulator's PCV pattern family."""
from __future__ import annotations

import json

import numpy as np
import pytest

from gnssatt.attitude.antenna_consider import (DEFAULT_PCO_SIGMA_MM, DEFAULT_PCV_RMS_MM, KAPPA_H, KAPPA_V,
                                               baseline_consider_body_m2, consider_theta_rad2)
from gnssatt.attitude.settings import AntennaCalibration
from gnssatt.gnss import rotations as rot
from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.platform import parse_platform

SIGNALS = ["G:L1", "G:L2"]


def _platform(**unc) -> object:
    ants = {"A": [0.0, 0.0, 0.0], "B": [1.04653, -0.07191, 0.0], "C": [0.0, 1.13969, 0.0]}
    doc = {"name": "t", "antennas": {k: {"position_m": v, "boresight": [0, 0, -1], **unc} for k, v in ants.items()},
           "master": "A"}
    return parse_platform(json.dumps(doc))


def _body(plat) -> np.ndarray:
    return np.array([plat.baseline_body_m(a, b) for a, b in plat.baselines])


def _blk(C, j, k=None):
    k = j if k is None else k
    return C[3 * j:3 * j + 3, 3 * k:3 * k + 3]


def test_attitude_term_matches_monte_carlo_of_perturbed_antennas():
    """G (R^T C R) G^T against the scatter of QUEST attitudes solved with the assumed body baselines from
    observations of phase-centre baselines made of independently perturbed ANTENNAS (A is in both baselines, so its
    error enters both: 4000 draws, the variances within 10 %, 2.2 % MC sigma)."""
    from gnssatt.attitude.antenna_consider import _antenna_body_m2

    plat = _platform(pco_sigma_mm=1.5, pcv_rms_mm={"L1": 2.0, "L2": 2.6})
    C, _ = baseline_consider_body_m2(plat, plat.baselines, SIGNALS)
    body = _body(plat)
    rng = np.random.default_rng(3)
    q_true = rot.quat_normalize(rng.normal(size=4))
    R = rot.quat_to_dcm(q_true)                                   # body <- ecef
    b_ecef = (R.T @ body.T).T[None]
    P = consider_theta_rad2(q_true[None], b_ecef, C, body)[0]
    n = 4000
    e = {name: rng.multivariate_normal(np.zeros(3), _antenna_body_m2(ant, SIGNALS, True), n)
         for name, ant in plat.antennas.items()}                  # (n, 3) per antenna, body frame
    d = np.stack([e[b] - e[a] for a, b in plat.baselines], 1)     # (n, n_bl, 3)
    np.testing.assert_allclose(np.cov(d.reshape(n, -1).T), C, atol=0.08 * C.max())   # the cross blocks too
    obs = np.einsum("ij,nbj->nbi", R.T, body[None] + d)
    w = np.linalg.norm(body, axis=1) / np.linalg.norm(body, axis=1).sum()
    q, _ = rot.quest(np.broadcast_to(body, obs.shape), obs, np.broadcast_to(w, (n, len(body))))
    E = rot.quat_to_dcm(q) @ R.T                                  # (I - [theta x]) to first order
    th = 0.5 * np.stack([E[:, 1, 2] - E[:, 2, 1], E[:, 2, 0] - E[:, 0, 2], E[:, 0, 1] - E[:, 1, 0]], -1)
    emp = np.cov(th.T)
    np.testing.assert_allclose(np.diag(emp), np.diag(P), rtol=0.10)
    # the size: a tilt sigma ~ the vertical phase-centre sigma over the baseline length (~0.2 deg here)
    sig_v = np.sqrt(C[2, 2])
    assert 0.5 < np.degrees(np.sqrt(P[1, 1])) / np.degrees(sig_v / np.linalg.norm(body[0])) < 2.0


def test_baselines_sharing_an_antenna_share_its_term_with_its_sign():
    """A>B and A>C share A: their cross block is +C_A (A first in both); B>C against A>B shares B with opposite
    places: -C_B; A>B and a disjoint baseline: zero."""
    from gnssatt.attitude.antenna_consider import _antenna_body_m2

    plat = _platform(pco_sigma_mm=1.5, pcv_rms_mm=2.0)
    C_a = _antenna_body_m2(plat.antennas["A"], SIGNALS, True)
    C, _ = baseline_consider_body_m2(plat, [("A", "B"), ("A", "C")], SIGNALS)
    np.testing.assert_allclose(_blk(C, 0, 1), C_a, rtol=1e-12)
    np.testing.assert_allclose(_blk(C, 0), 2 * C_a, rtol=1e-12)        # A and B alike here
    C, _ = baseline_consider_body_m2(plat, [("A", "B"), ("B", "C")], SIGNALS)
    np.testing.assert_allclose(_blk(C, 0, 1), -_antenna_body_m2(plat.antennas["B"], SIGNALS, True), rtol=1e-12)
    assert np.all(np.linalg.eigvalsh(C) > -1e-18)                        # a covariance


def test_body_covariance_from_the_declared_spec():
    """Two antennas, two independent equally weighted signals: (2 antennas) x (pco^2 + (kappa pcv)^2) summed over
    the signals / 2^2, horizontal and vertical."""
    plat = _platform(pco_sigma_mm=1.5, pcv_rms_mm={"L1": 2.0, "L2": 2.6})
    C, info = baseline_consider_body_m2(plat, plat.baselines, SIGNALS)
    h = 2 * sum(1.5 ** 2 + (KAPPA_H * p) ** 2 for p in (2.0, 2.6)) / 4
    v = 2 * sum(1.5 ** 2 + (KAPPA_V * p) ** 2 for p in (2.0, 2.6)) / 4
    np.testing.assert_allclose(np.diag(_blk(C, 0)) * 1e6, [h, h, v], rtol=1e-12)
    assert info["defaults_applied_to"] == []


def test_vanishes_with_a_calibrated_baseline_and_keeps_only_offsets_with_a_pcv_map():
    plat = _platform(pco_sigma_mm=1.5, pcv_rms_mm=2.0)
    full, _ = baseline_consider_body_m2(plat, plat.baselines, SIGNALS)
    a, b = plat.baselines[0]
    cal = AntennaCalibration(calibrated_baselines={(a, b): [1.0, 0.0, 0.0]})
    C, info = baseline_consider_body_m2(plat, plat.baselines, SIGNALS, cal)
    assert np.all(C[:3] == 0) and np.all(C[:, :3] == 0), info["removed"]
    assert np.array_equal(_blk(C, 1), _blk(full, 1))
    maps = AntennaCalibration(pcv_maps={(a, b, "L1"): {}})
    C, _ = baseline_consider_body_m2(plat, plat.baselines, SIGNALS, maps)
    np.testing.assert_allclose(np.diag(_blk(C, 0)) * 1e6, [2 * 2 * 1.5 ** 2 / 4] * 3, rtol=1e-12)
    np.testing.assert_allclose(np.diag(_blk(C, 0, 1)) * 1e6, [2 * 1.5 ** 2 / 4] * 3, rtol=1e-12)  # shared A: offsets
    # declared zero (a clean simulated set): no term
    C, _ = baseline_consider_body_m2(_platform(pco_sigma_mm=0.0, pcv_rms_mm=0.0), plat.baselines, SIGNALS)
    assert np.all(C == 0)


def test_default_applies_where_nothing_is_declared():
    plat = _platform()
    C, info = baseline_consider_body_m2(plat, plat.baselines, ["G:L1"])
    v = 2 * (DEFAULT_PCO_SIGMA_MM ** 2 + (KAPPA_V * DEFAULT_PCV_RMS_MM) ** 2)
    np.testing.assert_allclose(C[2, 2] * 1e6, v, rtol=1e-12)
    assert sorted(info["defaults_applied_to"]) == ["A", "B", "C"]


@pytest.mark.parametrize("bad", [-1.0, "2", {"L1": -0.5}, {}])
def test_platform_rejects_a_bad_declared_sigma(bad):
    with pytest.raises(ParseError, match="pcv_rms_mm"):
        _platform(pcv_rms_mm=bad)


def test_constants_against_the_simulator_pattern_family():
    """KAPPA_H / V and PCV_RMS_PER_PEAK_TO_PEAK re-drawn from gnssatt.sim.observables.pcv_grid_mm (1500 patterns:
    within 5 %, the MC sigma of a std ~2 %): the offset-like part of the pattern over the sky above 10 deg."""
    from gnssatt.sim import observables as ob

    E, A = np.meshgrid(np.radians(ob.PCV_EL_DEG), np.radians(ob.PCV_AZ_DEG), indexing="ij")
    up, m = E >= 0, E >= np.radians(10.0)
    w = np.cos(E)
    H = np.stack([np.ones_like(E), np.cos(E) * np.cos(A), np.cos(E) * np.sin(A), np.sin(E)], -1)[m]
    sw = np.sqrt(w[m])
    rng = np.random.default_rng(7)
    rms, off = [], []
    for _ in range(1500):
        g = ob.pcv_grid_mm(rng, 10.0)
        mean = np.average(g[up], weights=w[up])
        rms.append(np.sqrt(np.average((g[up] - mean) ** 2, weights=w[up])))
        off.append(np.linalg.lstsq(H * sw[:, None], g[m] * sw, rcond=None)[0][1:])
    r = np.sqrt(np.mean(np.square(rms)))
    s = np.array(off).std(0) / r
    assert abs(r / 10.0 / ob.PCV_RMS_PER_PEAK_TO_PEAK - 1) < 0.05
    assert abs(0.5 * (s[0] + s[1]) / KAPPA_H - 1) < 0.05 and abs(s[2] / KAPPA_V - 1) < 0.05, s


def test_process_adds_the_term_and_moves_no_estimate(realistic_pass, tmp_path):
    """The realistic pass as simulated (declared PCO / PCV) against the same files declaring 0: identical
    quaternions and fixes, larger tilt sigmas by the reported term (variances add), summary.json entries."""
    import shutil

    from gnssatt.attitude.process import load_inputs, process
    from gnssatt.attitude.settings import AttitudeSettings

    from .conftest import set_files

    zero = tmp_path / "zero"
    shutil.copytree(realistic_pass, zero)
    pj = json.loads((zero / "platform.json").read_text())
    for a in pj["antennas"].values():
        a["pco_sigma_mm"], a["pcv_rms_mm"] = 0.0, 0.0
    (zero / "platform.json").write_text(json.dumps(pj))
    st = AttitudeSettings.preset("seed000", mode="dynamic", smoother=True)
    sol = process(load_inputs(set_files(realistic_pass)), st)
    sol0 = process(load_inputs(set_files(zero)), st)
    assert np.array_equal(sol.q_body_from_ecef, sol0.q_body_from_ecef)
    assert np.array_equal(sol.att_fixed, sol0.att_fixed)
    f = sol.att_fixed
    np.testing.assert_allclose(sol.sigma_euler_deg[f] ** 2,
                               sol0.sigma_euler_deg[f] ** 2 + sol.sigma_consider_euler_deg[f] ** 2, rtol=1e-6)
    assert np.all(sol0.sigma_consider_euler_deg == 0)
    med = sol.summary["antenna_consider"]["attitude_sigma_deg_median"]
    assert sol.summary["smoother"]["covariance"]["antenna_consider_deg"] == med
    # pco 1.5 mm, pcv 2.1 / 2.7 mm on ~1.1 m baselines: vertical ~3.6 mm differential -> ~0.2 deg of tilt
    assert 0.1 < med[1] < 0.3 and 0.1 < med[2] < 0.3, med


def test_simulated_platform_declares_what_the_simulator_hides(tmp_path):
    """The calibration preset shifts GPS-0 and GPS-1 by seed 000 Table 3's offsets (8-10 mm); its platform.json
    must declare a phase-centre sigma that covers them (per axis: sqrt(scatter^2 + the offset's mean square)), or
    the consider term understates the attitude's error on such a set; GPS-2 (no offset) keeps the bare scatter."""
    from gnssatt.sim import simulate_scenario
    from gnssatt.sim.scenarios import CASSIOPE_TABLE3_OFFSETS_MM, make_params

    p = make_params("calibration", {"duration_s": 60.0, "count": 1})
    simulate_scenario("calibration", tmp_path / "cal", overrides={"duration_s": 60.0, "count": 1})
    doc = json.loads(next((tmp_path / "cal").rglob("platform.json")).read_text())
    scatter = float(p.pco_scatter_mm) if p.pco else 0.0
    for name, off in CASSIOPE_TABLE3_OFFSETS_MM.items():
        want = np.sqrt(scatter ** 2 + np.mean(np.square(off)))
        assert doc["antennas"][name]["pco_sigma_mm"] == pytest.approx(want, abs=1e-3), name
    assert doc["antennas"]["GPS-0"]["pco_sigma_mm"] > 5.0        # 2.10 / -7.86 / -5.68 mm: 5.7 mm RMS per axis
