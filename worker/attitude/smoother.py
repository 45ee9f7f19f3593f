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

__all__ = ["rts_smooth"]


def rts_smooth(x_post: np.ndarray, P_post: np.ndarray, x_prior: np.ndarray, P_prior: np.ndarray, Phi: np.ndarray,
               start: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x_k|N (n, m), P_k|N (n, m, m)) by the RTS recursion (module doc) over the segments that `start` (n,) bool
    opens (start[k]: no link from k-1 to k). Epochs with non-finite inputs are left as filtered and cut the chain."""
    n = x_post.shape[0]
    xs, Ps = x_post.copy(), P_post.copy()
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
    return xs, Ps


def smooth_filter_result(fr) -> int:
    """Replace the baselines, their covariance and omega of a dynamic-mode FilterResult (run with
    settings.smoother) by the smoothed ones over the runs of epochs where every baseline is fixed (a run starts at
    a fix, a reset or an epoch after a float one: float ambiguities are correlated with the baselines and are not in
    the smoothed sub-state). Returns the number of epochs smoothed.

    Covariance: the recursion treats every phase error as white, but multipath and uncalibrated PCV are correlated
    over minutes; the forward filter already counts them at their full (inflated) variance
    (multipath_correlation_factor) and averaging over the later epochs too does not shrink them further. With f the
    information-weighted share of that correlated variance in the epoch's phase variances (recorded by the filter),
    the reported covariance is P_k|N + f (P_k|k - P_k|N): white errors shrink as smoothed, correlated ones stay as
    filtered (f = 0 on white-noise data)."""
    sd = fr.smoother_data
    if sd is None:
        return 0
    n_ep, n_bl = fr.fixed.shape
    fixed_all = fr.fixed.all(axis=1) & fr.ok.all(axis=1)
    start = sd["start"].copy()
    start[1:] |= ~fixed_all[:-1]
    start |= ~fixed_all
    xs, Ps = rts_smooth(sd["x_post"], sd["P_post"], sd["x_prior"], sd["P_prior"], sd["Phi"], start)
    # an epoch is smoothed when it links to its successor (the last epoch of a run stays as filtered)
    linked = np.zeros(n_ep, bool)
    linked[:-1] = ~start[1:] & fixed_all[:-1]
    ep = np.flatnonzero(linked & np.isfinite(xs).all(1))
    fr.omega_ecef_rad_s[ep] = xs[ep, 0:3]
    fr.b_ecef_m[ep] = xs[ep, 3:].reshape(ep.size, n_bl, 3)
    f = np.clip(sd.get("corr_share", np.zeros(n_ep)), 0.0, 1.0)[ep, None, None]
    P_post = sd["P_post"][ep, 3:, 3:]
    fr.P_b_m2[ep] = Ps[ep, 3:, 3:] + f * (P_post - Ps[ep, 3:, 3:])
    sd["epochs_smoothed"] = int(ep.size)
    return int(ep.size)
