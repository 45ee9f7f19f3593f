"""Fixed-interval smoothing of the dynamic-mode angular velocity and baselines (post-processing).

Rauch, Tung & Striebel (1965, AIAA J. 3(8)), extended form: with the forward filter's posterior x_k|k, P_k|k, the
prior x_k+1|k, P_k+1|k after propagation and the transition matrix Phi_k+1 (linearised RK4 rotation of the
baselines by omega, gnssatt.estimation.ekf.rotation_rk4_stm), backwards from the last epoch of a segment:

    C_k = P_k|k Phi_k+1^T P_k+1|k^-1
    x_k|N = x_k|k + C_k (x_k+1|N - x_k+1|k)
    P_k|N = P_k|k + C_k (P_k+1|N - P_k+1|k) C_k^T

on the (omega, b_1..b_n) sub-state. The other states either carry no memory (white clocks, reset every epoch) or
are constrained integers once fixed (zero variance), so the marginal recursion on the sub-state is what the full
one gives while every baseline is fixed; float ambiguities of newcomers and the code biases are neglected (their
correlation with the baselines is small next to the fixed phases'). A segment restarts where the forward filter
reset its angular velocity or a baseline's ambiguities (events omega_reset / fix_reset): what came before was
computed with integers or a linearisation point the filter withdrew.

Why: a forward filter with an angular-velocity random walk lags an angular acceleration a by about
a / omega_n^2 (omega_n^2 = sqrt(q / r), q the random-walk rate, r the one-epoch attitude variance x dt), and noise
sigma^2 ~ sqrt(2) q^1/4 r^3/4 - a lag/noise trade-off no choice of q removes (seed 000 sec. 4.2, Fig. 6). The
smoother is the cubic smoothing spline of the same model: polynomials up to cubic pass unbiased (no lag in a
constant angular acceleration or jerk) and the noise is that of a two-sided window.
"""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.length_constraint import rescale_lengths
from gnssatt.attitude.rigid_smoother import rts_smooth_rigid
from gnssatt.attitude.rts_links import rts_links
from gnssatt.attitude.smoothed_covariance import covariance_scale

__all__ = ["rts_smooth", "smooth_filter_result", "fixed_runs", "adaptive_noise_profile", "acceleration_noise_rate"]


def rts_smooth(x_post: np.ndarray, P_post: np.ndarray, x_prior: np.ndarray, P_prior: np.ndarray, Phi: np.ndarray,
               start: np.ndarray, gains: bool = False):
    """(x_k|N (n, m), P_k|N (n, m, m)) by the RTS recursion (module doc) over the segments that `start` (n,) bool
    opens (start[k]: no link from k-1 to k). Epochs with non-finite inputs are left as filtered and cut the chain.
    gains: also return the gains C_k (n, m, m), nan where k does not link to k+1 (cov(x_k+1, x_k | N) =
    P_k+1|N C_k^T)."""
    xs, Ps = x_post.copy(), P_post.copy()
    C_all = np.full(P_post.shape, np.nan) if gains else None
    for k, C in rts_links(x_post, P_post, x_prior, P_prior, Phi, start):
        j = k + 1
        xs[k] = x_post[k] + C @ (xs[j] - x_prior[j])
        Pk = P_post[k] + C @ (Ps[j] - P_prior[j]) @ C.T
        Ps[k] = 0.5 * (Pk + Pk.T)
        if gains:
            C_all[k] = C
    return (xs, Ps, C_all) if gains else (xs, Ps)


def backward_pass(sd: dict, start: np.ndarray, n_bl: int, settings=None):
    """(x_k|N, P_k|N) of the recorded sub-state: rts_smooth, or with settings.baseline_update "rigid" the same
    recursion in the baselines' tangent space (gnssatt.attitude.rigid_smoother: consistent with the forward
    filter's retraction)."""
    args = (sd["x_post"], sd["P_post"], sd["x_prior"], sd["P_prior"], sd["Phi"], start)
    if settings is not None and settings.baseline_update == "rigid":
        return rts_smooth_rigid(*args, n_bl)
    return rts_smooth(*args)


def smooth_filter_result(fr, settings=None) -> int:
    """Replace the baselines, their covariance and omega of a dynamic-mode FilterResult (run with
    settings.smoothing.enabled) by the smoothed ones over the runs of epochs where every baseline is fixed (a run starts at
    a fix, a reset or an epoch after a float one: float ambiguities are correlated with the baselines and are not in
    the smoothed sub-state). Returns the number of epochs smoothed.

    Covariance: the recursion treats every phase error as white, but multipath and uncalibrated PCV are correlated
    over minutes and do not average out over the smoother's window; the reported covariance is s_k P_k|N with the
    white / time-correlated split of the phase post-fit residuals (gnssatt.attitude.smoothed_covariance: their
    autocorrelation, the correlated part averaged over the epochs the smoother effectively averages at k).

    settings.smoothing.adaptive_noise changes nothing here: fr is then the second forward pass (run with the
    per-epoch noise of adaptive_noise_profile), smoothed as any other."""
    sd = fr.smoother_data
    if sd is None:
        return 0
    n_ep, n_bl = fr.fixed.shape
    fixed_all, start = fixed_runs(fr)
    # an epoch is smoothed when it links to its successor (the last epoch of a run stays as filtered)
    linked = np.zeros(n_ep, bool)
    linked[:-1] = ~start[1:] & fixed_all[:-1]
    xs, Ps = backward_pass(sd, start, n_bl, settings)
    ep = np.flatnonzero(linked & np.isfinite(xs).all(1))
    fr.omega_ecef_rad_s[ep] = xs[ep, 0:3]
    r0 = xs.shape[1] - 3 * n_bl                      # omega (3) [+ alpha (3)] ahead of the baselines
    b_s = xs[ep, r0:].reshape(ep.size, n_bl, 3)
    if settings is not None and settings.length_constraint_sigma_m > 0:
        # the forward filter's lengths (held to the body length, gnssatt.attitude.length_constraint)
        b_s = rescale_lengths(b_s, np.linalg.norm(fr.b_ecef_m[ep], axis=-1))
    fr.b_ecef_m[ep] = b_s
    scale, sd["covariance"] = covariance_scale(fr, Ps, ep, r0)
    fr.P_b_m2[ep] = scale[:, None, None] * Ps[ep, r0:, r0:]
    sd["epochs_smoothed"] = int(ep.size)
    return int(ep.size)


# ---------------------------------------------------------------------------------------------------------------
# Adaptive process noise (settings.smoothing.adaptive_noise): the omega random walk per epoch from the data
#
# A random walk q on omega is white angular acceleration; its smoother is the cubic smoothing spline, whose penalty
# on the acceleration shrinks a real one: with Table 1's q the smoothed attitude starts a minimum-jerk manoeuvre
# early (0.3 deg before seed 000 Fig. 6's pitch-up) and its noise is that of a ~20-s window elsewhere. EM for a
# time-varying Q (Shumway & Stoffer 1982, J. Time Ser. Anal. 3(4): Q = E[dw dw^T | all data] / dt) would ask per
# epoch for alpha alpha^T dt (the increments of a deterministic angular acceleration alpha) plus the posterior
# variance of the increments; the latter keeps the windowed estimate near its starting value (measured: 3
# iterations moved q by < 10 %). So the estimate keeps EM's leading term:
#
#     Q_k = floor q_1 I + gain alpha_j alpha_j^T dt_k,   j = argmax |alpha| within +-window of k (same run)
#
# alpha from the smoothed omega over +-accel_window, its length first shrunk by k x its median over the pass (soft
# threshold: the median is the noise of the smoothed omega's differences, ~0.004 deg/s^2 on the simulated passes;
# without it the noise alone raised q to 2-3x the floor over most of the realistic 106-min pass), q_1 Table 1's
# rate; the largest acceleration nearby sets the noise so that it is raised at the onset of a manoeuvre (the jump of
# the angular jerk, where the spline's shrinkage error is largest) and along the acceleration only. Outside the
# all-fixed runs the rate stays Table 1's. The first pass is the Table 1 filter + smoother; the second runs the
# whole filter again with Q_k (run_filter q_omega) and is smoothed as usual: its fixes, integers, events and
# residuals are those of a normal filter run (an earlier version re-filtered the (omega, baselines) sub-state from
# the recorded information instead, which neglects the float ambiguities of newcomers: 2.66 deg on the realistic
# pass). Chosen on the slews of bench/bench_attitude.py (docs/attitude.md "Adaptive process noise of the smoother").


def fixed_runs(fr) -> tuple[np.ndarray, np.ndarray]:
    """(every baseline fixed (n_ep,) bool, segment starts (n_ep,) bool) of a FilterResult with smoother_data: a run
    of all-fixed epochs starts at a reset, a fix or after a float epoch; float epochs are runs of their own."""
    fixed_all = fr.fixed.all(axis=1) & fr.ok.all(axis=1)
    start = fr.smoother_data["start"].copy()
    start[1:] |= ~fixed_all[:-1]
    start |= ~fixed_all
    return fixed_all, start


def adaptive_noise_profile(fr, settings, floor_scale: float = 1.0, with_runs: bool = False):
    """(q_omega (n_ep, 3, 3) rad^2/s^3, info) for the second forward pass of settings.smoothing.adaptive_noise
    (docs/attitude.md "Adaptive process noise of the smoother"): the omega random walk per epoch from the angular
    acceleration of fr's RTS-smoothed omega over its all-fixed runs (acceleration_noise_rate: floor x Table 1 +
    gain alpha alpha^T dt, the largest alpha within +-window); Table 1's rate outside the runs (float epochs, and
    so everything up to the first fix; the second pass starts its noise estimator from the first's, run_filter
    noise0). info: summary.json. floor_scale: the floor x this (settings.smoothing.noise_em,
    gnssatt.attitude.process_noise_em); with_runs: also return the epochs given the profile (n_ep,) bool."""
    sd = fr.smoother_data
    q1 = float(sd["q_omega"])
    fixed_all, start = fixed_runs(fr)
    xs, _ = backward_pass(sd, start, fr.fixed.shape[1], settings)
    t_s = np.cumsum(np.nan_to_num(sd["dt_s"]))
    Qw = acceleration_noise_rate(xs[:, 0:3], t_s, start, floor_scale * settings.smoothing.noise_floor * q1,
                                 settings.smoothing.noise_gain, settings.smoothing.accel_window_s,
                                 settings.smoothing.noise_window_s, settings.smoothing.accel_noise_k)
    run = fixed_all & np.isfinite(xs[:, 0:3]).all(1)
    Qw[~run] = q1 * np.eye(3)
    sig = np.degrees(np.sqrt(np.linalg.eigvalsh(Qw)[:, -1]))
    info = {"method": "omega random walk per epoch from the smoothed angular acceleration of a first pass (Table 1), "
                      "then the whole filter run again with it and smoothed",
            "floor_sigma_omega_deg_s": float(np.degrees(np.sqrt(floor_scale * settings.smoothing.noise_floor * q1))),
            "max_sigma_omega_deg_s": float(sig[run].max()) if run.any() else None,
            "epochs_above_table1": int(np.sum(run & (sig > np.degrees(np.sqrt(q1)) * (1 + 1e-9)))),
            "epochs_at_table1_outside_fixed_runs": int(np.sum(~run))}
    return (Qw, info, run) if with_runs else (Qw, info)


def acceleration_noise_rate(omega: np.ndarray, t_s: np.ndarray, start: np.ndarray, q_floor: float, gain: float,
                            accel_window_s: float, window_s: float, noise_k: float = 0.0) -> np.ndarray:
    """(n, 3, 3) omega random-walk rate per epoch (rad^2/s^3): q_floor I + gain alpha_j alpha_j^T dt_k, alpha the
    angular acceleration of omega (n, 3) (rad/s) over +-accel_window_s, j the epoch of the largest |alpha| within
    +-window_s of k; windows do not cross a segment start (block comment above). noise_k > 0: |alpha| first shrunk
    by noise_k x its median over the pass (soft threshold: the median is the noise of the smoothed omega's
    differences on any pass that is not manoeuvring most of the time)."""
    n = len(t_s)
    w = np.nan_to_num(omega)
    alpha = np.zeros((n, 3))
    has = np.zeros(n, bool)
    jmax = np.arange(n)
    dt = np.ones(n)
    bounds = np.flatnonzero(start)
    bounds = np.unique(np.concatenate([[0], bounds, [n]]))
    segs = [(s0, s1) for s0, s1 in zip(bounds[:-1], bounds[1:]) if s1 - s0 >= 2]
    for s0, s1 in segs:
        t = t_s[s0:s1]
        dt[s0 + 1:s1] = np.diff(t)
        dt[s0] = dt[s0 + 1]
        lo = np.searchsorted(t, t - accel_window_s, "left")
        hi = np.searchsorted(t, t + accel_window_s, "right") - 1
        span = t[hi] - t[lo]
        ok = span > 0
        alpha[s0:s1][ok] = (w[s0:s1][hi[ok]] - w[s0:s1][lo[ok]]) / span[ok, None]
        has[s0:s1] = ok
    if noise_k > 0 and has.any():
        a_abs = np.linalg.norm(alpha, axis=1)
        thr = noise_k * float(np.median(a_abs[has]))
        alpha *= (np.maximum(a_abs - thr, 0.0) / np.where(a_abs > 0, a_abs, 1.0))[:, None]
    for s0, s1 in segs:
        t = t_s[s0:s1]
        a2 = np.einsum("ka,ka->k", alpha[s0:s1], alpha[s0:s1])
        lo = np.searchsorted(t, t - window_s, "left")
        hi = np.searchsorted(t, t + window_s, "right")
        for i in range(s1 - s0):
            jmax[s0 + i] = s0 + lo[i] + int(np.argmax(a2[lo[i]:hi[i]]))
    a = alpha[jmax]
    return q_floor * np.eye(3) + gain * np.einsum("ka,kb->kab", a, a) * dt[:, None, None]
