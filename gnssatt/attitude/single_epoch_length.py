"""Seed 000's length validation of a first fix on a solution of the epoch's own data: the baseline from this
epoch's phase single differences with the candidate DD integers, by least squares, without the filter's prior.

Today's test (gnssatt.attitude.ambiguity) takes the length of the filter's conditional baseline
b_fix = b - Q_ba Q_aa^-1 (a - a_fix), which leans on everything the filter has accumulated; seed 000 sec. 2
validates "the baseline computed with the candidate integers" of the epoch. Here, per signal group (a reference
satellite r and the others s with DD integers N_sr):
    SD_s - pcv_s - lambda (A_r + N_sr) = -u_s . b + cf_s c_g + e,
    SD_r - pcv_r - lambda A_r = -u_r . b + cf_r c_g + e
with unknowns b (3) and one clock c_g per group (it absorbs the phase clock and the error of the reference's float
A_r, which enters every row of the group alike); equal weights. n_dd - 3 degrees of freedom (n_dd >= 3 needed).

Implements: seed 000 sec. 2 (baseline-length validation of the candidate integers), the single-difference phase
model of gnssatt.attitude.filter (eq. 1) with the ambiguities fixed; ordinary least squares.
"""
from __future__ import annotations

import numpy as np

__all__ = ["single_epoch_baseline"]


def single_epoch_baseline(D: np.ndarray, a_fix: np.ndarray, x: np.ndarray, n_fixed_part: int, amb_key: np.ndarray,
                          sdp_m: np.ndarray, pcv_m: np.ndarray, u: np.ndarray, cfac: np.ndarray,
                          wavelength_m: np.ndarray) -> np.ndarray | None:
    """The baseline (3,) m (ECEF) of the epoch's phase SDs with the DD integers a_fix of the two-term rows D
    (+1 at the satellite's ambiguity state, -1 at its reference's), or None when fewer than 3 DDs have data.

    Args:
        x: filter state (only the references' float ambiguities are read); amb_key (n_amb, 3): (baseline,
            satellite, signal) of each ambiguity state (state index - n_fixed_part).
        sdp_m, pcv_m: (n_bl, n_sat, n_sig) the epoch's clock-corrected SD phase and PCV correction (m).
        u: (n_sat, 3) line-of-sight unit vectors; cfac: (n_sat,) clock partials; wavelength_m: (n_sat, n_sig) per satellite (GLONASS FDMA).
    """
    rows, groups = [], {}
    for drow, n_int in zip(D, a_fix):
        pos, neg = np.flatnonzero(drow > 0.5), np.flatnonzero(drow < -0.5)
        if pos.size != 1 or neg.size != 1:
            continue
        p, r = int(pos[0]), int(neg[0])
        g = groups.setdefault(r, len(groups))
        rows.append((p, x[r] + float(n_int), g))
    for r, g in groups.items():
        rows.append((r, x[r], g))
    A, y = [], []
    for idx, amb_cyc, g in rows:
        j, sat, f = (int(v) for v in amb_key[idx - n_fixed_part])
        obs = sdp_m[j, sat, f] - pcv_m[j, sat, f] - wavelength_m[sat, f] * amb_cyc
        if not np.isfinite(obs) or not np.all(np.isfinite(u[sat])):
            continue
        row = np.zeros(3 + len(groups))
        row[:3] = -u[sat]
        row[3 + g] = cfac[sat]
        A.append(row)
        y.append(obs)
    if len(y) - len(groups) < 3:
        return None
    A, y = np.array(A), np.array(y)
    used = np.abs(A[:, 3:]).sum(0) > 0                   # groups with at least one row
    A = np.concatenate([A[:, :3], A[:, 3:][:, used]], axis=1)
    if np.linalg.matrix_rank(A) < A.shape[1]:
        return None
    sol, *_ = np.linalg.lstsq(A, y, rcond=None)
    return sol[:3]
