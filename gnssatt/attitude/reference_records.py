"""The attitude filter's per-observation records in readable numpy: one row per available SD code and phase per
epoch (residuals.csv: epoch, baseline, satellite, signal, antenna-frame elevation and azimuth, C/N0, kind,
post-fit residual, reason), and the memory of the triple differences carried to the next epoch.

This is the specification of the compiled kernel gnssatt.attitude.qc_kernels.record_epoch
(tests/attitude/test_qc_kernels.py). Plain numpy, no numba.

Implements: seed 000 Fig. 2 "output" (residual monitoring); reason codes of gnssatt.attitude.reference_qc
(5 = phase rejected by the TD test or unused for another phase-only reason).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.attitude.reference_update import UsedRows

__all__ = ["EpochFlags", "epoch_residual_rows", "residual_table", "triple_difference_memory", "R_TD_PHASE"]

R_TD_PHASE = 5


@dataclass
class EpochFlags:
    """(n_bl, n_sat, n_sig) availability, use and reason of each observation after the QC."""
    avail_c: np.ndarray
    avail_p: np.ndarray
    use_c: np.ndarray
    use_p: np.ndarray
    reason: np.ndarray


def epoch_residual_rows(k: int, flags: EpochFlags, el_ant_rad: np.ndarray, az_ant_rad: np.ndarray,
                        cn0_dbhz: np.ndarray, post_m: np.ndarray, rows: UsedRows) -> dict | None:
    """Epoch k's records, None without an available code: columns of the code rows (every available code in
    (bl, sat, sig) order) with the code residual post_m[r] of code row r (NaN where not in the update, or all NaN
    when post_m is empty), the phase residual and reasons of the same observations, and which have a phase."""
    jr, sr, fr = np.nonzero(flags.avail_c)
    if not jr.size:
        return None
    lookup = np.full((2,) + flags.avail_c.shape, np.nan)
    if post_m.size:
        lookup[0, rows.jc, rows.sc, rows.fc] = post_m[:rows.n_code]
        lookup[1, rows.jp, rows.sp, rows.fp] = post_m[rows.n_code:]
    reason = flags.reason[jr, sr, fr]
    reason_c = np.where(flags.use_c[jr, sr, fr], 0, reason)
    reason_p = np.where(flags.use_p[jr, sr, fr], 0, np.where(reason == 0, R_TD_PHASE, reason))
    return {"epoch": np.full(jr.size, k, np.int64), "bl": jr.astype(np.int64), "sat": sr.astype(np.int64),
            "sig": fr.astype(np.int64), "el_ant_deg": np.degrees(el_ant_rad[jr, sr]),
            "az_ant_deg": np.degrees(np.mod(az_ant_rad[jr, sr], 2 * np.pi)), "cn0_dbhz": cn0_dbhz[jr, sr, fr],
            "residual_code_m": lookup[0, jr, sr, fr], "reason_code": reason_c,
            "residual_phase_m": lookup[1, jr, sr, fr], "reason_phase": reason_p,
            "has_phase": flags.avail_p[jr, sr, fr]}


def residual_table(blocks: list[dict]) -> dict:
    """residuals.csv columns of epochs in order (epoch_residual_rows blocks): per epoch its code rows (kind 0),
    then its phase rows (kind 1, where a phase exists)."""
    cat = {key: np.concatenate([b[key] for b in blocks]) for key in blocks[0]}
    keep = cat["has_phase"]
    cols = ("epoch", "bl", "sat", "sig", "el_ant_deg", "az_ant_deg", "cn0_dbhz")
    code = {**{c: cat[c] for c in cols}, "kind": np.zeros(keep.size, np.int64), "residual_m": cat["residual_code_m"],
            "reason": cat["reason_code"].astype(np.int64)}
    phase = {**{c: cat[c][keep] for c in cols}, "kind": np.ones(int(keep.sum()), np.int64),
             "residual_m": cat["residual_phase_m"][keep], "reason": cat["reason_phase"].astype(np.int64)[keep]}
    order = np.argsort(2 * np.concatenate([code["epoch"], phase["epoch"]])
                       + np.concatenate([code["kind"], phase["kind"]]), kind="stable")
    return {key: np.concatenate([code[key], phase[key]])[order] for key in code}


def triple_difference_memory(sdc_c_m: np.ndarray, sdp_c_m: np.ndarray, flags: EpochFlags, b_out_m: np.ndarray,
                             u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(prev_sdc, prev_sdp, prev_ub) for the next epoch's triple differences: the clock-corrected SDs where
    available (else NaN) and the predicted geometry b u^T of the epoch's output baselines (n_bl, 3)."""
    return (np.where(flags.avail_c, sdc_c_m, np.nan), np.where(flags.avail_p, sdp_c_m, np.nan), b_out_m @ u.T)
