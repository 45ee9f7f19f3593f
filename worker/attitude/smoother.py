"""Fixed-interval smoothing of the dynamic-mode angular velocity and baselines (post-processing).

Rauch, Tung & Striebel (1965, AIAA J. 3(8)), extended form: with the forward filter's posterior x_k|k, P_k|k, the
prior x_k+1|k, P_k+1|k after propagation and the transition matrix Phi_k+1 (linearised RK4 rotation of the
baselines by omega, worker.estimation.ekf.rotation_rk4_stm), backwards from the last epoch of a segment:

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

__all__ = ["rts_smooth", "smooth_filter_result", "adaptive_substate_smooth", "refilter_substate"]


def rts_smooth(x_post: np.ndarray, P_post: np.ndarray, x_prior: np.ndarray, P_prior: np.ndarray, Phi: np.ndarray,
               start: np.ndarray, gains: bool = False):
    """(x_k|N (n, m), P_k|N (n, m, m)) by the RTS recursion (module doc) over the segments that `start` (n,) bool
    opens (start[k]: no link from k-1 to k). Epochs with non-finite inputs are left as filtered and cut the chain.
    gains: also return the gains C_k (n, m, m), nan where k does not link to k+1 (cov(x_k+1, x_k | N) =
    P_k+1|N C_k^T)."""
    n = x_post.shape[0]
    xs, Ps = x_post.copy(), P_post.copy()
    C_all = np.full(P_post.shape, np.nan) if gains else None
    fin_post = np.isfinite(x_post).all(1) & np.isfinite(P_post).all((1, 2))
    fin_prior = np.isfinite(x_prior).all(1) & np.isfinite(P_prior).all((1, 2)) & np.isfinite(Phi).all((1, 2))
    for k in range(n - 2, -1, -1):
        j = k + 1
        if start[j] or not (fin_post[k] and fin_post[j] and fin_prior[j]):
            continue
        try:
            C = np.linalg.solve(P_prior[j], Phi[j] @ P_post[k]).T      # P_k|k Phi^T P_prior^-1 (P symmetric)
        except np.linalg.LinAlgError:
            continue
        xs[k] = x_post[k] + C @ (xs[j] - x_prior[j])
        Pk = P_post[k] + C @ (Ps[j] - P_prior[j]) @ C.T
        Ps[k] = 0.5 * (Pk + Pk.T)
        if gains:
            C_all[k] = C
    return (xs, Ps, C_all) if gains else (xs, Ps)


def smooth_filter_result(fr, settings=None) -> int:
    """Replace the baselines, their covariance and omega of a dynamic-mode FilterResult (run with
    settings.smoother) by the smoothed ones over the runs of epochs where every baseline is fixed (a run starts at
    a fix, a reset or an epoch after a float one: float ambiguities are correlated with the baselines and are not in
    the smoothed sub-state). Returns the number of epochs smoothed.

    Covariance: the recursion treats every phase error as white, but multipath and uncalibrated PCV are correlated
    over minutes; the forward filter already counts them at their full (inflated) variance
    (multipath_correlation_factor) and averaging over the later epochs too does not shrink them further. With f the
    information-weighted share of that correlated variance in the epoch's phase variances (recorded by the filter),
    the reported covariance is P_k|N + f (P_k|k - P_k|N): white errors shrink as smoothed, correlated ones stay as
    filtered (f = 0 on white-noise data).

    settings.smoother_adaptive_noise: the per-epoch omega random walk of adaptive_substate_smooth replaces Table 1's
    before smoothing (P_k|k above stays the Table 1 forward filter's: the multipath inflation factor was set for
    its averaging length), and the last epoch of each run takes the re-run filter's value."""
    sd = fr.smoother_data
    if sd is None:
        return 0
    n_ep, n_bl = fr.fixed.shape
    fixed_all = fr.fixed.all(axis=1) & fr.ok.all(axis=1)
    start = sd["start"].copy()
    start[1:] |= ~fixed_all[:-1]
    start |= ~fixed_all
    # an epoch is smoothed when it links to its successor (the last epoch of a run stays as filtered)
    linked = np.zeros(n_ep, bool)
    linked[:-1] = ~start[1:] & fixed_all[:-1]
    if settings is not None and getattr(settings, "smoother_adaptive_noise", False):
        xs, Ps, info = adaptive_substate_smooth(sd, start, settings)
        linked[1:] |= ~start[1:] & fixed_all[1:]           # the re-run filter changed the runs' last epochs too
        sd["adaptive_noise"] = info
    else:
        xs, Ps = rts_smooth(sd["x_post"], sd["P_post"], sd["x_prior"], sd["P_prior"], sd["Phi"], start)
    ep = np.flatnonzero(linked & np.isfinite(xs).all(1))
    fr.omega_ecef_rad_s[ep] = xs[ep, 0:3]
    fr.b_ecef_m[ep] = xs[ep, 3:].reshape(ep.size, n_bl, 3)
    f = np.clip(sd.get("corr_share", np.zeros(n_ep)), 0.0, 1.0)[ep, None, None]
    P_post = sd["P_post"][ep, 3:, 3:]
    fr.P_b_m2[ep] = Ps[ep, 3:, 3:] + f * (P_post - Ps[ep, 3:, 3:])
    sd["epochs_smoothed"] = int(ep.size)
    return int(ep.size)


# ---------------------------------------------------------------------------------------------------------------
# Adaptive process noise (settings.smoother_adaptive_noise): the omega random walk per epoch from the data
#
# A random walk q on omega is white angular acceleration; its smoother is the cubic smoothing spline, whose penalty
# on the acceleration shrinks a real one: with Table 1's q the smoothed attitude starts a minimum-jerk manoeuvre
# early (0.3 deg before seed 000 Fig. 6's pitch-up) and its noise is that of a ~20-s window elsewhere. EM for a
# time-varying Q (Shumway & Stoffer 1982, J. Time Ser. Anal. 3(4): Q = E[dw dw^T | all data] / dt) would ask per
# epoch for alpha alpha^T dt (the increments of a deterministic angular acceleration alpha) plus the posterior
# variance of the increments; the latter keeps the windowed estimate near its starting value (EM converges slowly
# where one epoch says little about an omega increment: measured, 3 iterations moved q by < 10 %). So the estimate
# here keeps EM's leading term and iterates it:
#
#     Q_k = floor q_1 I + gain alpha_j alpha_j^T dt_k,   j = argmax |alpha| within +-window of k (same run)
#
# alpha from the smoothed omega over +-accel_window, q_1 Table 1's rate; the largest acceleration nearby sets the
# noise so that it is raised at the onset of a manoeuvre (the jump of the angular jerk, where the spline's
# shrinkage error is largest) and along the acceleration only. Each epoch's information is divided by the mean
# misfit of the information within +-smoother_info_window_s to the smoothed state relative to the pass's median
# (>= 1; the first ~20 s after the first fix show 2.5-3x: information gathered while omega had just been reset).
# Then the (omega, baselines) sub-state is re-filtered with Q_k and smoothed again. Chosen on the slews of
# bench/bench_attitude.py, seeds 0-3 (docs/attitude.md "Adaptive process noise of the smoother").
#
# The re-run needs no measurement: per epoch of a fixed run, the information the update added to the sub-state
# is recovered from the recorded prior and posterior (information form, Maybeck 1979 sec. 5.7):
#     J_k = P_k|k^-1 - P_k|k-1^-1,   g_k = P_k|k^-1 (x_k|k - x_k|k-1),
# and with a new prior (x', P') the update is P'_k|k = (P'_k|k-1^-1 + J_k)^-1,
#     x'_k|k = x'_k|k-1 + P'_k|k (g_k - J_k (x'_k|k-1 - x_k|k-1));
# propagation uses the recorded transition about the recorded trajectory (x'_k|k-1 = x_k|k-1 + Phi_k (x'_k-1|k-1 -
# x_k-1|k-1)) and P'_k|k-1 = Phi_k P'_k-1|k-1 Phi_k^T + (recorded Q_k) + dQ_k. With dQ = 0 this returns the
# recorded filter exactly (test). Approximation: J_k is the update's effect on the sub-state given the recorded
# prior; the float ambiguities of newcomers and the code biases it went through would have correlated differently
# with another prior (against a full re-run of the filter with 2x the random-walk sigma: rms 0.045 deg in pitch,
# largest in the first minute where newcomers are rounded every few epochs). Fixes, integers and events are the
# forward filter's; the run's first epoch keeps its recorded posterior.


def _inv_spd(P: np.ndarray) -> np.ndarray:
    """Inverse of symmetric positive-definite matrices (..., m, m), equilibrated by their diagonal (omega in rad/s
    and baselines in m differ by orders of magnitude)."""
    d = np.sqrt(np.abs(np.diagonal(P, axis1=-2, axis2=-1)))
    d = np.where(d > 0, d, 1.0)
    dd = d[..., :, None] * d[..., None, :]
    Si = np.linalg.inv(P / dd)
    return 0.5 * (Si + np.swapaxes(Si, -1, -2)) / dd


def omega_noise_matrix(Qw: np.ndarray, b_prior: np.ndarray, dt_s: np.ndarray) -> np.ndarray:
    """(n, m, m) discrete noise of the (omega, b_1..b_nb) sub-state for omega random-walk rates Qw (n, 3, 3)
    (rad^2/s^3) over dt_s (n,), about the propagated baselines b_prior (n, nb, 3): Q_ww = Qw dt,
    Q_bw = B_j Qw dt^2 / 2, Q_bb = B_j Qw B_i^T dt^3 / 3, B_j = -[b_j x] (Van Loan 1978; the filter's
    worker.estimation.ekf_kernels.propagate_rotation_cov)."""
    n, nb = b_prior.shape[:2]
    m = 3 + 3 * nb
    B = np.zeros((n, nb, 3, 3))
    x, y, z = b_prior[..., 0], b_prior[..., 1], b_prior[..., 2]
    B[..., 0, 1], B[..., 0, 2] = z, -y
    B[..., 1, 0], B[..., 1, 2] = -z, x
    B[..., 2, 0], B[..., 2, 1] = y, -x
    dt = dt_s[:, None, None]
    Q = np.zeros((n, m, m))
    Q[:, 0:3, 0:3] = Qw * dt
    for j in range(nb):
        r = 3 + 3 * j
        BQ = B[:, j] @ Qw
        Q[:, r:r + 3, 0:3] = BQ * dt ** 2 / 2
        Q[:, 0:3, r:r + 3] = np.swapaxes(Q[:, r:r + 3, 0:3], -1, -2)
        for i in range(nb):
            ri = 3 + 3 * i
            Q[:, r:r + 3, ri:ri + 3] = BQ @ np.swapaxes(B[:, i], -1, -2) * dt ** 3 / 3
    return Q


def refilter_substate(x_post, P_post, x_prior, P_prior, Phi, start, dQ, info_scale=None):
    """(x_k|k, P_k|k, x_k|k-1, P_k|k-1) of the sub-state filter re-run with dQ (n, m, m) added to the recorded
    process noise of each transition, from the recorded prior/posterior/transition (block comment above), each
    epoch's information times info_scale (n,) if given. Epochs that start a segment (start) or have non-finite
    records keep the recorded values."""
    xf, Pf, xp, Pp = x_post.copy(), P_post.copy(), x_prior.copy(), P_prior.copy()
    fin = (np.isfinite(x_post).all(1) & np.isfinite(P_post).all((1, 2)) & np.isfinite(x_prior).all(1)
           & np.isfinite(P_prior).all((1, 2)) & np.isfinite(Phi).all((1, 2)))
    link = np.zeros(len(start), bool)
    link[1:] = ~start[1:] & fin[1:] & fin[:-1]
    ks = np.flatnonzero(link)
    if ks.size == 0:
        return xf, Pf, xp, Pp
    L_post = _inv_spd(P_post[ks])
    J = L_post - _inv_spd(P_prior[ks])
    J = 0.5 * (J + np.swapaxes(J, -1, -2))
    g = np.einsum("kab,kb->ka", L_post, x_post[ks] - x_prior[ks])
    if info_scale is not None:
        J = J * info_scale[ks, None, None]
        g = g * info_scale[ks, None]
    PhiT = np.swapaxes(Phi[ks], -1, -2)
    Q_rec = P_prior[ks] - Phi[ks] @ P_post[ks - 1] @ PhiT + dQ[ks]
    for a, k in enumerate(ks):
        F = Phi[k]
        xp[k] = x_prior[k] + F @ (xf[k - 1] - x_post[k - 1])
        Ppk = F @ Pf[k - 1] @ PhiT[a] + Q_rec[a]
        Pp[k] = 0.5 * (Ppk + Ppk.T)
        Pf[k] = _inv_spd(_inv_spd(Pp[k]) + J[a])
        xf[k] = xp[k] + Pf[k] @ (g[a] - J[a] @ (xp[k] - x_prior[k]))
    return xf, Pf, xp, Pp


def information_consistency(x_post, P_post, x_prior, P_prior, xs, Ps, start) -> np.ndarray:
    """(n,) per epoch in a run: e^T J^+ e / (dof - tr(J P_k|N)), the normalised misfit of the baselines'
    information J_k = P_k|k^-1 - P_k|k-1^-1 (b blocks) to the smoothed state, e = g_k - J_k (x_k|N - x_k|k-1)
    (g_k as in refilter_substate): about the variance factor of that epoch's information; nan elsewhere."""
    n, m = x_post.shape
    out = np.full(n, np.nan)
    ks = np.flatnonzero(~start & np.isfinite(xs).all(1) & np.isfinite(P_prior).all((1, 2))
                        & np.isfinite(P_post).all((1, 2)))
    if ks.size == 0:
        return out
    Lb = _inv_spd(P_post[ks, 3:, 3:])
    J = Lb - _inv_spd(P_prior[ks, 3:, 3:])
    J = 0.5 * (J + np.swapaxes(J, -1, -2))
    e = np.einsum("kab,kb->ka", Lb, x_post[ks, 3:] - x_prior[ks, 3:]) \
        - np.einsum("kab,kb->ka", J, xs[ks, 3:] - x_prior[ks, 3:])
    chi2 = np.einsum("ka,kab,kb->k", e, np.linalg.pinv(J, rcond=1e-10, hermitian=True), e)
    dof = (m - 3) - np.einsum("kab,kba->k", J, Ps[ks, 3:, 3:])
    out[ks] = chi2 / np.maximum(dof, 0.5)
    return out


def _window_mean(v: np.ndarray, t_s: np.ndarray, start: np.ndarray, half_s: float) -> np.ndarray:
    """Mean of the finite v within +-half_s of each epoch, not across a segment start (nan if none)."""
    n = len(v)
    out = np.full(n, np.nan)
    bounds = np.unique(np.concatenate([[0], np.flatnonzero(start), [n]]))
    for s0, s1 in zip(bounds[:-1], bounds[1:]):
        t, x = t_s[s0:s1], v[s0:s1]
        ok = np.isfinite(x)
        cs = np.concatenate([[0.0], np.cumsum(np.where(ok, x, 0.0))])
        cn = np.concatenate([[0], np.cumsum(ok)])
        lo = np.searchsorted(t, t - half_s, "left")
        hi = np.searchsorted(t, t + half_s, "right")
        c = cn[hi] - cn[lo]
        out[s0:s1] = np.where(c > 0, (cs[hi] - cs[lo]) / np.maximum(c, 1), np.nan)
    return out


def acceleration_noise_rate(omega: np.ndarray, t_s: np.ndarray, start: np.ndarray, q_floor: float, gain: float,
                            accel_window_s: float, window_s: float) -> np.ndarray:
    """(n, 3, 3) omega random-walk rate per epoch (rad^2/s^3): q_floor I + gain alpha_j alpha_j^T dt_k, alpha the
    angular acceleration of omega (n, 3) (rad/s) over +-accel_window_s, j the epoch of the largest |alpha| within
    +-window_s of k; windows do not cross a segment start (block comment above)."""
    n = len(t_s)
    w = np.nan_to_num(omega)
    alpha = np.zeros((n, 3))
    jmax = np.arange(n)
    dt = np.ones(n)
    bounds = np.flatnonzero(start)
    bounds = np.unique(np.concatenate([[0], bounds, [n]]))
    for s0, s1 in zip(bounds[:-1], bounds[1:]):
        t = t_s[s0:s1]
        if s1 - s0 < 2:
            continue
        dt[s0 + 1:s1] = np.diff(t)
        dt[s0] = dt[s0 + 1]
        lo = np.searchsorted(t, t - accel_window_s, "left")
        hi = np.searchsorted(t, t + accel_window_s, "right") - 1
        span = t[hi] - t[lo]
        ok = span > 0
        alpha[s0:s1][ok] = (w[s0:s1][hi[ok]] - w[s0:s1][lo[ok]]) / span[ok, None]
        a2 = np.einsum("ka,ka->k", alpha[s0:s1], alpha[s0:s1])
        lo = np.searchsorted(t, t - window_s, "left")
        hi = np.searchsorted(t, t + window_s, "right")
        for i in range(s1 - s0):
            jmax[s0 + i] = s0 + lo[i] + int(np.argmax(a2[lo[i]:hi[i]]))
    a = alpha[jmax]
    return q_floor * np.eye(3) + gain * np.einsum("ka,kb->kab", a, a) * dt[:, None, None]


def adaptive_substate_smooth(sd: dict, start: np.ndarray, settings) -> tuple[np.ndarray, np.ndarray, dict]:
    """(x_k|N, P_k|N, info) with the per-epoch omega random walk estimated from the smoothed angular acceleration
    (block comment above): smooth with the recorded noise, then settings.smoother_noise_iterations times: noise
    from the current smoothed omega, sub-state re-filter, smooth. info: the noise used (summary.json)."""
    x_post, P_post, x_prior, P_prior, Phi = sd["x_post"], sd["P_post"], sd["x_prior"], sd["P_prior"], sd["Phi"]
    n, m = x_post.shape
    nb = (m - 3) // 3
    q1 = float(sd["q_omega"])
    dt = np.nan_to_num(sd["dt_s"])
    t_s = np.cumsum(dt)
    b_prior = np.nan_to_num(x_prior[:, 3:]).reshape(n, nb, 3)
    xs, Ps = rts_smooth(x_post, P_post, x_prior, P_prior, Phi, start)
    Qw = np.repeat((q1 * np.eye(3))[None], n, 0)
    scale = None
    for _ in range(int(settings.smoother_noise_iterations)):
        if settings.smoother_info_window_s > 0:
            r = information_consistency(x_post, P_post, x_prior, P_prior, xs, Ps, start)
            lam = _window_mean(r, t_s, start, settings.smoother_info_window_s) / np.nanmedian(r)
            scale = 1.0 / np.clip(np.nan_to_num(lam, nan=1.0), 1.0, settings.smoother_info_scale_max)
        Qw = acceleration_noise_rate(xs[:, 0:3], t_s, start, settings.smoother_noise_floor * q1,
                                     settings.smoother_noise_gain, settings.smoother_accel_window_s,
                                     settings.smoother_noise_window_s)
        dQ = omega_noise_matrix(Qw - q1 * np.eye(3), b_prior, dt)
        xf, Pf, xp, Pp = refilter_substate(x_post, P_post, x_prior, P_prior, Phi, start, dQ, scale)
        xs, Ps = rts_smooth(xf, Pf, xp, Pp, Phi, start)
    sig = np.degrees(np.sqrt(np.linalg.eigvalsh(Qw)[:, -1]))
    run = ~start
    info = {"method": "omega random walk per epoch from the smoothed angular acceleration; (omega, baselines) "
                      "re-filtered from the recorded information (scaled by its misfit) and smoothed again",
            "floor_sigma_omega_deg_s": float(np.degrees(np.sqrt(settings.smoother_noise_floor * q1))),
            "max_sigma_omega_deg_s": float(sig[run].max()) if run.any() else None,
            "epochs_above_table1": int(np.sum(run & (sig > np.degrees(np.sqrt(q1)))))}
    return xs, Ps, info
