"""The accuracy floor of a baseline on simulated data: epoch-by-epoch least squares of the single-differenced
carrier phases with the TRUE integer ambiguities (simulator truth/arcs.csv), independent of the filter.

Model per epoch, baseline b (second antenna minus first), satellite s, signal f (all in metres):

    SD_phase - lambda_f (N_second - N_first) = -u_s . b + (1 - rho_dot_s / c) c dt_f + e,

unknowns b (3) and one clock per signal (which makes it the double-difference solution; the receivers' fractional
phase biases and a common wind-up go into the clock). This is what any epoch-wise estimator with the right integers
computes (RTKLIB's fixed moving-base solution, gnssatt's kinematic mode): its scatter is the floor of both on
white-noise data. Weights: one sigma per signal (uniform when equal). Only the filter's inputs are shared
(observations on common epochs, line of sight and range rate from `sol.geom`); the ambiguities, the weighting and
the data selection are this module's.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gnssatt.attitude.truth import ambiguity_at, load_arcs
from gnssatt.gnss.constants import C_M_S

__all__ = ["true_integer_floor", "used_phase_mask"]


def used_phase_mask(sol) -> np.ndarray:
    """(n_ep, n_bl, n_sat, n_sig) bool: the phases the filter used in its update (residuals, reason 0)."""
    r = sol.fr.residuals
    n_ep, n_bl = sol.fr.ok.shape
    out = np.zeros((n_ep, n_bl, len(sol.pobs.sats), len(sol.pobs.signals)), bool)
    sel = (r["kind"] == 1) & (r["reason"] == 0)
    out[r["epoch"][sel], r["bl"][sel], r["sat"][sel], r["sig"][sel]] = True
    return out


def true_integer_floor(sol, truth_dir: Path, sigma_m=None, mask: np.ndarray | None = None) -> np.ndarray:
    """(n_ep, n_bl, 3) ECEF baselines (NaN where fewer than 2 + n_sig phases) by weighted least squares per epoch.

    sigma_m: per-signal SD phase sigma (n_sig,) for the weights (None: uniform); mask (n_ep, n_bl, n_sat, n_sig):
    the phases to use (None: every phase both antennas have).
    """
    pobs, geom = sol.pobs, sol.geom
    t_s = np.asarray(pobs.time - pobs.time[0], float)
    arcs = load_arcs(Path(truth_dir), pobs.time[0])
    lam = np.asarray(pobs.wavelength_sat_m, float)                                  # (n_sat, n_sig)
    n_ep, n_sat, n_sig = t_s.size, len(pobs.sats), len(pobs.signals)
    w_sig = np.ones(n_sig) if sigma_m is None else 1.0 / np.asarray(sigma_m, float)
    out = np.full((n_ep, len(sol.baselines), 3), np.nan)
    for j, (a, b) in enumerate(sol.baselines):
        ia, ib = pobs.antennas.index(a), pobs.antennas.index(b)
        dn = np.full((n_ep, n_sat, n_sig), np.nan)
        for s, sat in enumerate(pobs.sats):
            for f, sg in enumerate(pobs.signals):
                dn[:, s, f] = ambiguity_at(arcs, (b, sat, sg), t_s) - ambiguity_at(arcs, (a, sat, sg), t_s)
        sd = pobs.phase_m[ib] - pobs.phase_m[ia] - lam[None, :, :] * dn          # (n_ep, n_sat, n_sig)
        ok = np.isfinite(sd) & geom.valid[:, :, None]
        if mask is not None:
            ok &= mask[:, j]
        for k in range(n_ep):
            s_i, f_i = np.nonzero(ok[k])
            if s_i.size < 3 + n_sig + 1:
                continue
            H = np.zeros((s_i.size, 3 + n_sig))
            H[:, :3] = -geom.los_ecef[k, s_i]
            H[np.arange(s_i.size), 3 + f_i] = 1.0 - geom.range_rate_m_s[k, s_i] / C_M_S
            w = w_sig[f_i]
            x = np.linalg.lstsq(H * w[:, None], sd[k, s_i, f_i] * w, rcond=None)[0]
            out[k, j] = x[:3]
    return out
