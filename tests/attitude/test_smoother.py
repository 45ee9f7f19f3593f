"""Fixed-interval smoother of the dynamic mode (gnssatt/attitude/smoother.py, setting `smoother`): the RTS recursion
against the batch least-squares solution of the same linear model, and on seed 000 Fig. 6's pitch manoeuvre
(clean simulated pass with the pitch-up of 50 deg in one minute) against the forward filter and the truth. The
adaptive process noise (`smoother_adaptive_noise`): the second forward pass with Table 1's noise reproduces the first,
the noise estimate on a synthetic angular velocity, and the pitch-up."""
from __future__ import annotations

import numpy as np
import pytest

from tests.attitude.conftest import CLEAN, _simulate, set_files
from gnssatt.attitude.truth import attitude_errors_deg, lag_deg
from gnssatt.attitude.process import load_inputs, process
from gnssatt.attitude.settings import AttitudeSettings
from gnssatt.attitude.smoother import acceleration_noise_rate, rts_smooth


def _cv_model(n, dt, q, r, rng):
    """Constant-velocity track (position, velocity) with white acceleration q and position measurements r."""
    Phi = np.array([[1.0, dt], [0.0, 1.0]])
    Q = q * np.array([[dt ** 3 / 3, dt ** 2 / 2], [dt ** 2 / 2, dt]])
    x = np.zeros((n, 2))
    x[0] = [0.0, 1.0]
    for k in range(1, n):
        x[k] = Phi @ x[k - 1] + rng.multivariate_normal(np.zeros(2), Q)
    z = x[:, 0] + rng.normal(0.0, np.sqrt(r), n)
    return Phi, Q, z


def test_rts_equals_batch_least_squares_of_the_whole_interval():
    rng = np.random.default_rng(7)
    n, dt, q, r = 60, 1.0, 0.05, 0.3
    Phi, Q, z = _cv_model(n, dt, q, r, rng)
    P0 = np.diag([100.0, 10.0])
    H = np.array([1.0, 0.0])
    xf, Pf, xp, Pp = np.zeros((n, 2)), np.zeros((n, 2, 2)), np.zeros((n, 2)), np.zeros((n, 2, 2))
    x, P = np.zeros(2), P0.copy()
    for k in range(n):
        if k:
            x, P = Phi @ x, Phi @ P @ Phi.T + Q
        xp[k], Pp[k] = x, P
        K = P @ H / (H @ P @ H + r)
        x = x + K * (z[k] - H @ x)
        P = P - np.outer(K, H @ P)
        xf[k], Pf[k] = x, P
    start = np.zeros(n, bool)
    start[0] = True
    xs, Ps = rts_smooth(xf, Pf, xp, Pp, np.repeat(Phi[None], n, 0), start)
    # independent: the batch (information-form) solution of x_0..x_n-1 given prior, dynamics and all measurements
    m = 2 * n
    A = np.zeros((m, m))
    b = np.zeros(m)
    A[0:2, 0:2] += np.linalg.inv(P0)
    Qi = np.linalg.inv(Q)
    for k in range(n):
        A[2 * k, 2 * k] += 1.0 / r
        b[2 * k] += z[k] / r
        if k:
            G = np.zeros((2, m))
            G[:, 2 * k:2 * k + 2] = np.eye(2)
            G[:, 2 * k - 2:2 * k] = -Phi
            A += G.T @ Qi @ G
    cov = np.linalg.inv(A)
    x_batch = cov @ b
    assert np.allclose(xs.ravel(), x_batch, atol=1e-8)
    assert np.allclose(Ps, np.array([cov[2 * k:2 * k + 2, 2 * k:2 * k + 2] for k in range(n)]), atol=1e-8)
    assert np.allclose(xs[-1], xf[-1]) and np.all(Ps[:, 0, 0] <= Pf[:, 0, 0] + 1e-12)


def test_rts_does_not_link_across_a_segment_start():
    rng = np.random.default_rng(1)
    n = 20
    xf = rng.normal(size=(n, 2))
    Pf = np.repeat(np.eye(2)[None], n, 0)
    xp = xf + 0.5
    Pp = 2.0 * Pf
    Phi = np.repeat(np.eye(2)[None], n, 0)
    start = np.zeros(n, bool)
    start[[0, 10]] = True
    xs, _ = rts_smooth(xf, Pf, xp, Pp, Phi, start)
    assert np.allclose(xs[9], xf[9]) and np.allclose(xs[19], xf[19])       # last epoch of each segment
    assert not np.allclose(xs[8], xf[8])
    # the first segment does not see the second one's data
    xf2 = xf.copy()
    xf2[10:] += 5.0
    xs2, _ = rts_smooth(xf2, Pf, xp, Pp, Phi, start)
    assert np.allclose(xs2[:10], xs[:10])


#: seed 000 Fig. 6 (bottom): Earth pointing, pitch 0 -> 50 deg in one minute (t = 60-120 s), then slowly back (the
#: paper's return to -40 deg takes minutes); 200 s keeps the test short
PITCH_UP = {"start_gps": "2018-06-06T16:31:00", "duration_s": 200.0,
            "waypoints": [[0.0, 0.0, 0.0, 0.0], [60.0, 0.0, 0.0, 0.0], [120.0, 0.0, 50.0, 0.0],
                          [600.0, 0.0, -40.0, 0.0]]}


@pytest.fixture(scope="module")
def pitch_up(tmp_path_factory):
    d = _simulate(tmp_path_factory, "pitch_up", "slew", 0, {**PITCH_UP, **CLEAN})
    inputs = load_inputs(set_files(d))
    sols = {sm: process(inputs, AttitudeSettings.preset("all-phases", mode="dynamic", smoothing={"enabled": sm})) for sm in (False, True)}
    sols["adaptive"] = process(inputs, AttitudeSettings.preset("all-phases", mode="dynamic", smoothing={"adaptive_noise": True}))
    return d, sols


def test_smoother_removes_the_lag_of_the_pitch_up(pitch_up):
    d, sols = pitch_up
    out = {}
    for sm, sol in sols.items():
        if sm == "adaptive":
            continue
        ang, _ = attitude_errors_deg(d, sol)
        f = sol.att_fixed
        t = np.asarray(sol.pobs.time - sol.pobs.time[0], float)[sol.att_epochs]
        t0 = t[int(np.argmax(f))]
        assert f[int(np.argmax(f)):].mean() > 0.99 and "fix_lost" not in sol.summary["events"]
        late = f & (t > t0 + 30.0)
        out[sm] = ang[late].max(), lag_deg(d, sol, t0 + 30.0), sol
    (max_f, lag_f, _), (max_s, lag_s, sol_s) = out[False], out[True]
    # the forward filter with Table 1's random walk lags the pitch-up (the paper: up to 1 deg)
    assert lag_f > 0.4 and max_f > 0.6, (lag_f, max_f)
    # the smoother: lag and maximum error after convergence (measured 0.19 / 0.24 deg on this pass with the rigid
    # update, the default, forward filter 0.70 / 0.86 deg; `baseline_update: additive` 0.26 / 0.31 and 0.64 / 0.83:
    # the rigid forward filter's higher lag peak at the onset, docs/attitude.md "Known limits")
    assert lag_s < 0.5 * lag_f and max_s < 0.4, (lag_s, max_s)
    # its sigmas are not optimistic after convergence: std(error / sigma) per angle not above 1.2 (measured
    # 0.58 / 0.78 / 0.54: conservative, as the forward filter's on white-noise data, because the multipath model's
    # share is kept at its filtered value; the forward filter's pitch 1.62 with its lag)
    _, de = attitude_errors_deg(d, sol_s)
    t = np.asarray(sol_s.pobs.time - sol_s.pobs.time[0], float)[sol_s.att_epochs]
    late = sol_s.att_fixed & (t > t[int(np.argmax(sol_s.att_fixed))] + 30.0)
    z = (de / sol_s.sigma_euler_deg)[late]
    assert np.all(z.std(axis=0) < 1.2), z.std(axis=0)


def test_smoother_changes_nothing_but_the_baselines_omega_and_their_covariance(pitch_up):
    _, sols = pitch_up
    a, b = sols[False].fr, sols[True].fr
    assert AttitudeSettings().smoothing.enabled is False and a.smoother_data is None
    assert "smoother" not in sols[False].summary
    assert sols[True].summary["smoother"]["epochs_smoothed"] == int((np.linalg.norm(
        a.b_ecef_m - b.b_ecef_m, axis=-1).max(axis=1) > 0).sum())
    assert np.array_equal(a.fixed, b.fixed) and np.array_equal(a.ok, b.ok) and a.events == b.events
    f = a.fixed.all(axis=1)
    moved = np.linalg.norm(a.b_ecef_m - b.b_ecef_m, axis=-1).max(axis=1)
    assert np.all(moved[~f] == 0.0) and moved[f].max() > 1e-4      # float epochs as filtered
    last = int(np.flatnonzero(f)[-1])
    assert moved[last] == 0.0                                       # the last epoch: nothing later to use


def test_job_config_passes_the_smoother_setting():
    from worker.jobs.attitude import AttitudeConfig

    assert AttitudeConfig.model_validate({"smoother": True}).to_settings().smoothing.enabled is True
    assert AttitudeConfig.model_validate({}).to_settings().smoothing.enabled is False
    assert AttitudeConfig.model_validate({"smoother_adaptive_noise": True}).to_settings().smoothing.adaptive_noise
    assert AttitudeConfig.model_validate({}).to_settings().smoothing.adaptive_noise is False


def test_second_pass_with_table1_noise_reproduces_the_first(pitch_up, monkeypatch):
    """run_filter's per-epoch q_omega set to Table 1's rate everywhere is the default run, bit for bit (the second
    pass of smoother_adaptive_noise differs from the first only by its noise)."""
    import gnssatt.attitude.process as P

    d, _ = pitch_up
    calls = []
    orig = P.run_filter

    def spy(*a, **k):
        calls.append((a, k))
        return orig(*a, **k)

    monkeypatch.setattr(P, "run_filter", spy)
    P.process(load_inputs(set_files(d)), AttitudeSettings.preset("all-phases", mode="dynamic", smoothing={"enabled": True}))
    (args, kw), = calls
    a = orig(*args, **kw)
    n = a.fixed.shape[0]
    q1 = a.smoother_data["q_omega"]
    b = orig(*args, **kw, q_omega=np.repeat((q1 * np.eye(3))[None], n, 0))
    for name in ("ok", "b_ecef_m", "P_b_m2", "fixed", "n_sats", "ratio", "omega_ecef_rad_s"):
        assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name
    assert a.events == b.events
    assert all(np.array_equal(a.fix_log[c], b.fix_log[c]) for c in a.fix_log)
    assert all(np.array_equal(a.residuals[c], b.residuals[c], equal_nan=True) for c in a.residuals)
    for c in ("x_post", "P_post", "x_prior", "P_prior", "Phi"):
        assert np.array_equal(a.smoother_data[c], b.smoother_data[c], equal_nan=True), c
    # ... and another rate changes the run
    c = orig(*args, **kw, q_omega=np.repeat((0.1 * q1 * np.eye(3))[None], n, 0))
    assert np.nanmax(np.abs(c.b_ecef_m - a.b_ecef_m)) > 1e-5


def test_noise_rate_is_raised_around_an_angular_acceleration_only():
    """acceleration_noise_rate on a synthetic omega: white noise (the smoothed omega's) plus a 20-s burst of
    angular acceleration: the floor far from it, raised along the acceleration within the window around it; without
    the noise threshold the noise alone raises the rate."""
    rng = np.random.default_rng(5)
    n = 600
    t = np.arange(n, dtype=float)
    alpha = np.zeros((n, 3))
    alpha[300:320, 1] = 1e-3                                         # rad/s^2 along y
    omega = np.cumsum(alpha, 0) + 2e-4 * rng.standard_normal((n, 3))
    start = np.zeros(n, bool)
    start[0] = True
    q_floor = 1e-10
    Q = acceleration_noise_rate(omega, t, start, q_floor, 0.5, 5.0, 20.0, noise_k=3.0)
    far = (t < 250) | (t > 380)
    assert np.allclose(Q[far], q_floor * np.eye(3), rtol=0, atol=1e-3 * q_floor)
    near = (t > 295) & (t < 320)
    assert np.all(Q[near, 1, 1] > 10 * q_floor)
    assert np.all(Q[near, 1, 1] > 10 * np.abs(Q[near, 0, 0] - q_floor))
    Q0 = acceleration_noise_rate(omega, t, start, q_floor, 0.5, 5.0, 20.0, noise_k=0.0)
    assert np.median(Q0[far, 0, 0]) > 1.5 * q_floor
    # windows do not cross a segment start
    start[310] = True
    Qs = acceleration_noise_rate(omega, t, start, q_floor, 0.5, 5.0, 20.0, noise_k=3.0)
    assert Qs.shape == (n, 3, 3) and np.all(np.isfinite(Qs))


def test_adaptive_noise_keeps_the_pitch_up_below_0_3_deg(pitch_up):
    d, sols = pitch_up
    out = {}
    for key in (True, "adaptive"):
        sol = sols[key]
        ang, de = attitude_errors_deg(d, sol)
        f = sol.att_fixed
        t = np.asarray(sol.pobs.time - sol.pobs.time[0], float)[sol.att_epochs]
        t0 = t[int(np.argmax(f))]
        late = f & (t > t0 + 30.0)
        out[key] = ang[late].max(), (de / sol.sigma_euler_deg)[late].std(axis=0), sol
    (max_s, _, sol_s), (max_a, z_a, sol_a) = out[True], out["adaptive"]
    # with the rigid update (the default) the plain smoother is below the limit on this pass too (measured 0.24 deg;
    # 0.31 with `baseline_update: additive`, whose lengths drift), the adaptive noise lower still (measured 0.19 deg
    # with the second pass; additive 0.23): the second pass takes 0.05 deg off the lag peak, at least 0.02 required
    assert max_s < 0.3 and max_a < 0.3 and max_a < max_s - 0.02, (max_s, max_a)
    assert np.all(z_a < 1.2), z_a                                     # sigmas not optimistic (measured 0.66 / 0.58 / 0.68)
    # the second pass is a whole filter run: no fix lost, the first fix at the same epoch; it starts its noise
    # estimator where the first pass ended (FilterRun.start_noise_from, the first pass's phase noise above Table 1's
    # 3 mm floor), so the float epochs before the fix differ too
    a, b = sol_s.fr, sol_a.fr
    assert "fix_lost" not in sol_a.summary["events"]
    k0 = int(np.flatnonzero(a.fixed.all(axis=1))[0])
    assert int(np.flatnonzero(b.fixed.all(axis=1))[0]) == k0
    assert np.sqrt(a.smoother_data["noise_state"]["est_var_p"].max()) > 0.0033
    assert not np.array_equal(a.b_ecef_m[:k0], b.b_ecef_m[:k0], equal_nan=True)
    assert np.nanmax(np.abs(a.b_ecef_m - b.b_ecef_m)) > 1e-4
    pn = sol_a.summary["smoother"]["process_noise"]
    assert pn["max_sigma_omega_deg_s"] > 0.03 > pn["floor_sigma_omega_deg_s"] and pn["epochs_above_table1"] > 10
    assert pn["epochs_at_table1_outside_fixed_runs"] >= k0
