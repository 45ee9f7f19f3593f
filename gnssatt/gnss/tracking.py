"""Tracking statistics of one receiver: per satellite and signal, epochs, span, mean C/N0, gaps, LLI count."""
from __future__ import annotations

import numpy as np


def signal_groups(codes: list[str]) -> dict[str, dict[str, int]]:
    """Signal id (band + attribute, e.g. '1C'; RINEX 2: '1', or 'P1' for P-code) -> {'C'|'L'|'D'|'S': index}.

    Implements: RINEX 3.05 sec. 5.1 observation codes (type letter + band digit + attribute).
    """
    groups: dict[str, dict[str, int]] = {}
    for i, code in enumerate(codes):
        kind = code[0]
        if kind == "P":  # RINEX 2 P-code pseudorange: its own signal
            groups.setdefault("P" + code[1:], {})["C"] = i
            continue
        if kind not in "CLDS" or len(code) < 2:
            continue
        groups.setdefault(code[1:], {})[kind] = i
    return groups


def tracking_table(obs, gap_factor: float = 1.5) -> list[dict]:
    """One dict per (satellite, signal) with data: epochs, first/last epoch (ISO GPS), mean C/N0 [dB-Hz],
    gaps (steps longer than gap_factor x interval) and loss-of-lock count (LLI bit 0 on the phase).

    Args:
        obs: a RinexObs (values/lli as (n_epochs, n_sats, n_codes), time as GpsTime).
    """
    n_epochs = len(obs.time)
    if n_epochs == 0:
        return []
    t_s = (obs.time - obs.time[0]).astype(np.float64)
    steps = np.diff(t_s)
    interval = float(np.median(steps)) if len(steps) else 0.0
    groups = signal_groups(list(obs.codes))
    iso = obs.time.iso()
    rows = []
    for j, sat in enumerate(obs.sats):
        for sig, members in sorted(groups.items()):
            cols = [members[k] for k in ("C", "L") if k in members] or list(members.values())
            seen = np.zeros(n_epochs, dtype=bool)
            for c in cols:
                seen |= np.isfinite(obs.values[:, j, c])
            if not seen.any():
                continue
            idx = np.flatnonzero(seen)
            gaps = int(np.sum(np.diff(t_s[idx]) > gap_factor * interval)) if interval > 0 else 0
            cn0 = None
            if "S" in members:
                s_vals = obs.values[idx, j, members["S"]]
                s_vals = s_vals[np.isfinite(s_vals) & (s_vals > 0)]
                cn0 = round(float(np.mean(s_vals)), 2) if len(s_vals) else None
            lol = 0
            if "L" in members:
                lli = obs.lli[idx, j, members["L"]]
                lol = int(np.sum((lli > 0) & ((lli & 1) == 1)))
            rows.append({"satellite": sat, "signal": sig, "epochs": int(len(idx)), "first_epoch": iso[idx[0]],
                         "last_epoch": iso[idx[-1]], "mean_cn0_dbhz": cn0, "gaps": gaps, "loss_of_lock": lol})
    return rows
