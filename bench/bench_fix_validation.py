"""First-fix length validation over simulator seeds (issue 21: 0 wrong integers in every mode): the job's default
data selection (seed 000 Table 2 masks) on the realistic and hard 106-minute passes of bench_attitude_lengths.py,
seeds 0-7, dynamic and kinematic mode, with `ambiguity.length_validation` = filter (the filter's baseline
conditioned on the candidate integers), single-epoch (seed 000 sec. 2: the epoch's own phases with them) and both.
Per run: wrong integer constraints against the simulator's truth (gnssatt.attitude.truth.score_fixes), fix and
fix_rejected events, the attitude fix rate and each baseline's first fix (s from the first epoch).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_fix_validation.py [--seeds 0,1,...,7] [--passes realistic,hard]
        [--validations filter,single-epoch,both] [--modes dynamic,kinematic] [--sets DIR (keep the simulated sets)]

Prints a markdown table and the totals per setting; writes nothing into docs/BENCHMARKS.md.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from bench._report import machine_line  # noqa: E402
from bench.bench_attitude import files_of  # noqa: E402


def run_row(d: Path, inputs, mode: str, validation: str) -> dict:
    """Figures of one run (module doc)."""
    from gnssatt.attitude.process import process
    from gnssatt.attitude.settings import AttitudeSettings
    from gnssatt.attitude.truth import score_fixes

    t = time.process_time()
    sol = process(inputs, AttitudeSettings.preset("seed000", mode=mode, length_validation=validation))
    cpu = time.process_time() - t
    sc = score_fixes(sol, d / "truth")
    fr = sol.fr
    t_s = np.asarray(sol.pobs.time - sol.pobs.time[0], float)
    first = [float(t_s[e]) if e >= 0 else float("nan") for e in fr.first_fix_epoch]
    kinds = [e["event"] for e in fr.events]
    return {"wrong": sc["wrong_constraints"], "constraints": sc["constraints"], "fix": kinds.count("fix"),
            "rejected": kinds.count("fix_rejected"), "fix_rate": float(np.mean(sol.att_fixed)), "first_s": first,
            "cpu": cpu, "details": sc["details"][:3]}


def main() -> None:
    from bench.bench_attitude_lengths import simulated_pass
    from gnssatt.attitude.process import load_inputs

    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", default="0,1,2,3,4,5,6,7")
    ap.add_argument("--passes", default="realistic,hard")
    ap.add_argument("--validations", default="filter,single-epoch,both")
    ap.add_argument("--modes", default="dynamic,kinematic")
    ap.add_argument("--minutes", type=float, default=106.0)
    ap.add_argument("--sets", default=None, help="folder to keep (and reuse) the simulated sets")
    args = ap.parse_args()
    print(f"Machine: {machine_line()}. {args.minutes:.0f} min passes, the job's default data selection.")
    print("| seed | pass | mode | length validation | wrong integers | fix / fix_rejected events | attitude fix rate "
          "| first fix s per baseline | CPU s |")
    print("|---|---|---|---|---|---|---|---|---|")
    totals: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(args.sets) if args.sets else Path(tmp)
        for seed in (int(s) for s in args.seeds.split(",")):
            for label in args.passes.split(","):
                d = simulated_pass(base, label, seed, args.minutes)
                inputs = load_inputs(files_of(d))
                for mode in args.modes.split(","):
                    for val in args.validations.split(","):
                        r = run_row(d, inputs, mode, val)
                        tot = totals.setdefault((label, mode, val), {"wrong": 0, "runs_wrong": 0, "fix_rate": [],
                                                                     "first_s": []})
                        tot["wrong"] += r["wrong"]
                        tot["runs_wrong"] += r["wrong"] > 0
                        tot["fix_rate"].append(r["fix_rate"])
                        tot["first_s"].extend(r["first_s"])
                        print(f"| {seed} | {label} | {mode} | {val} | {r['wrong']} of {r['constraints']} | "
                              f"{r['fix']} / {r['rejected']} | {r['fix_rate']:.4f} | "
                              f"{', '.join(f'{x:.0f}' for x in r['first_s'])} | {r['cpu']:.1f} |", flush=True)
                        for line in r["details"]:
                            print(f"    {line}", flush=True)
    print("\n| pass | mode | length validation | wrong integers (runs with any) | mean attitude fix rate | "
          "median / max first fix s |")
    print("|---|---|---|---|---|---|")
    for (label, mode, val), t in totals.items():
        f = np.asarray(t["first_s"])
        print(f"| {label} | {mode} | {val} | {t['wrong']} ({t['runs_wrong']}) | {np.mean(t['fix_rate']):.4f} | "
              f"{np.nanmedian(f):.0f} / {np.nanmax(f):.0f} |")


if __name__ == "__main__":
    main()
