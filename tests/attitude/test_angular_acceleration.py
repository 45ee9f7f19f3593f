"""The angular-acceleration state of dynamic mode (gnssatt.attitude.angular_acceleration, issue 21 item 3): the time
update's algebra against the model it states, and on a short clean slew the option runs through filter and smoother
with the right integers and an attitude no worse than without it."""
from __future__ import annotations

import numpy as np
import pytest

from gnssatt.attitude.angular_acceleration import propagate_acceleration, sub_transition
from gnssatt.attitude.process import load_inputs, process
from gnssatt.attitude.settings import ALL_PHASES, AttitudeSettings
from tests.attitude.conftest import set_files


def test_propagation_is_the_constant_acceleration_transition():
    """omega += alpha dt exactly; P equals A P A^T + q dt on alpha with A = I + dt E_omega,alpha (dense reference);
    the baselines' rows untouched."""
    rng = np.random.default_rng(3)
    n = 9
    M = rng.normal(size=(n, n))
    P = M @ M.T
    x = rng.normal(size=n)
    A = np.eye(n)
    A[0:3, 3:6] = 2.0 * np.eye(3)
    P_ref = A @ P @ A.T
    P_ref[3:6, 3:6] += np.eye(3) * 1e-6 * 2.0
    x_ref = A @ x
    propagate_acceleration(x, P, 1e-6, 2.0)
    assert np.allclose(x, x_ref, atol=1e-15) and np.allclose(P, P_ref, atol=1e-12)


def test_sub_transition_is_rotation_after_acceleration():
    """Phi_rot A on the sub-state [omega, alpha, b]: alpha's columns = dt x omega's, everything else Phi_rot's."""
    rng = np.random.default_rng(4)
    Phi_rot = np.eye(9)
    Phi_rot[6:9, 6:9] = np.eye(3) + 0.01 * rng.normal(size=(3, 3))
    Phi_rot[6:9, 0:3] = rng.normal(size=(3, 3))
    A = np.eye(9)
    A[0:3, 3:6] = 0.5 * np.eye(3)
    assert np.allclose(sub_transition(Phi_rot, 0.5), Phi_rot @ A, atol=1e-15)


def test_slew_with_the_acceleration_state(slew_pass):
    """Clean 6-min slew (seed 000 Fig. 6's preset), dynamic mode with the smoother: with angular_acceleration_state
    the run keeps every fix (fixed share after the first fix >= the run without it), and the smoothed attitude's
    error after the first 30 s of fix stays below 0.3 deg (the slews' target) and within 10 % of the run without
    it (95th percentile, deg)."""
    from gnssatt.attitude.truth import attitude_errors_deg

    inputs = load_inputs(set_files(slew_pass))
    out = {}
    for acc in (False, True):
        sol = process(inputs, AttitudeSettings.preset("all-phases", mode="dynamic", smoother=True,
                                                      angular_acceleration_state=acc))
        ang, _ = attitude_errors_deg(slew_pass, sol)
        f = sol.att_fixed
        i0 = int(np.argmax(f))
        late = f.copy()
        late[:i0 + 30] = False
        assert sol.fr.smoother_data["x_post"].shape[1] == (6 if acc else 3) + 3 * sol.fr.fixed.shape[1]
        out[acc] = (f[i0:].mean(), float(ang[late].max()), float(np.percentile(ang[late], 95)))
    assert out[True][0] >= out[False][0], out
    assert out[True][1] < 0.3, out
    assert out[True][2] < 1.1 * out[False][2], out


def _first_fixed_epochs(slew_pass):
    """(rotation angle error (n_fixed,) deg, tilt chi-square (2 dof) of the first 10 fixed epochs) of the short slew,
    dynamic mode with angular_acceleration_state and smoother_adaptive_noise."""
    from gnssatt.attitude.truth import attitude_errors_deg

    sol = process(load_inputs(set_files(slew_pass)), AttitudeSettings.preset(
        "all-phases", mode="dynamic", smoother=True, smoother_adaptive_noise=True, angular_acceleration_state=True))
    ang, de = attitude_errors_deg(slew_pass, sol)
    fi = np.flatnonzero(sol.att_fixed)
    z = de[fi[:10], 1:3] / sol.sigma_euler_deg[fi[:10], 1:3]
    return ang[fi], (z ** 2).sum(1)


def test_slew_below_0_3_deg_from_the_first_fixed_epoch(slew_pass):
    """The issue's slew target on the short slew: with angular_acceleration_state and smoother_adaptive_noise every
    fixed epoch from the first one below 0.3 deg (measured 0.43 deg at the first fixed epoch while the second pass
    started its noise estimate at Table 1's 3 mm floor; below 0.3 since it starts from the first pass's estimate)."""
    ang, _ = _first_fixed_epochs(slew_pass)
    assert ang.max() < 0.3, ang.max()


@pytest.mark.xfail(strict=True, reason="issue 21 item 7 not met on this run: smoother tilt chi-square (2 dof) over "
                                       "the first 10 fixed epochs 4.48 on this slew with the residual-based "
                                       "covariance (gnssatt/attitude/smoothed_covariance.py; 0.97 with the former "
                                       "fixed correlated share, which was ~2x conservative everywhere: 0.53 over "
                                       "the rest); the RTS covariance alone gives 3.24 here. Ten epochs of one run "
                                       "are 1-2 independent error samples (the error's autocorrelation is 0.5-0.7 "
                                       "at 10 s): over the 16 slews of bench_attitude_slews.py the first-10 mean is 1.97 "
                                       "(0.98 per dof), runs 0.5-8.3 (docs/BENCHMARKS.md 'Smoother chi-square')")
def test_slew_chi_square_from_the_first_fixed_epoch(slew_pass):
    """Honest sigmas from the first fixed epoch: the smoother's tilt chi-square (2 dof) over the first 10 fixed
    epochs of the short slew within 1.0-1.5."""
    _, chi2 = _first_fixed_epochs(slew_pass)
    assert 1.0 <= chi2.mean() <= 1.5, chi2


def test_jerk_rate_profile_follows_the_omega_profile():
    """smoothing.quiet_jerk_share: q_alpha x share at the quiet level of the omega profile, x share sqrt(ratio) above
    it (the largest eigenvalue: a manoeuvre about one axis), never above the configured q_alpha."""
    from gnssatt.attitude.angular_acceleration import jerk_rate_profile

    q_alpha, q_quiet, share = 2.0e-12, 1.0e-9, 0.04
    Q = np.stack([np.eye(3) * q_quiet, np.diag([q_quiet, q_quiet, 100.0 * q_quiet]), np.eye(3) * 1e6 * q_quiet])
    q = jerk_rate_profile(q_alpha, Q, q_quiet, share)
    assert np.allclose(q, [q_alpha * share, q_alpha * share * 10.0, q_alpha], rtol=1e-12), q


def test_quiet_jerk_share_on_the_slew(slew_pass):
    """Clean 6-min slew, dynamic mode, angular_acceleration_state + smoother_adaptive_noise: with
    smoother_quiet_jerk_share 0.04 the same integers (none wrong against truth/arcs.csv), the max error over the fixed
    epochs lower than with the configured jerk rate everywhere (measured 0.16 against 0.23 deg, the first fixed
    epochs) and the RMS within 10 % of it (measured 0.055 against 0.058 deg)."""
    from gnssatt.attitude.truth import attitude_errors_deg, score_fixes

    inputs = load_inputs(set_files(slew_pass))
    out = {}
    for share in (1.0, 0.04):
        sol = process(inputs, AttitudeSettings.preset(
            "all-phases", mode="dynamic", smoother=True, smoother_adaptive_noise=True, angular_acceleration_state=True,
            smoother_quiet_jerk_share=share))
        ang, _ = attitude_errors_deg(slew_pass, sol)
        fi = np.flatnonzero(sol.att_fixed)
        assert score_fixes(sol, slew_pass / "truth")["wrong_constraints"] == 0
        out[share] = (float(ang[fi].max()), float(np.sqrt(np.mean(ang[fi] ** 2))))
    assert out[0.04][0] < out[1.0][0], out
    assert out[0.04][1] < 1.1 * out[1.0][1], out
