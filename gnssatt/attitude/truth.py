"""Scoring an attitude solution against the simulator's truth files (gnssatt.sim: truth/attitude.csv, arcs.csv,
receivers.csv): attitude errors, integer ambiguities, cycle slips and clock jumps. Used by the tests and bench/.

Integers: every integer constraint the filter applied is in `FilterResult.fix_log` (a double difference SD(sat) -
SD(ref) per baseline and signal, from the epoch it was fixed to the last epoch both arcs stayed in the filter). The
truth double difference at an epoch is (N_b,sat - N_a,sat) - (N_b,ref - N_a,ref) of the arcs covering that epoch
(the simulator's receiver and satellite phase biases cancel in it). A constraint is wrong at an epoch when the two
differ; an undetected slip after the fix shows the same way.

Signals: truth/arcs.csv names GPS "L1"/"L2" and GLONASS "R:G1"/"R:G2"; a solution's "G:L1"/"G:L2" are the GPS ones
(gnssatt.gnss.signals.SIGNAL_ALIASES), so a G+R or R-only solution is scored by the same arcs.

Attitude error: the rotation angle of R(q_est) R(q_true)^T (CONVENTIONS.md), and the yaw/pitch/roll differences
wrapped to [-180, 180) deg.
"""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from gnssatt.gnss import rotations as rot
from gnssatt.gnss.time import GpsTime

__all__ = ["truth_signal", "load_arcs", "ambiguity_at", "score_fixes", "truth_at", "attitude_errors_deg", "lag_deg",
           "slips_seen_by_single_differences", "clock_jump_match"]


_TRUTH_NAME = {"G:L1": "L1", "G:L2": "L2"}


def truth_signal(signal: str) -> str:
    """The name truth/arcs.csv gives a solution's signal ("G:L1" -> "L1"; "L1", "R:G1", "R:G2" as they are)."""
    return _TRUTH_NAME.get(signal, signal)


def _solution_signal(pobs, truth_name: str) -> int | None:
    """Index in pobs.signals of the signal truth/arcs.csv calls truth_name (None when the solution lacks it)."""
    for i, s in enumerate(pobs.signals):
        if truth_signal(s) == truth_name:
            return i
    return None


def load_arcs(truth_dir: Path, t0: GpsTime) -> dict:
    """{(antenna, sat, signal): [(start_s, end_s, N)]} of truth/arcs.csv with times in seconds since t0."""
    arcs: dict = {}
    for r in csv.DictReader(open(Path(truth_dir) / "arcs.csv")):
        t1 = float(GpsTime.from_iso(r["start_time_gps"]) - t0)
        t2 = float(GpsTime.from_iso(r["end_time_gps"]) - t0)
        arcs.setdefault((r["antenna"], r["sat"], r["signal"]), []).append((t1, t2, int(r["ambiguity_cyc"])))
    return arcs


def ambiguity_at(arcs: dict, key, t_s: np.ndarray) -> np.ndarray:
    """Truth integer ambiguity (cycles) of the arc of key (antenna, sat, signal) covering each time t_s (s since
    the arcs' t0; NaN outside every arc). Arc ends are matched within 0.5 s (1 Hz epochs)."""
    out = np.full(t_s.shape, np.nan)
    for t1, t2, n in arcs.get(key, []):
        out[(t_s >= t1 - 0.5) & (t_s <= t2 + 0.5)] = n
    return out


def score_fixes(sol, truth_dir: Path) -> dict:
    """{"constraints", "wrong_constraints", "wrong_epochs" (n_ep, n_bl) bool, "details" [str],
    "unscored_constraints" (no truth arc covers them: a signal or satellite the truth does not name)} of a solution.

    wrong_epochs[k, j]: at epoch k baseline j held at least one wrong integer constraint.
    """
    fr, pobs = sol.fr, sol.pobs
    t_s = np.asarray(pobs.time - pobs.time[0], float)
    arcs = load_arcs(truth_dir, pobs.time[0])
    log = fr.fix_log
    n_ep, n_bl = fr.ok.shape
    wrong_ep = np.zeros((n_ep, n_bl), bool)
    details = []
    n_wrong = n_unscored = 0
    for i in range(log["epoch"].size):
        j, f = int(log["bl"][i]), int(log["sig"][i])
        a, b = sol.baselines[j]
        sig, s1, s0 = truth_signal(pobs.signals[f]), pobs.sats[log["sat"][i]], pobs.sats[log["ref_sat"][i]]
        ks = np.arange(log["epoch"][i], log["last_epoch"][i] + 1)
        tt = t_s[ks]
        truth = (ambiguity_at(arcs, (b, s1, sig), tt) - ambiguity_at(arcs, (a, s1, sig), tt)) \
            - (ambiguity_at(arcs, (b, s0, sig), tt) - ambiguity_at(arcs, (a, s0, sig), tt))
        n_unscored += int(not np.isfinite(truth).any())
        bad = np.isfinite(truth) & (np.round(truth) != np.round(log["dd_cyc"][i]))
        if bad.any():
            n_wrong += 1
            wrong_ep[ks[bad], j] = True
            if len(details) < 20:
                details.append(f"bl {j} {sig} {s1}-{s0} fixed {log['dd_cyc'][i]:.0f} at epoch {log['epoch'][i]}, "
                               f"truth {np.unique(truth[bad])} at {bad.sum()} of {ks.size} epochs "
                               f"(first {ks[bad][0]})")
    return {"constraints": int(log["epoch"].size), "wrong_constraints": n_wrong, "wrong_epochs": wrong_ep,
            "details": details, "unscored_constraints": n_unscored}


def truth_at(set_dir: Path, sol) -> tuple[np.ndarray, np.ndarray]:
    """(q_body_from_ecef (n, 4), yaw/pitch/roll deg (n, 3)) of set_dir/truth/attitude.csv at the solution's
    attitude epochs."""
    rows = {r["time_gps"]: r for r in csv.DictReader(open(Path(set_dir) / "truth" / "attitude.csv"))}
    iso = np.asarray(sol.pobs.time.iso(3))[sol.att_epochs]
    q = np.array([[float(rows[t][k]) for k in ("qe_w", "qe_x", "qe_y", "qe_z")] for t in iso])
    e = np.array([[float(rows[t][k]) for k in ("yaw_deg", "pitch_deg", "roll_deg")] for t in iso])
    return q, e


def attitude_errors_deg(set_dir: Path, sol) -> tuple[np.ndarray, np.ndarray]:
    """(rotation angle error (n,), yaw/pitch/roll errors wrapped to [-180, 180) (n, 3)) in deg of the solution
    against the truth, at its attitude epochs."""
    q, e = truth_at(set_dir, sol)
    ang = rot.attitude_error_deg(sol.q_body_from_ecef, q)
    de = (sol.euler_deg - e + 180.0) % 360.0 - 180.0
    return ang, de


def lag_deg(set_dir: Path, sol, t_from_s: float) -> float:
    """Max over fixed epochs after t_from_s (s since the first epoch) of the 15-s running mean of the Euler errors
    (the lag behind a manoeuvre; white noise averages out), deg."""
    _, de = attitude_errors_deg(set_dir, sol)
    f = sol.att_fixed
    t = np.asarray(sol.pobs.time - sol.pobs.time[0], float)[sol.att_epochs]
    k = np.ones(15)
    n = np.convolve(f * 1.0, k, "same")
    sm = np.array([np.convolve(np.where(f, de[:, i], 0.0), k, "same") for i in range(3)]).T / np.maximum(n, 1)[:, None]
    late = f & (t >= t_from_s) & (n >= 10)
    return np.abs(sm[late]).max()


def slips_seen_by_single_differences(sol, truth_dir: Path) -> list[tuple[str, str, float]]:
    """Truth slips (sat, signal, time s since the first epoch) on a phase that forms a single difference of some
    baseline at the slip epoch and the one before (the only slips a differential filter can see)."""
    po = sol.pobs
    t = np.asarray(po.time - po.time[0], float)
    ants = list(po.antennas)
    out = []
    for r in csv.DictReader(open(Path(truth_dir) / "arcs.csv")):
        if r["cause"] != "slip":
            continue
        ts = float(GpsTime.from_iso(r["start_time_gps"]) - po.time[0])
        k = int(np.argmin(np.abs(t - ts)))
        if k == 0 or abs(t[k] - ts) > 0.5 or t[k] - t[k - 1] > 1.5:
            continue
        fi = _solution_signal(po, r["signal"])
        if fi is None or r["sat"] not in po.sats:
            continue
        si, a = po.sats.index(r["sat"]), ants.index(r["antenna"])
        ok = np.isfinite(po.phase_m[:, k - 1:k + 1, si, fi]).all(axis=1)
        if any(ok[ants.index(x)] and ok[ants.index(y)] and a in (ants.index(x), ants.index(y))
               for x, y in sol.baselines):
            out.append((r["sat"], po.signals[fi], ts))
    return out


def clock_jump_match(sol, truth_dir: Path) -> tuple[list, list, list]:
    """(truth jumps (antenna, t s), missed truth jumps, spurious clock_jump events) of truth/receivers.csv against
    the solution's events: a truth jump is found by an event within 2 s on a baseline that includes its receiver."""
    t = np.asarray(sol.pobs.time - sol.pobs.time[0], float)
    rows: dict = {}
    for r in csv.DictReader(open(Path(truth_dir) / "receivers.csv")):
        rows.setdefault(r["antenna"], []).append((float(GpsTime.from_iso(r["time_gps"]) - sol.pobs.time[0]),
                                                  int(r["clock_jumps_ms"])))
    jumps = [(a, v[i][0]) for a, v in rows.items() for i in range(1, len(v)) if v[i][1] != v[i - 1][1]]
    evs = [(sol.baselines[e["baseline"]], t[e["epoch"]]) for e in sol.fr.events if e["event"] == "clock_jump"]
    missed = [x for x in jumps if not any(x[0] in bl and abs(te - x[1]) <= 2.0 for bl, te in evs)]
    spurious = [e for e in evs if not any(a in e[0] and abs(e[1] - tj) <= 2.0 for a, tj in jumps)]
    return jumps, missed, spurious
