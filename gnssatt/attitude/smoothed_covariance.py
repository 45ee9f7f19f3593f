"""Covariance of the smoothed baselines under white plus time-correlated phase errors (issue 21 item 7).

The RTS recursion (gnssatt.attitude.smoother) treats every phase error as white: its P_k|N is that of a mean over
the N_k epochs the smoother effectively averages at k, which shrinks white noise by N_k but a time-correlated error
(multipath, uncalibrated PCV at the passing geometry) by far less. The variance of an N-epoch mean of a stationary
series with autocorrelation rho_l, over the white one (e.g. Priestley 1981, Spectral Analysis and Time Series,
eq. 5.3.5):

    G(N) = 1 + 2 sum_{l=1}^{N-1} (1 - l/N) rho_l

The reported covariance is P_k|N x s_k with

    s_k = (1 - f_k) / (1 - c) x G(N_k)

- rho_l from the data: the pooled autocorrelation of the used phase post-fit residuals over their (baseline,
  satellite, signal) arcs at lags l = 0..MAX_LAG epochs; the lags >= 1 divided by (1 - h), h = 3 / (phase rows per
  baseline and epoch), the mean leverage: the share of a slowly varying error the baseline absorbs (it is then in
  the estimate, not in the residuals);
- c = rho_1: the time-correlated share of the residual variance (the white part decorrelates within one epoch);
- f_k: the filter's information-weighted share of modelled correlated variance in the epoch's phase variances
  (smoother_data corr_share): (1 - f_k) x the model variance is the white part the filter estimated from triple
  differences, so the true variance is that / (1 - c) and the model's correlated part, whatever its size, is
  replaced by the one the residuals show;
- N_k = tr(P1_k) / tr(P_k|N) on the baselines, P1_k = (P_k|k^-1 - P_k|k-1^-1)^-1 the epoch's own information on
  the sub-state: the epochs' worth of information the smoothed estimate holds (one-sided near a run's ends).

Not seen by any residual: a constant baseline error (uncalibrated PCO, the mean of an uncalibrated PCV over the
pass) is absorbed whole into the baselines; calibration (calibrated_baselines, PCV maps) is what removes it.
"""
from __future__ import annotations

import numpy as np

__all__ = ["residual_autocorrelation", "phase_leverage", "mean_variance_gain", "effective_epochs",
           "covariance_scale", "MAX_LAG"]

#: longest lag of the residual autocorrelation (epochs); N_k is capped at it
MAX_LAG = 600


def residual_autocorrelation(residuals: dict, fixed: np.ndarray, max_lag: int = MAX_LAG) -> tuple[np.ndarray, int]:
    """(rho (max_lag + 1,) with rho_0 = 1, number of residuals) of the used phase post-fit residuals of fixed
    baselines (residuals.csv columns, fixed (n_ep, n_bl) bool), pooled over their (bl, sat, sig) arcs: sum of the
    lagged products over the number of pairs, per lag, over the lag-0 value (module doc). No residuals: white."""
    ep, bl = residuals["epoch"], residuals["bl"]
    sel = (residuals["kind"] == 1) & (residuals["reason"] == 0)
    sel &= fixed[np.clip(ep, 0, fixed.shape[0] - 1), np.clip(bl, 0, fixed.shape[1] - 1)]
    rho = np.zeros(max_lag + 1)
    rho[0] = 1.0
    if sel.sum() < 2:
        return rho, int(sel.sum())
    e, v = ep[sel], residuals["residual_m"][sel]
    key = (bl[sel].astype(np.int64) * 100_000 + residuals["sat"][sel]) * 100 + residuals["sig"][sel]
    order = np.lexsort((e, key))
    e, v, key = e[order], v[order], key[order]
    num, cnt = np.zeros(max_lag + 1), np.zeros(max_lag + 1)
    for ea, va in zip(np.split(e, np.flatnonzero(np.diff(key)) + 1), np.split(v, np.flatnonzero(np.diff(key)) + 1)):
        n = int(ea[-1] - ea[0]) + 1
        a, m = np.zeros(n), np.zeros(n)
        a[ea - ea[0]], m[ea - ea[0]] = va, 1.0
        size = 1 << int(np.ceil(np.log2(2 * n)))
        fa, fm = np.fft.rfft(a, size), np.fft.rfft(m, size)
        k = min(max_lag, n - 1) + 1
        num[:k] += np.fft.irfft(fa * np.conj(fa), size)[:k]
        cnt[:k] += np.fft.irfft(fm * np.conj(fm), size)[:k]
    c = np.where(cnt > 0.5, num / np.maximum(cnt, 1.0), 0.0)
    if c[0] > 0:
        rho = c / c[0]
    return rho, int(sel.sum())


def phase_leverage(residuals: dict, n_params: int = 3) -> float:
    """Mean leverage h = n_params / (used phase rows per baseline and epoch) of the baselines (module doc)."""
    sel = (residuals["kind"] == 1) & (residuals["reason"] == 0)
    if not sel.any():
        return 0.0
    rows = np.unique(residuals["epoch"][sel].astype(np.int64) * 1000 + residuals["bl"][sel], return_counts=True)[1]
    return float(np.mean(np.minimum(n_params / rows, 0.9)))


def mean_variance_gain(rho: np.ndarray, n_epochs: np.ndarray) -> np.ndarray:
    """G(N) = 1 + 2 sum_{l=1}^{N-1} (1 - l/N) rho_l per N (n,) (module doc; N in epochs, floored, within
    1..len(rho)); at least 1 (a pooled estimate's noise at long lags must not shrink the white variance)."""
    n = np.clip(np.floor(n_epochs), 1, len(rho)).astype(np.int64)
    l = np.arange(1, len(rho))
    s0 = np.concatenate([[0.0], np.cumsum(rho[1:])])          # sum_{l<j} rho_l for j = 1..
    s1 = np.concatenate([[0.0], np.cumsum(l * rho[1:])])
    g = 1.0 + 2.0 * (s0[n - 1] - s1[n - 1] / n)
    return np.maximum(g, 1.0)


def effective_epochs(P_post: np.ndarray, P_prior: np.ndarray, P_smooth: np.ndarray, r0: int) -> np.ndarray:
    """N_k (n,) = tr(P1_k) / tr(P_k|N) over the baseline block (rows r0:) of the sub-state, P1_k the inverse of the
    epoch's information P_k|k^-1 - P_k|k-1^-1 (module doc); 1 where that is not positive definite or not finite."""
    out = np.ones(P_post.shape[0])
    ok = np.isfinite(P_post).all((1, 2)) & np.isfinite(P_prior).all((1, 2)) & np.isfinite(P_smooth).all((1, 2))
    k = np.flatnonzero(ok)
    if k.size == 0:
        return out
    with np.errstate(all="ignore"):
        try:
            info = np.linalg.inv(P_post[k]) - np.linalg.inv(P_prior[k])
            t1 = np.trace(np.linalg.inv(info[:, r0:, r0:]), axis1=1, axis2=2)
        except np.linalg.LinAlgError:          # one singular epoch: epoch by epoch
            t1 = np.array([_own_trace(P_post[i], P_prior[i], r0) for i in k])
        ts = np.trace(P_smooth[k, r0:, r0:], axis1=1, axis2=2)
        good = np.isfinite(t1) & (t1 > 0) & (ts > 0)
    out[k[good]] = t1[good] / ts[good]
    return out


def _own_trace(P_post: np.ndarray, P_prior: np.ndarray, r0: int) -> float:
    """tr(P1) of one epoch (effective_epochs), nan if singular."""
    try:
        info = np.linalg.inv(P_post) - np.linalg.inv(P_prior)
        return float(np.trace(np.linalg.inv(info[r0:, r0:])))
    except np.linalg.LinAlgError:
        return float("nan")


def covariance_scale(fr, P_smooth: np.ndarray, ep: np.ndarray, r0: int) -> tuple[np.ndarray, dict]:
    """(s_k (ep.size,), info) for the smoothed epochs ep of a FilterResult with smoother_data: P_rep = s_k P_k|N
    (module doc). info: summary.json's smoother "covariance" entry."""
    sd = fr.smoother_data
    rho, n_res = residual_autocorrelation(fr.residuals, fr.fixed)
    h = phase_leverage(fr.residuals)
    rho[1:] /= 1.0 - h
    c = float(np.clip(rho[1], 0.0, 0.95))
    n_eff = np.minimum(effective_epochs(sd["P_post"][ep], sd["P_prior"][ep], P_smooth[ep], r0), MAX_LAG)
    f = np.clip(np.asarray(sd.get("corr_share", np.zeros(fr.fixed.shape[0])))[ep], 0.0, 1.0)
    g = mean_variance_gain(rho, n_eff)
    s = (1.0 - f) / (1.0 - c) * g
    info = {"method": "white + time-correlated split of the phase post-fit residuals (autocorrelation), the "
                      "correlated part averaged over the smoother's effective epochs",
            "phase_residuals": n_res, "correlated_share": c, "leverage": h,
            "autocorrelation_10_60_300": [float(rho[min(l, MAX_LAG)]) for l in (10, 60, 300)],
            "effective_epochs_median": float(np.median(n_eff)) if ep.size else None,
            "scale_median": float(np.median(s)) if ep.size else None}
    return s, info
