"""The time-to-first-fix study: one set (every configuration and method) and many sets (seed 000 Table 5 layout,
shares, wrong fixes, single-epoch success rates).

Methods (rows of runs.csv, column `method`):
- ``filter``: the attitude EKF of seed 000 (gnssatt.attitude.filter, Table 1 settings, Earth-pointing start,
  MLAMBDA + 3 cm length validation) -- the paper's method; TTFF = first accepted fix of the baseline.
- ``filter-constrained``: the same EKF with the body-constrained search (attitude setting
  ``ambiguity_search="constrained"``), when the attitude filter offers it.
- ``epoch-lambda``: every epoch on its own, per baseline MLAMBDA + length validation (gnssatt.ttff.single_epoch).
- ``epoch-constrained``: every epoch on its own, MC-LAMBDA (C-LAMBDA for one baseline) + ratio/length/angle
  validation.
For the ``epoch-*`` methods the TTFF is the first epoch whose own solution is accepted; their single-epoch success
rate is the share of sampled epochs (every ``single_epoch_step_s``) with an accepted *and right* fix.

Implements: seed 000 sec. 5 and Table 5 (TTFF per baseline for L1/L2, L1, L2; instant-fix share and mean
non-zero TTFF), issue 7 (right/wrong against truth, single-epoch success).
"""
from __future__ import annotations

import copy
import math
import time
from dataclasses import asdict, dataclass, field

import numpy as np

from gnssatt.ttff.data import StudySet, initial_offset_euler_deg, subset_signals
from gnssatt.ttff.single_epoch import (WRONG_FIX_DEG, SingleEpochOptions, epoch_problem, solve_constrained,
                                      solve_lambda)

__all__ = ["CONFIGURATIONS", "METHODS", "StudyOptions", "run_set", "summarize", "table5_rows", "table5_markdown",
           "runs_csv", "RUN_COLUMNS"]

CONFIGURATIONS = {"L1+L2": ("L1", "L2"), "L1": ("L1",), "L2": ("L2",)}
METHODS = ("filter", "filter-constrained", "epoch-lambda", "epoch-constrained")
RUN_COLUMNS = ("set", "yaw_deg", "pitch_deg", "roll_deg", "configuration", "baseline", "method", "ttff_s",
               "fix_right", "fix_error_deg", "wrong_fixed_epochs", "fixed_epochs", "off_3deg_fixed_epochs",
               "single_epoch_n",
               "single_epoch_success", "single_epoch_accepted", "single_epoch_wrong", "single_epoch_best_right",
               "seconds", "note")


#: Study-level AR settings of the paper's method per configuration (decision, docs/ttff.md "Wrong fixes of L2"):
#: L2 alone (semi-codeless, 6 dB weaker, PCV x1.3) gives the 3 cm length test few, noisy DDs at the first epochs of
#: an off-pointed start, and a wrong candidate of the right length was accepted on 2 of 400 baselines; a first fix
#: of an L2-only baseline also needs the MLAMBDA ratio >= 2. L1+L2 and L1 keep seed 000's length test alone.
FILTER_SETTINGS_BY_CONFIGURATION: dict = {"L2": {"ambiguity": {"min_ratio_first_fix": 2.0}}}


@dataclass(frozen=True)
class StudyOptions:
    """What to run on every set."""

    configurations: tuple = ("L1+L2", "L1", "L2")
    methods: tuple = ("filter", "epoch-lambda", "epoch-constrained")
    max_duration_s: float | None = 120.0          # seconds of each set used (TTFFs beyond are "never")
    single_epoch_step_s: float = 10.0             # sampling of the single-epoch success rate
    filter_settings: dict = field(default_factory=dict)   # AttitudeSettings.override keywords (e.g. mode, {"ambiguity": {...}})
    # further AttitudeSettings overrides per configuration, applied after filter_settings
    filter_settings_by_configuration: dict = field(
        default_factory=lambda: copy.deepcopy(FILTER_SETTINGS_BY_CONFIGURATION))
    single_epoch: SingleEpochOptions = field(default_factory=SingleEpochOptions)
    wrong_fix_deg: float = WRONG_FIX_DEG

    def to_dict(self) -> dict:
        d = asdict(self)
        d["single_epoch"] = asdict(self.single_epoch)
        return d


def _bl_label(a: str, b: str) -> str:
    return f"{a}>{b}"


def _angle_deg(u: np.ndarray, v: np.ndarray) -> float:
    return math.degrees(math.atan2(float(np.linalg.norm(np.cross(u, v))), float(np.dot(u, v))))


def filter_integer_errors(ss: StudySet, fix_log: dict, signals: list[str]) -> np.ndarray | None:
    """(n_ep, n_bl) bool: baseline j held at least one wrong integer constraint at epoch k, or None without the
    simulator's truth integers.

    Every constraint of the filter's fix_log (DD SD(sat) - SD(ref) of a baseline and signal, from its epoch to its
    last_epoch) against the truth DD (N_b,sat - N_a,sat) - (N_b,ref - N_a,ref) of the arcs covering each epoch
    (the simulator's receiver and satellite phase biases cancel in it; gnssatt/attitude/truth.py does the same).
    """
    if ss.truth is None or ss.truth.n_cyc is None or fix_log is None:
        return None
    n = ss.truth.n_cyc
    n_ep, n_bl = n.shape[1], len(ss.bl_idx)
    wrong = np.zeros((n_ep, n_bl), bool)
    sig_full = [ss.pobs.signals.index(sg) for sg in signals]
    for i in range(np.asarray(fix_log["epoch"]).size):
        j, f = int(fix_log["bl"][i]), sig_full[int(fix_log["sig"][i])]
        ia, ib = ss.bl_idx[j]
        s1, s0 = int(fix_log["sat"][i]), int(fix_log["ref_sat"][i])
        ks = np.arange(int(fix_log["epoch"][i]), int(fix_log["last_epoch"][i]) + 1)
        truth = (n[ib, ks, s1, f] - n[ia, ks, s1, f]) - (n[ib, ks, s0, f] - n[ia, ks, s0, f])
        bad = np.isfinite(truth) & (np.round(truth) != np.round(float(fix_log["dd_cyc"][i])))
        wrong[ks[bad], j] = True
    return wrong


def _filter_runs(ss: StudySet, cfg: str, method: str, opts: StudyOptions) -> list[dict]:
    from gnssatt.attitude.filter import run_filter
    from gnssatt.attitude.settings import AttitudeSettings

    t0 = time.process_time()
    sigs = list(CONFIGURATIONS[cfg])
    # the paper's method: preset seed000 = seed 000 Tables 1-2 (Table 2 editing masks explicitly)
    settings = (AttitudeSettings.preset("seed000", signals=sigs).override(**opts.filter_settings)
                .override(**opts.filter_settings_by_configuration.get(cfg, {})))
    if method == "filter-constrained":
        settings = settings.override(ambiguity={"ambiguity_search": "constrained"})
    pobs = subset_signals(ss.pobs, sigs)
    attitude_fn = None
    if len(ss.bl_idx) >= 2:
        from gnssatt.attitude.solution import attitude_from_baselines
        from gnssatt.gnss import rotations as rot

        def attitude_fn(b, fixed, k=None):
            q, _ = attitude_from_baselines(b[None], np.zeros((1, 3 * len(b), 3 * len(b))), ss.body_baselines_m,
                                           settings.attitude_method)
            return rot.quat_to_dcm(q[0])
    try:
        fr = run_filter(pobs, ss.geom, ss.bl_idx, ss.body_baselines_m, ss.boresight_body, settings,
                        ss.R_ref_from_ecef[0], attitude_fn)
    except Exception as exc:  # noqa: BLE001 - one failing run must not lose the study; it shows in the row
        note = f"filter failed: {type(exc).__name__}: {str(exc)[:120]}"
        return [{"baseline": _bl_label(a, b), "configuration": cfg, "method": method, "ttff_s": None,
                 "fix_right": None, "note": note, "seconds": round(time.process_time() - t0, 4)}
                for a, b in ss.baselines]
    t = ss.t_s
    rows = []
    int_wrong = filter_integer_errors(ss, fr.fix_log, sigs)
    for j, (a, b) in enumerate(ss.baselines):
        k = int(fr.first_fix_epoch[j]) if fr.first_fix_epoch is not None else -1
        ttff = float(t[k] - t[0]) if k >= 0 else None
        right, err, wrong_ep, off_ep = None, None, None, None
        fixed_ep = int(fr.fixed[:, j].sum())
        if ss.truth is not None:
            ok = ss.truth.ok & fr.fixed[:, j] & np.isfinite(fr.b_ecef_m[:, j]).all(-1)
            b_true = np.einsum("i,nij->nj", ss.body_baselines_m[j], np.nan_to_num(ss.truth.R_body_from_ecef))
            b_fix = fr.b_ecef_m[:, j]
            cosang = np.einsum("nj,nj->n", np.nan_to_num(b_fix), b_true)
            sinang = np.linalg.norm(np.cross(np.nan_to_num(b_fix), b_true), axis=-1)
            errs = np.where(ok, np.degrees(np.arctan2(sinang, cosang)), np.nan)
            off_ep = int(np.sum(errs[ok] > opts.wrong_fix_deg))
            wrong_ep = off_ep
            if k >= 0 and ss.truth.ok[k]:
                err = float(errs[k])
                right = bool(err <= opts.wrong_fix_deg)
        if int_wrong is not None:
            # exact: the filter's integer constraints against the simulator's truth integers
            wrong_ep = int(np.sum(int_wrong[:, j] & fr.fixed[:, j]))
            if k >= 0:
                right = not bool(int_wrong[k, j])
        rows.append({"baseline": _bl_label(a, b), "configuration": cfg, "method": method, "ttff_s": ttff,
                     "fix_right": right, "fix_error_deg": err, "wrong_fixed_epochs": wrong_ep,
                     "off_3deg_fixed_epochs": off_ep, "fixed_epochs": fixed_ep, "seconds": None})
    dt = time.process_time() - t0
    for r in rows:
        r["seconds"] = round(dt / max(len(rows), 1), 4)
    return rows


def _epoch_runs(ss: StudySet, cfg: str, methods: list[str], opts: StudyOptions) -> list[dict]:
    """TTFF and single-epoch success of the epoch-wise methods of one configuration."""
    sigs = list(CONFIGURATIONS[cfg])
    t = ss.t_s
    n_ep, q = len(t), len(ss.bl_idx)
    body = ss.body_baselines_m
    solvers = {"epoch-lambda": solve_lambda, "epoch-constrained": solve_constrained}
    step = max(opts.single_epoch_step_s, 1e-9)
    sample = set(np.flatnonzero(np.diff(np.floor((t - t[0]) / step), prepend=-1) > 0).tolist())
    cache: dict = {}
    seconds = {m: 0.0 for m in methods}

    def problem(k, m):
        # each method's own usability rule (SingleEpochOptions.usability); one problem when the rules agree
        kind = m.split("-", 1)[1]
        key = (k, opts.single_epoch.usability(kind))
        if key not in cache:
            cache[key] = epoch_problem(ss, k, sigs, opts.single_epoch, kind)
        return cache[key]

    out = []
    for m in methods:
        t0 = time.process_time()
        solver = solvers[m]
        first = np.full(q, -1)
        first_right: list = [None] * q
        stats = {key: np.zeros(q, np.int64) for key in ("n", "ok", "acc", "wrong", "best")}
        results: dict = {}
        # TTFF: epochs in order until every baseline has an accepted fix
        for k in range(n_ep):
            if (first >= 0).all():
                break
            p = problem(k, m)
            if p is None:
                continue
            res = solver(p, body, opts.single_epoch)
            results[k] = res
            for j in np.flatnonzero((first < 0) & res.accepted):
                first[j] = k
                first_right[j] = res.correct[j]
        # single-epoch success on the sampled epochs
        for k in sorted(sample):
            p = problem(k, m)
            if p is None:
                stats["n"] += 1                      # an epoch without a usable problem counts as a failure
                continue
            res = results.get(k) or solver(p, body, opts.single_epoch)
            for j in range(q):
                stats["n"][j] += 1
                stats["acc"][j] += bool(res.accepted[j])
                stats["ok"][j] += res.correct[j] is True
                stats["wrong"][j] += res.correct[j] is False
                stats["best"][j] += res.best_correct[j] is True
        seconds[m] = time.process_time() - t0
        for j, (a, b) in enumerate(ss.baselines):
            n = int(stats["n"][j])
            k = int(first[j])
            out.append({"baseline": _bl_label(a, b), "configuration": cfg, "method": m,
                        "ttff_s": float(t[k] - t[0]) if k >= 0 else None, "fix_right": first_right[j],
                        "fix_error_deg": None, "wrong_fixed_epochs": None, "fixed_epochs": None,
                        "single_epoch_n": n,
                        "single_epoch_success": round(stats["ok"][j] / n, 4) if n else None,
                        "single_epoch_accepted": int(stats["acc"][j]), "single_epoch_wrong": int(stats["wrong"][j]),
                        "single_epoch_best_right": int(stats["best"][j]),
                        "seconds": round(seconds[m] / max(q, 1), 4)})
    return out


def constrained_filter_available() -> bool:
    """True when the attitude filter offers ambiguity_search="constrained"."""
    from gnssatt.attitude.settings import FLAT_TO_NESTED

    return "ambiguity_search" in FLAT_TO_NESTED


def run_set(ss: StudySet, opts: StudyOptions) -> dict:
    """JSON-able result of one set: {"set", "initial_euler_deg", "runs": [row per configuration, baseline and
    method (RUN_COLUMNS)], "truth", "n_epochs", "seconds"}."""
    t0 = time.process_time()
    eul = initial_offset_euler_deg(ss)
    runs = []
    for cfg in opts.configurations:
        if not set(CONFIGURATIONS[cfg]) <= set(ss.pobs.signals):
            continue
        for m in opts.methods:
            if m == "filter-constrained" and not constrained_filter_available():
                continue
            if m.startswith("filter"):
                runs += _filter_runs(ss, cfg, m, opts)
        ep = [m for m in opts.methods if m.startswith("epoch")]
        if ep:
            runs += _epoch_runs(ss, cfg, ep, opts)
    for r in runs:
        r["set"] = ss.label
        r["yaw_deg"], r["pitch_deg"], r["roll_deg"] = (round(v, 2) for v in eul) if eul else (None, None, None)
        for c in RUN_COLUMNS:
            r.setdefault(c, None)
    return {"set": ss.label, "initial_euler_deg": [round(v, 3) for v in eul] if eul else None,
            "truth": ss.truth.source if ss.truth is not None else None, "n_epochs": int(len(ss.t_s)),
            "runs": [{c: r[c] for c in RUN_COLUMNS} for r in runs], "warnings": ss.warnings[:20],
            "seconds": round(time.process_time() - t0, 3)}


# ---------------------------------------------------------------------------------------------- many sets ---
def _fmt(v, nd=1) -> str:
    return "–" if v is None else f"{v:.{nd}f}"


def table5_rows(runs: list[dict], method: str) -> dict:
    """Seed 000 Table 5 layout of one method: {"columns", "rows", "footer"} (TTFF "–" = never fixed)."""
    rr = [r for r in runs if r["method"] == method]
    sets = list(dict.fromkeys(r["set"] for r in rr))
    cols = list(dict.fromkeys((r["configuration"], r["baseline"]) for r in rr))
    cols.sort(key=lambda c: (list(CONFIGURATIONS).index(c[0]) if c[0] in CONFIGURATIONS else 9, c[1]))
    cell = {(r["set"], r["configuration"], r["baseline"]): r for r in rr}
    eul = {r["set"]: (r["yaw_deg"], r["pitch_deg"], r["roll_deg"]) for r in rr}
    rows = []
    for s in sets:
        row = [_fmt(v) for v in eul[s]]
        for c in cols:
            r = cell.get((s,) + c)
            row.append("" if r is None else _fmt(r["ttff_s"]) + ("*" if r["fix_right"] is False else ""))
        rows.append(row)
    instant, mean_nz, never, wrong = [], [], [], []
    for c in cols:
        v = [cell[(s,) + c] for s in sets if (s,) + c in cell]
        tt = [r["ttff_s"] for r in v]
        instant.append(f"{100.0 * sum(x == 0 for x in tt) / len(tt):.0f}" if tt else "")
        nz = [x for x in tt if x is not None and x > 0]
        mean_nz.append(f"{np.mean(nz):.1f}" if nz else "–")
        never.append(str(sum(x is None for x in tt)))
        wrong.append(str(sum(r["fix_right"] is False for r in v)))
    return {"columns": ["Yaw [deg]", "Pitch [deg]", "Roll [deg]"] + [f"{c} {b} [s]" for c, b in cols],
            "rows": rows,
            "footer": [["Instant fix [%]", "", ""] + instant, ["Mean TTFF (> 0) [s]", "", ""] + mean_nz,
                       ["Never fixed", "", ""] + never, ["Wrong first fix", "", ""] + wrong]}


def table5_markdown(runs: list[dict], method: str) -> str:
    """Markdown of table5_rows (a wrong first fix is marked with *)."""
    t = table5_rows(runs, method)
    lines = ["| " + " | ".join(t["columns"]) + " |", "|" + "---|" * len(t["columns"])]
    for row in t["rows"] + t["footer"]:
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines) + "\n"


def table5_csv(runs: list[dict], method: str) -> str:
    t = table5_rows(runs, method)
    return "\n".join(",".join(x.replace(",", " ") for x in row) for row in [t["columns"]] + t["rows"] + t["footer"]) \
        + "\n"


def runs_csv(runs: list[dict]) -> str:
    """runs.csv text: RUN_COLUMNS, one row per set, configuration, baseline and method."""
    def cell(v):
        if v is None:
            return ""
        if isinstance(v, bool):
            return "1" if v else "0"
        return str(v)
    lines = [",".join(RUN_COLUMNS)]
    for r in runs:
        lines.append(",".join(cell(r.get(c)) for c in RUN_COLUMNS))
    return "\n".join(lines) + "\n"


def summarize(runs: list[dict]) -> dict:
    """Per method, configuration and baseline: starts, instant-fix share, mean non-zero TTFF, never fixed, wrong
    first fixes (and wrong fixed epochs for the filter), single-epoch success (pooled over sets); totals."""
    out: dict = {"methods": {}, "wrong_fixes_total": 0}
    keys = list(dict.fromkeys((r["method"], r["configuration"], r["baseline"]) for r in runs))
    for m, c, b in keys:
        v = [r for r in runs if (r["method"], r["configuration"], r["baseline"]) == (m, c, b)]
        tt = [r["ttff_s"] for r in v]
        nz = [x for x in tt if x is not None and x > 0]
        wrong = sum(r["fix_right"] is False for r in v)
        d = {"starts": len(v), "instant_fix_share": round(sum(x == 0 for x in tt) / len(v), 4),
             "instant_fix_right_share": round(sum(r["ttff_s"] == 0 and r["fix_right"] is not False for r in v)
                                              / len(v), 4),
             "mean_nonzero_ttff_s": round(float(np.mean(nz)), 2) if nz else None,
             "median_ttff_s": float(np.median([x for x in tt if x is not None])) if any(x is not None for x in tt)
             else None,
             "never_fixed": sum(x is None for x in tt), "wrong_first_fixes": wrong,
             "unverified_first_fixes": sum(r["ttff_s"] is not None and r["fix_right"] is None for r in v)}
        if m.startswith("filter"):
            d["wrong_fixed_epochs"] = int(sum(r["wrong_fixed_epochs"] or 0 for r in v))
            d["fixed_epochs"] = int(sum(r["fixed_epochs"] or 0 for r in v))
            d["off_3deg_fixed_epochs"] = int(sum(r.get("off_3deg_fixed_epochs") or 0 for r in v))
            errs = [r["fix_error_deg"] for r in v if r["fix_right"] and r.get("fix_error_deg") is not None]
            d["first_fix_direction_error_deg"] = ([round(float(np.mean(errs)), 3), round(float(np.std(errs)), 3)]
                                                  if errs else None)
        else:
            n = sum(r["single_epoch_n"] or 0 for r in v)
            ok = sum(round((r["single_epoch_success"] or 0) * (r["single_epoch_n"] or 0)) for r in v)
            d["single_epoch_epochs"] = n
            d["single_epoch_success"] = round(ok / n, 4) if n else None
            d["single_epoch_wrong"] = int(sum(r["single_epoch_wrong"] or 0 for r in v))
            d["single_epoch_accepted"] = int(sum(r["single_epoch_accepted"] or 0 for r in v))
            d["single_epoch_best_right"] = int(sum(r["single_epoch_best_right"] or 0 for r in v))
        out["methods"].setdefault(m, {}).setdefault(c, {})[b] = d
        out["wrong_fixes_total"] += wrong + int(d.get("single_epoch_wrong", 0))
    out["sets"] = len(dict.fromkeys(r["set"] for r in runs))
    return out
