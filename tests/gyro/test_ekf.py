"""The quaternion EKF (gnssatt.gyro.ekf): the compiled propagation against its numpy specification, the update's
reset and covariance, and a static NEES check with simulated gyro and GPS-attitude noise."""
from __future__ import annotations

import numpy as np

from gnssatt.gnss import rotations as rot
from gnssatt.gyro.ekf import FilterState, NoiseRates, propagate, propagate_reference, update


def _noise():
    return NoiseRates(arw2=(1.9e-5) ** 2, drift_sigma=4.8e-5, drift_tau=1800.0,
                      gm_cov=np.diag([3e-5, 4e-5, 2e-6]), gm_tau=60.0)


def test_kernel_matches_reference():
    rng = np.random.default_rng(2)
    n = 50
    rates = rng.normal(0, 1e-3, (n, 3)) + np.array([0, -1.1e-3, 0])
    dts = np.full(n, 0.1)
    q0 = rot.quat_from_rotvec(rng.normal(0, 1, 3))
    b = np.array([1e-5, -2e-5, 3e-5])
    P0 = np.diag(rng.uniform(1e-6, 1e-4, 9))
    nz = _noise()
    q_k, P_k, Phi, Q = propagate(q0, b, P0, rates, dts, nz.arw2, nz.drift_sigma, nz.drift_tau, nz.gm_cov,
                                 nz.gm_tau, np.empty((n, 4)), np.empty((n, 3, 3)))
    q_r, P_r = propagate_reference(q0, b, P0, rates, dts, nz)
    ang = np.linalg.norm(rot.quat_to_rotvec(rot.quat_multiply(q_k, rot.quat_conjugate(q_r))))
    assert ang < 1e-12                                  # same formula, rounding only: 1e-12 rad
    assert np.allclose(P_k, P_r, rtol=1e-9, atol=1e-18)
    # the interval's transition and noise reproduce the propagated covariance
    assert np.allclose(Phi @ P0 @ Phi.T + Q, P_k, rtol=1e-9, atol=1e-18)


def test_update_resets_and_shrinks():
    q = rot.quat_from_rotvec([0.1, 0.2, 0.3])
    P = np.diag([1e-4] * 3 + [1e-9] * 3 + [1e-6] * 3)
    st = FilterState(q, np.zeros(3), np.zeros(3), P)
    q_gps = rot.quat_multiply(rot.quat_from_rotvec([1e-3, 0, 0]), q)
    st2, z, S = update(st, q_gps, np.eye(3) * 1e-6)
    assert np.allclose(z, [1e-3, 0, 0], atol=1e-9)
    # gain = P_tt / (P_tt + P_bb + R) on the x axis: 1e-4 / (1e-4 + 1e-6 + 1e-6)
    moved = rot.quat_to_rotvec(rot.quat_multiply(st2.q, rot.quat_conjugate(q)))
    assert np.allclose(moved, [1e-3 * 1e-4 / 1.02e-4, 0, 0], atol=1e-9)
    assert np.all(np.diag(st2.P) <= np.diag(P) + 1e-18)
    assert np.allclose(st2.P, st2.P.T)


def test_static_nees_is_consistent():
    """A body at rest in inertial space, gyro with ARW and a constant drift, GPS attitude every 5 s with white
    noise: the filter's attitude errors over 50 runs have unit normalised variance (NEES / 3 in 0.8-1.25)."""
    rng = np.random.default_rng(9)
    nz = NoiseRates(arw2=(1.9e-5) ** 2, drift_sigma=4.8e-5, drift_tau=1800.0, gm_cov=np.eye(3) * 1e-14,
                    gm_tau=60.0)
    R_gps = np.eye(3) * (2e-3) ** 2
    nees = []
    for run in range(50):
        b_true = rng.normal(0, 4.8e-5, 3)
        q_true = rot.quat_from_rotvec(rng.normal(0, 1, 3))
        st = FilterState(rot.quat_multiply(rot.quat_from_rotvec(rng.normal(0, 2e-3, 3)), q_true), np.zeros(3),
                         np.zeros(3), np.diag([4e-6] * 3 + [4.8e-5 ** 2] * 3 + [1e-14] * 3))
        for k in range(60):
            rates = b_true + rng.normal(0, 1.9e-5 / np.sqrt(0.1), (50, 3))
            q, P, _, _ = propagate(st.q, st.bias, st.P, rates, np.full(50, 0.1), nz.arw2, nz.drift_sigma,
                                   nz.drift_tau, nz.gm_cov, nz.gm_tau, np.empty((50, 4)), np.empty((50, 3, 3)))
            st = FilterState(q, st.bias, st.beta_theta, P)
            q_gps = rot.quat_multiply(rot.quat_from_rotvec(rng.normal(0, 2e-3, 3)), q_true)
            st, _, _ = update(st, q_gps, R_gps)
        e = rot.quat_to_rotvec(rot.quat_multiply(st.q, rot.quat_conjugate(q_true)))
        nees.append(e @ np.linalg.solve(st.P[:3, :3], e))
    # 50 runs x 3 dof: NEES/3 has a standard error of sqrt(2/150) = 0.12; 0.65-1.4 is ~3 sigma
    assert 0.65 < np.mean(nees) / 3 < 1.4
