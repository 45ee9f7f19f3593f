"""Scoring an attitude solution's integer ambiguities against the simulator's truth/arcs.csv.

Every integer constraint the filter applied is in `FilterResult.fix_log` (a double difference SD(sat) - SD(ref)
per baseline and signal, from the epoch it was fixed to the last epoch both arcs stayed in the filter). The truth
double difference at an epoch is (N_b,sat - N_a,sat) - (N_b,ref - N_a,ref) of the arcs covering that epoch
(the simulator's receiver and satellite phase biases cancel in it). A constraint is wrong at an epoch when the two
differ; an undetected slip after the fix shows the same way.
"""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from gnssatt.gnss.time import GpsTime

__all__ = ["load_arcs", "score_fixes"]


def load_arcs(truth_dir: Path, t0: GpsTime) -> dict:
    """{(antenna, sat, signal): [(start_s, end_s, N)]} with times in seconds since t0."""
    arcs: dict = {}
    for r in csv.DictReader(open(Path(truth_dir) / "arcs.csv")):
        t1 = float(GpsTime.from_iso(r["start_time_gps"]) - t0)
        t2 = float(GpsTime.from_iso(r["end_time_gps"]) - t0)
        arcs.setdefault((r["antenna"], r["sat"], r["signal"]), []).append((t1, t2, int(r["ambiguity_cyc"])))
    return arcs


def _n_at(arcs: dict, key, t_s: np.ndarray) -> np.ndarray:
    out = np.full(t_s.shape, np.nan)
    for t1, t2, n in arcs.get(key, []):
        out[(t_s >= t1 - 0.5) & (t_s <= t2 + 0.5)] = n
    return out


def score_fixes(sol, truth_dir: Path) -> dict:
    """{"constraints", "wrong_constraints", "wrong_epochs" (n_ep, n_bl) bool, "details" [str]} of a solution.

    wrong_epochs[k, j]: at epoch k baseline j held at least one wrong integer constraint.
    """
    fr, pobs = sol.fr, sol.pobs
    t_s = np.asarray(pobs.time - pobs.time[0], float)
    arcs = load_arcs(truth_dir, pobs.time[0])
    log = fr.fix_log
    n_ep, n_bl = fr.ok.shape
    wrong_ep = np.zeros((n_ep, n_bl), bool)
    details = []
    n_wrong = 0
    for i in range(log["epoch"].size):
        j, f = int(log["bl"][i]), int(log["sig"][i])
        a, b = sol.baselines[j]
        sig, s1, s0 = pobs.signals[f], pobs.sats[log["sat"][i]], pobs.sats[log["ref_sat"][i]]
        ks = np.arange(log["epoch"][i], log["last_epoch"][i] + 1)
        tt = t_s[ks]
        truth = (_n_at(arcs, (b, s1, sig), tt) - _n_at(arcs, (a, s1, sig), tt)) \
            - (_n_at(arcs, (b, s0, sig), tt) - _n_at(arcs, (a, s0, sig), tt))
        bad = np.isfinite(truth) & (np.round(truth) != np.round(log["dd_cyc"][i]))
        if bad.any():
            n_wrong += 1
            wrong_ep[ks[bad], j] = True
            if len(details) < 20:
                details.append(f"bl {j} {sig} {s1}-{s0} fixed {log['dd_cyc'][i]:.0f} at epoch {log['epoch'][i]}, "
                               f"truth {np.unique(truth[bad])} at {bad.sum()} of {ks.size} epochs "
                               f"(first {ks[bad][0]})")
    return {"constraints": int(log["epoch"].size), "wrong_constraints": n_wrong, "wrong_epochs": wrong_ep,
            "details": details}
