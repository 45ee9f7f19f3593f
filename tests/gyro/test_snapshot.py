"""Snapshot attitude (seed 002 eq. 1-2) and the exclusion bank (sec. 3.1) on synthetic epochs built here from
the plane-wave phase model, independently of the simulator: attitude within its sigma, the cost's chi-square
distribution with (m-1)(n-1)-3 degrees of freedom, the integers, and the isolation of a 0.35-cycle fault (also on
the reference satellite, which needs the change of reference)."""
from __future__ import annotations

import numpy as np
import pytest

from gnssatt.gnss import rotations as rot
from gnssatt.gyro.exclusion_bank import run_bank, threshold
from gnssatt.gyro.snapshot import EpochPhases, fit_attitude, integer_corrected

LAM = 0.19029367
B = np.array([[0.0, 0.6, 0.0], [0.6, 0.0, 0.0]])          # master at the origin (seed 002 sec. 4)
POS = np.vstack([np.zeros(3), B])
SIG = 0.0019 * np.sqrt(2)                                  # white + multipath-like, m


def _epoch(rng, m=8, fault=None):
    R_be = rot.quat_to_dcm(rot.quat_from_rotvec(rng.normal(0, 1.0, 3)))
    up_body = np.array([0, 0, -1.0])                       # boresight
    los_body = []
    while len(los_body) < m:
        v = rng.normal(size=3)
        v /= np.linalg.norm(v)
        if v @ up_body > np.sin(np.radians(20)):
            los_body.append(v)
    e = np.array(los_body) @ R_be                          # ECEF: e_ecef = R_be' e_body
    N = rng.integers(-20, 20, (3, m))
    phase = np.empty((3, m))
    for a in range(3):
        r_ecef = R_be.T @ POS[a]
        phase[a] = -(e @ r_ecef) / LAM + N[a] + rng.normal(0, SIG / LAM, m)
    if fault is not None:
        ant, sat, size = fault
        phase[ant, sat] += size
    ep = EpochPhases(phase, e, np.full(m, 0.0019), np.full(m, 0.0019), [f"G{j:02d}" for j in range(m)], LAM)
    return ep, R_be, N


def _angle_err(R, R_true):
    return rot.quat_to_rotvec(rot.dcm_to_quat(R @ R_true.T))


def test_cost_is_chi_square_and_attitude_within_sigma():
    rng = np.random.default_rng(7)
    Js, z = [], []
    for _ in range(300):
        ep, R_true, N = _epoch(rng)
        prior = rot.quat_to_dcm(rot.quat_from_rotvec(rng.normal(0, np.radians(1.0), 3))) @ R_true
        Z, ratio, Nfix = integer_corrected(ep, B, prior, np.eye(3) * np.radians(1.5) ** 2, 0)
        assert Z is not None
        dd_true = (N[1:] - N[:1]).T                           # SD integers (m, n-1) ...
        assert np.array_equal(Nfix, (dd_true[1:] - dd_true[:1]))  # ... double-differenced against sat 0
        fit = fit_attitude(Z, ep, B, prior, np.arange(8), 0)
        Js.append(fit.J)
        z.append(_angle_err(fit.R_body_from_ecef, R_true) / np.sqrt(np.diag(fit.P_rad2)))
    mu = (8 - 1) * (3 - 1) - 3
    assert fit.dof == mu == 11
    # chi-square(11): mean 11, variance 22; 300 draws give the mean to sqrt(22/300) = 0.27, so 4 sigma
    assert abs(np.mean(Js) - mu) < 4 * np.sqrt(2 * mu / 300)
    assert abs(np.var(Js) - 2 * mu) < 0.35 * 2 * mu        # the variance of 300 draws to ~12 %, so 35 %
    # error / sigma per axis: unit variance, 300 draws -> 8 % on the rms, so 25 %
    assert np.allclose(np.sqrt(np.mean(np.square(z), axis=0)), 1.0, atol=0.25)


@pytest.mark.parametrize("ant, sat", [(1, 3), (0, 5), (2, 0)], ids=["antenna-1", "master", "reference-sat"])
def test_bank_isolates_a_035_cycle_fault(ant, sat):
    rng = np.random.default_rng(11)
    right, ants = 0, []
    for _ in range(30):
        ep, R_true, _ = _epoch(rng, fault=(ant, sat, 0.35))
        prior = R_true                                    # the EKF's prediction (good to well under a degree)
        Z, _, _ = integer_corrected(ep, B, prior, np.eye(3) * np.radians(0.2) ** 2, 0)
        res = run_bank(Z, ep, B, prior, [0, 1, 2], kappa=3.0)
        assert res.detected
        right += res.excluded == sat
        ants.append(res.antenna)
        if res.excluded == sat:
            assert res.fit.J < threshold(res.fit.dof, 3.0)
            # the fault is gone from the chosen fit: its error is noise (4.5 sigma per axis: p ~ 1e-5 each)
            zn = _angle_err(res.fit.R_body_from_ecef, R_true) / np.sqrt(np.diag(res.fit.P_rad2))
            assert np.all(np.abs(zn) < 4.5)
    assert right >= 29                                     # seed 002 target: >= 98 % isolated right
    if sat == 0:
        assert res.ref != 0                               # found only after the change of reference satellite
    assert np.mean(np.array(ants) == ant) >= 0.9


def test_no_fault_no_detection_most_of_the_time():
    rng = np.random.default_rng(5)
    det = 0
    for _ in range(200):
        ep, R_true, _ = _epoch(rng)
        Z, _, _ = integer_corrected(ep, B, R_true, np.eye(3) * np.radians(0.2) ** 2, 0)
        det += run_bank(Z, ep, B, R_true, [0, 1], kappa=3.0).detected
    # chi2 threshold: P(J > J*) = Q(3) = 0.135 % at any dof; 200 epochs: expect 0.27, allow up to 4 (p ~ 2e-4)
    assert det <= 4


def test_threshold_models():
    """"gaussian" is the paper's mu + kappa sqrt(2 mu); "chi2" has the normal kappa-sigma tail at every dof, so
    with few dof it lies above the paper's (whose chi-square tail at kappa = 3 is 0.8-1.1 % for mu = 7-17)."""
    from scipy.stats import chi2, norm

    for mu in (3, 7, 11, 17, 40):
        assert threshold(mu, 3.0, "gaussian") == pytest.approx(mu + 3.0 * np.sqrt(2.0 * mu), rel=1e-12)
        assert chi2.sf(threshold(mu, 3.0), mu) == pytest.approx(norm.sf(3.0), rel=1e-6)
        assert threshold(mu, 3.0) > threshold(mu, 3.0, "gaussian")
        assert chi2.sf(threshold(mu, 3.0, "gaussian"), mu) > 2 * norm.sf(3.0)
    with pytest.raises(ValueError, match="threshold model"):
        threshold(9, 3.0, "student")
