"""The smoother's omega random-walk floor estimated from the data (gnssatt/attitude/process_noise_em.py, setting
`smoother_noise_em_iterations`): the smoothed increments' covariance against the batch posterior of a small linear
model, the covariance-matching iteration recovering a known random-walk rate on a synthetic linear-Gaussian model
(from above and from below), its fixed point being the EM objective's minimum, and a simulated pitch-up pass."""
from __future__ import annotations

import numpy as np
import pytest

from tests.attitude.conftest import CLEAN, _simulate, set_files
from gnssatt.attitude.process import load_inputs, process
from gnssatt.attitude.process_noise_em import em_objective, floor_scale_ratio, omega_increment_moments
from gnssatt.attitude.settings import AttitudeSettings
from gnssatt.attitude.truth import attitude_errors_deg

R_VAR = 1.0                                   # measurement variance per axis (omega measured directly)
BURST = slice(800, 900)                       # epochs where the profile G_k (and the truth) has a manoeuvre


def _profile(n):
    G = np.zeros((n, 3, 3))
    a = np.array([1.0, 0.5, 0.0])
    G[BURST] = 50.0 * np.outer(a, a)          # rank 1, along a (as adaptive_noise_profile's gain part)
    return G


def _simulate_walk(rng, n, q_true, G):
    """omega_k = omega_k-1 + w_k, w_k ~ N(0, q_true I + G_k) (dt = 1 s), measured with variance R_VAR per axis."""
    g, U = np.linalg.eigh(G)
    w = rng.standard_normal((n, 3)) * np.sqrt(q_true)
    w += np.einsum("kab,kb->ka", U, np.sqrt(np.maximum(g, 0.0)) * rng.standard_normal((n, 3)))
    w[0] = 0.0
    return np.cumsum(w, 0) + rng.standard_normal((n, 3)) * np.sqrt(R_VAR)


def _kalman(z, Q, p0=1.0):
    """The forward filter's record (smoother_data layout) of the linear model: x_k = x_k-1 + w_k, z_k = x_k + v_k."""
    n, eye = len(z), np.eye(3)
    rec = {key: np.zeros((n, 3)) for key in ("x_post", "x_prior")}
    rec.update({key: np.zeros((n, 3, 3)) for key in ("P_post", "P_prior")})
    x, P = np.zeros(3), eye * p0
    for k in range(n):
        if k:
            P = P + Q[k]
        rec["x_prior"][k], rec["P_prior"][k] = x, P
        K = P @ np.linalg.inv(P + R_VAR * eye)
        x, P = x + K @ (z[k] - x), (eye - K) @ P
        rec["x_post"][k], rec["P_post"][k] = x, P
    rec["Phi"] = np.repeat(eye[None], n, 0)
    start = np.zeros(n, bool)
    start[0] = True
    return rec, start


def _estimate(z, G, f0):
    """(q estimate, effective links, last floor scale, the moments at it): s <- s r to convergence."""
    s, n = 1.0, len(z)
    for _ in range(40):
        Q = G + s * f0 * np.eye(3)
        rec, start = _kalman(z, Q)
        w, V, k = omega_increment_moments(rec, start, np.ones(n, bool))
        r, n_eff = floor_scale_ratio(w, V, Q[k], np.ones(k.size), s * f0)
        s_new = s * r
        done = abs(np.log(r)) < 1e-4
        s = s_new
        if done:
            break
    return s * f0, n_eff, s, (w, V, Q[k])


def test_increment_covariance_is_the_batch_posterior():
    """V_k (lag-one smoothed covariance, Shumway & Stoffer) against the covariance of omega_k - omega_k-1 in the
    batch (information-form) posterior of the whole trajectory of a 30-epoch model; w^_k against its mean."""
    rng = np.random.default_rng(3)
    n, q = 30, 0.05
    G = np.zeros((n, 3, 3))
    G[10:14] = 0.4 * np.outer([0.0, 1.0, 1.0], [0.0, 1.0, 1.0])
    z = _simulate_walk(rng, n, q, G)
    Q = G + q * np.eye(3)
    rec, start = _kalman(z, Q)
    w, V, k = omega_increment_moments(rec, start, np.ones(n, bool))
    # batch: prior x_0 ~ N(0, I), increments ~ N(0, Q_k), measurements ~ N(x_k, R_VAR I)
    D = np.zeros((3 * n, 3 * n))                               # x -> (x_0, x_1 - x_0, ...)
    W = np.zeros((3 * n, 3 * n))                               # their inverse covariances
    for i in range(n):
        D[3 * i:3 * i + 3, 3 * i:3 * i + 3] = np.eye(3)
        if i:
            D[3 * i:3 * i + 3, 3 * i - 3:3 * i] = -np.eye(3)
        W[3 * i:3 * i + 3, 3 * i:3 * i + 3] = np.linalg.inv(Q[i]) if i else np.eye(3)
    info = D.T @ W @ D + np.eye(3 * n) / R_VAR
    P = np.linalg.inv(info)
    x = P @ (z.reshape(-1) / R_VAR)
    inc_cov = D @ P @ D.T
    assert np.array_equal(k, np.arange(1, n))
    for j, kk in enumerate(k):
        blk = inc_cov[3 * kk:3 * kk + 3, 3 * kk:3 * kk + 3]
        assert np.allclose(V[j], blk, atol=1e-9 * np.abs(blk).max()), kk
        assert np.allclose(w[j], x[3 * kk:3 * kk + 3] - x[3 * kk - 3:3 * kk], atol=1e-9)


@pytest.mark.parametrize("start_factor", [4.0, 0.25])
def test_floor_recovers_a_known_random_walk(start_factor):
    """q_true 0.01 per epoch, measured with variance 1 (each increment poorly observed, as the attitude filter's are),
    2000 epochs with a 100-epoch manoeuvre in the profile: from a floor 4x too high and 4x too low the iteration ends
    within 3 sampling sigmas of the truth. The sampling sigma is 1 / sqrt(effective links): over 20 seeds the
    estimate's relative std was 0.103 with n_eff = 95 (1 / sqrt(95) = 0.103), its mean 1.012 x q_true."""
    q_true, n = 0.01, 2000
    G = _profile(n)
    z = _simulate_walk(np.random.default_rng(11), n, q_true, G)
    q_hat, n_eff, _, _ = _estimate(z, G, start_factor * q_true)
    assert 60 < n_eff < 150, n_eff
    assert abs(q_hat / q_true - 1.0) < 3.0 / np.sqrt(n_eff), (q_hat, n_eff)


def test_matching_fixed_point_is_the_em_minimum():
    """At the converged floor the EM objective (with the E-step of that model) is smallest at s = 1 on a grid of
    +-10 %: the matching condition is the stationarity condition of the maximum-likelihood M-step."""
    n = 2000
    G = _profile(n)
    z = _simulate_walk(np.random.default_rng(5), n, 0.02, G)
    q_hat, _, _, (w, V, Qk) = _estimate(z, G, 0.05)
    grid = np.linspace(0.9, 1.1, 21)
    J = em_objective(grid, w, V, Qk, np.ones(len(w)), q_hat)
    assert abs(grid[int(np.argmin(J))] - 1.0) < 0.011, grid[int(np.argmin(J))]
    assert J[0] > J[10] and J[-1] > J[10]


PITCH_UP = {"start_gps": "2018-06-06T16:31:00", "duration_s": 200.0,
            "waypoints": [[0.0, 0.0, 0.0, 0.0], [60.0, 0.0, 0.0, 0.0], [120.0, 0.0, 50.0, 0.0],
                          [600.0, 0.0, -40.0, 0.0]]}


def test_estimated_floor_on_the_pitch_up():
    """seed 000 Fig. 6's pitch-up (200 s, clean): the estimate is recorded in summary.json, stays within its bounds,
    no fix is lost and the max error after 30 s of fix stays below 0.3 deg (0.26 deg with the configured floor,
    tests/attitude/test_smoother.py)."""
    import tempfile
    from pathlib import Path

    class _Factory:                                            # _simulate's tmp_path_factory, without the fixture
        def __init__(self, root):
            self.root = Path(root)

        def mktemp(self, name):
            p = self.root / name
            p.mkdir()
            return p

    with tempfile.TemporaryDirectory() as tmp:
        d = _simulate(_Factory(tmp), "pitch_up_em", "slew", 0, {**PITCH_UP, **CLEAN})
        inputs = load_inputs(set_files(d))
        sol = process(inputs, AttitudeSettings.preset("all-phases", mode="dynamic",
                                                      smoothing={"adaptive_noise": True, "noise_em_iterations": 2}))
        ang, _ = attitude_errors_deg(d, sol)
    em = sol.summary["smoother"]["process_noise"]["noise_em"]
    lo, hi = em["bounds"]
    assert lo <= em["floor_scale"] <= hi and 1 <= len(em["iterations"]) <= 3
    assert all(np.isfinite(h["ratio"]) and h["effective_links"] > 0 for h in em["iterations"])
    assert "fix_lost" not in sol.summary["events"]
    f = sol.att_fixed
    t = np.asarray(sol.pobs.time - sol.pobs.time[0], float)[sol.att_epochs]
    late = f & (t > t[int(np.argmax(f))] + 30.0)
    assert ang[late].max() < 0.3, ang[late].max()


def test_floor_moves_only_where_the_data_reject_it():
    """2 sampling sigmas (1 / sqrt(n_eff) in log) and at least MIN_EFFECTIVE_LINKS: a ratio of 0.45 from 6 effective
    links (the acceleration state's slews) is no evidence, from 400 (the clean pass) it is."""
    from gnssatt.attitude.process_noise_em import MIN_EFFECTIVE_LINKS, _significant

    assert not _significant(0.45, 6.0) and MIN_EFFECTIVE_LINKS > 6.0
    assert _significant(0.45, 400.0) and _significant(0.19, 12.0)
    assert not _significant(0.92, 400.0)          # |log 0.92| = 0.083 < 2 / 20
    assert _significant(0.88, 400.0)
