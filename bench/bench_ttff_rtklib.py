"""RTKLIB 2.4.3 b34 moving-base (pyrtklib `postpos`) on the same simulated TTFF starts as bench/bench_ttff.py, one
baseline at a time, next to gnssatt (issue 7 item 4).

    .venv/bin/python -m bench.bench_ttff_rtklib --count 200 --seed 1      # -> /tmp/bench_ttff_rtklib.json
    .venv/bin/python -m bench.bench_ttff_rtklib --report [--write]         # table for docs/ttff.md

Same starts and files as `bench_ttff study --seed 1` (the simulator is deterministic: same seed and overrides, same
bytes). RTKLIB settings (a fair chance, as issue 7 lists them): moving base (base = GPS-2 by SPP every epoch,
rover = GPS-0 or GPS-1), L1+L2 (`pos1-frequency=l1+2`) or L1 (`l1`), `pos2-armode` fix-and-hold (TTFF) or
instantaneous (single-epoch success), ratio 3, elevation mask -90 deg, dynamics off, RAIM on
(`pos1-posopt5=on`), `pos2-baselen` = the known length with a loose `pos2-basesig` 0.1 m, broadcast ephemerides.
Known RTKLIB behaviour (stated, not worked around): moving-base models the base observations at the rover's time
tag, so receivers with free-running clocks give it wrong fixes unless their clock offsets are removed first; the
`ttff` preset's receivers are clock-steered (|dt| < 0.3 us), where this does not matter.

Scoring against the truth attitude (reference attitude of the set): a fixed epoch (Q = 1) whose baseline direction
is more than 3 deg from the truth is a wrong fix (gnssatt.ttff.single_epoch.WRONG_FIX_DEG); TTFF = time of the first
fixed epoch from the first epoch of the files.
"""
from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

MODES = {"fix-and-hold": "fix-and-hold", "instantaneous": "instantaneous"}
CONFIGS = {"L1+L2": "l1+2", "L1": "l1"}


def _angle_deg(u, v) -> np.ndarray:
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(u, v), axis=-1), np.einsum("ij,ij->i", u, v)))


def score_rtklib(sol, ss, j: int, wrong_deg: float) -> dict:
    """TTFF, instant fix, wrong fixes, fixed share and direction errors of one RTKLIB run on baseline j."""
    from gnssatt.gnss.frames import R_enu_from_ecef, ecef_to_geodetic

    keys = sol.epoch_keys_ms()
    tags = ss.pobs.time.s.astype(np.int64) * 1000 + np.round(ss.pobs.time.frac * 1000).astype(np.int64)
    idx = np.searchsorted(tags, keys)
    idx_c = np.clip(idx, 0, len(tags) - 1)
    hit = tags[idx_c] == keys
    k = idx_c[hit]
    enu = sol.vector_m[hit]
    fixed = sol.fixed[hit]
    lat, lon, _ = ecef_to_geodetic(ss.geom.r_platform_ecef_m[k])
    R = R_enu_from_ecef(lat, lon)                                  # (n, 3, 3) enu <- ecef
    b_true = np.einsum("i,nij->nj", ss.body_baselines_m[j], ss.truth.R_body_from_ecef[k])
    b_true_enu = np.einsum("nij,nj->ni", R, b_true)
    err = _angle_deg(enu, b_true_enu)
    t = ss.t_s
    n_ep = len(t)
    fk = k[fixed]
    ttff = float(t[fk[0]] - t[0]) if fk.size else None
    right = err[fixed] <= wrong_deg
    return {"ttff_s": ttff, "first_fix_right": bool(right[0]) if fk.size else None,
            "fixed_epochs": int(fixed.sum()), "wrong_fixed_epochs": int((~right).sum()),
            "right_fixed_epochs": int(right.sum()), "epochs": n_ep, "solution_epochs": int(hit.sum()),
            "err_right_deg": err[fixed][right].tolist()}


def run(count: int, seed: int, duration_s: float, out: Path, first: int = 0) -> None:
    from bench._ttff_common import set_files, study_payloads
    from bench.rtklib_runner import options_for, run_postpos
    from gnssatt.sim import simulate_scenario
    from gnssatt.ttff.data import load_study_set
    from gnssatt.ttff.single_epoch import WRONG_FIX_DEG

    pl = study_payloads(count, seed, duration_s)[first:]
    results = []
    t_all = time.perf_counter()
    for p in pl:
        tmp = Path(tempfile.mkdtemp(prefix="ttff_rtk_"))
        try:
            simulate_scenario("ttff", tmp, seed=int(p["seed"]), overrides=p["overrides"])
            ss = load_study_set(set_files(tmp), p["label"], truth_dir=tmp / "truth")
            rec = {"set": p["label"], "start": p["start"], "runs": []}
            for j, (a, b) in enumerate(ss.baselines):
                L = float(np.linalg.norm(ss.body_baselines_m[j]))
                for cfg, freq in CONFIGS.items():
                    for mode, armode in MODES.items():
                        opts = options_for("movingbase", **{
                            "pos1-frequency": freq, "pos2-armode": armode, "pos2-arthres": "3",
                            "pos1-elmask": "-90", "pos1-dynamics": "off", "pos1-posopt5": "on",
                            "pos2-baselen": f"{L:.4f}", "pos2-basesig": "0.1"})
                        sol = run_postpos(tmp / "obs" / f"{b}.rnx", tmp / "obs" / f"{a}.rnx",
                                          [tmp / "nav" / "brdc.rnx"], opts, tmp / "rtk" / f"{b}_{cfg}_{mode}.pos")
                        sc = score_rtklib(sol, ss, j, WRONG_FIX_DEG)
                        sc.update({"baseline": f"{a}>{b}", "configuration": cfg, "mode": mode,
                                   "seconds": round(sol.elapsed_s, 3),
                                   "cpu_s": round(sol.cpu_s, 3)})
                        rec["runs"].append(sc)
            results.append(rec)
            print(p["label"], f"{time.perf_counter() - t_all:.0f} s", flush=True)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        out.write_text(json.dumps({"count": count, "seed": seed, "duration_s": duration_s, "results": results}))


def summarize_rtklib(doc: dict) -> dict:
    """Per configuration, mode and baseline: instant-fix share, mean non-zero TTFF, wrong first fixes, wrong
    fixed epochs, single-epoch success (instantaneous: right fixed epochs / epochs), direction error, run time."""
    out: dict = {}
    for rec in doc["results"]:
        for r in rec["runs"]:
            d = out.setdefault(r["configuration"], {}).setdefault(r["mode"], {}).setdefault(r["baseline"], {
                "starts": 0, "instant": 0, "ttff_nz": [], "never": 0, "wrong_first": 0, "wrong_epochs": 0,
                "right_epochs": 0, "epochs": 0, "err": [], "seconds": 0.0})
            d["starts"] += 1
            d["instant"] += r["ttff_s"] == 0 and r["first_fix_right"] is True
            if r["ttff_s"] is None:
                d["never"] += 1
            elif r["ttff_s"] > 0:
                d["ttff_nz"].append(r["ttff_s"])
            d["wrong_first"] += r["first_fix_right"] is False
            d["wrong_epochs"] += r["wrong_fixed_epochs"]
            d["right_epochs"] += r["right_fixed_epochs"]
            d["epochs"] += r["epochs"]
            d["err"] += r["err_right_deg"]
            d["seconds"] += r.get("cpu_s", r["seconds"])
    for cfg in out.values():
        for mode in cfg.values():
            for bl, d in mode.items():
                e = np.array(d.pop("err")) if d["err"] else np.zeros(0)
                nz = d.pop("ttff_nz")
                mode[bl] = {"starts": d["starts"], "instant_fix_share": d["instant"] / d["starts"],
                            "mean_nonzero_ttff_s": round(float(np.mean(nz)), 2) if nz else None,
                            "never_fixed": d["never"], "wrong_first_fixes": d["wrong_first"],
                            "wrong_fixed_epochs": d["wrong_epochs"],
                            "single_epoch_success": d["right_epochs"] / d["epochs"] if d["epochs"] else None,
                            "direction_error_mean_deg": round(float(e.mean()), 3) if e.size else None,
                            "direction_error_std_deg": round(float(e.std()), 3) if e.size else None,
                            "seconds_per_run": round(d["seconds"] / d["starts"], 3)}
    return out


def merge_parts(paths: list[Path]) -> dict:
    """One result document from the files of split runs (--first), in start order."""
    docs = [json.loads(p.read_text()) for p in paths]
    res = sorted((r for d in docs for r in d["results"]), key=lambda r: r["start"]["index"])
    return {"count": len(res), "seed": docs[0]["seed"], "duration_s": docs[0]["duration_s"], "results": res}


def comparison_markdown(rtk_doc: dict, study_doc: dict) -> str:
    """One table: gnssatt (study, the same starts) and RTKLIB per configuration and baseline."""
    from gnssatt.ttff.study import summarize

    sets = {r["set"] for r in rtk_doc["results"]}
    runs = [row for r in study_doc["results"] if r["label"] in sets for row in r["runs"]]
    g = summarize(runs)["methods"]
    rk = summarize_rtklib(rtk_doc)
    secs = {(m, c): np.mean([row["seconds"] or 0 for row in runs if (row["method"], row["configuration"]) == (m, c)])
            for m in g for c in g[m]}
    lines = [f"{len(sets)} starts (seed {rtk_doc['seed']}, the first {len(sets)} of the {study_doc['count']} of "
             f"bench_ttff), "
             f"{rtk_doc['duration_s']:.0f} s each. Per cell: GPS-2>GPS-0 / GPS-2>GPS-1.", "",
             "| tool, method | conf. | instant fix [%] | mean TTFF > 0 [s] | never fixed | wrong first fixes | "
             "wrong fixed epochs | single-epoch success [%] | direction error [deg] | run time per baseline [s] |",
             "|---|---|---|---|---|---|---|---|---|---|"]

    def pair(d, key, fmt="{:.0f}", scale=1.0):
        vals = [d[b][key] for b in ("GPS-2>GPS-0", "GPS-2>GPS-1")]
        return " / ".join("–" if v is None else fmt.format(v * scale) for v in vals)

    for cfg in ("L1+L2", "L1", "L2"):
        for m, label in (("filter", "gnssatt EKF + MLAMBDA + length (paper)"),
                         ("epoch-lambda", "gnssatt epoch-wise MLAMBDA + length"),
                         ("epoch-constrained", "gnssatt epoch-wise MC-LAMBDA")):
            d = g.get(m, {}).get(cfg)
            if not d:
                continue
            se = pair(d, "single_epoch_success", "{:.1f}", 100) if m != "filter" else "–"
            we = pair(d, "wrong_fixed_epochs") if m == "filter" else pair(d, "single_epoch_wrong")
            err = [row["fix_error_deg"] for row in runs if row["method"] == "filter" and row["fix_right"]
                   and row["configuration"] == cfg]
            de = f"{np.mean(err):.2f} ± {np.std(err):.2f} (first fix)" if m == "filter" and err else "–"
            lines.append(f"| {label} | {cfg} | {pair(d, 'instant_fix_share', '{:.0f}', 100)} | "
                         f"{pair(d, 'mean_nonzero_ttff_s', '{:.1f}')} | {pair(d, 'never_fixed')} | "
                         f"{pair(d, 'wrong_first_fixes')} | {we} | {se} | {de} | {secs[(m, cfg)]:.2f} |")
        if cfg not in CONFIGS:
            lines.append(f"| RTKLIB moving-base | {cfg} | not available: `pos1-frequency` has no L2-only setting |"
                         + " |" * 7)
        for mode in ("fix-and-hold", "instantaneous"):
            d = rk.get(cfg, {}).get(mode)
            if not d:
                continue
            de = " / ".join(f"{d[b]['direction_error_mean_deg']} ± {d[b]['direction_error_std_deg']}"
                            for b in ("GPS-2>GPS-0", "GPS-2>GPS-1"))
            lines.append(f"| RTKLIB moving-base, {mode} | {cfg} | {pair(d, 'instant_fix_share', '{:.0f}', 100)} | "
                         f"{pair(d, 'mean_nonzero_ttff_s', '{:.1f}')} | {pair(d, 'never_fixed')} | "
                         f"{pair(d, 'wrong_first_fixes')} | {pair(d, 'wrong_fixed_epochs')} | "
                         f"{pair(d, 'single_epoch_success', '{:.1f}', 100)} | {de} | "
                         f"{pair(d, 'seconds_per_run', '{:.2f}')} |")
    lines += ["", "Wrong fixes: gnssatt by the fixed integers against the simulator's truth integers (truth/arcs.csv; "
                  "the filter: every integer constraint it held, per epoch); RTKLIB (integers not in its output) by the "
                  "fixed baseline direction more than 3 deg from the truth. Single-epoch success: gnssatt epoch "
                  "methods over epochs sampled every 10 s (accepted and right); RTKLIB instantaneous mode over every "
                  "epoch (fixed and right; fix-and-hold rows: share of all epochs fixed and right). Direction error: "
                  "angle between fixed and true baseline, RTKLIB over its right fixed epochs (mean ± std), gnssatt "
                  "at the first fix. Run time: CPU seconds, gnssatt per baseline and configuration inside the study "
                  "(files already parsed), RTKLIB postpos per run and baseline (reading the RINEX files included). "
                  "RTKLIB moving-base models the base observations at the rover's time tag: with free-running "
                  "receiver clocks it fixes wrongly unless the clock offsets are removed first (these receivers are "
                  "clock-steered, |dt| < 0.3 us)."]
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=200)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--first", type=int, default=0, help="skip the first starts (split a run over processes)")
    ap.add_argument("--out", default="/tmp/bench_ttff_rtklib.json")
    ap.add_argument("--report", action="store_true", help="print the comparison table (docs/ttff.md)")
    ap.add_argument("--parts", nargs="*", default=[], help="with --report: result files of split runs to merge")
    ap.add_argument("--study", default="/tmp/bench_ttff_study.json", help="with --report: bench_ttff study output")
    args = ap.parse_args(argv)
    if args.report:
        doc = merge_parts([Path(p) for p in (args.parts or [args.out])])
        print(json.dumps(summarize_rtklib(doc), indent=1))
        print(comparison_markdown(doc, json.loads(Path(args.study).read_text())))
        return
    run(args.count, args.seed, args.duration, Path(args.out), args.first)


if __name__ == "__main__":
    main()
