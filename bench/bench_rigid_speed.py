"""CPU of `baseline_update` "rigid" against "additive" (gnssatt/attitude/rigid_kernels.py, issue 21 item 2): the
smoother's backward pass on the records of one forward run (the linear RTS step, the rigid tangent-space step
compiled and its numpy reference) and whole runs of process() (Table 1 forward; smoother_adaptive_noise: two
forward passes and three backward ones), on a 106-minute pass of bench_attitude_lengths.py (--pass, clean by
default; seed 0, dynamic mode, --preset "all-phases" by default; "seed000" is the job's default).
time.process_time, median of --runs runs interleaved (additive, rigid, ...); the reference backward pass once (it
takes ~20 s). Print only.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_rigid_speed.py [--runs 3] [--minutes 106] [--pass clean]
        [--preset all-phases] [--forward-only]
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

from bench.bench_attitude import files_of  # noqa: E402
from bench.bench_attitude_lengths import PASSES, SEED  # noqa: E402

RUNS = {"Table 1 forward": {}, "smoother_adaptive_noise": {"smoother": True, "smoother_adaptive_noise": True}}


def cpu_of(fn, *args) -> float:
    """CPU seconds of one call."""
    c0 = time.process_time()
    fn(*args)
    return time.process_time() - c0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--minutes", type=float, default=106.0)
    ap.add_argument("--pass", dest="pass_name", default="clean", choices=("clean", "realistic", "hard", "slew"))
    ap.add_argument("--preset", default="all-phases")
    ap.add_argument("--forward-only", action="store_true", help="only process() with Table 1 forward")
    args = ap.parse_args()
    from gnssatt.attitude.process import load_inputs, process
    from gnssatt.attitude.rigid_smoother import rts_smooth_rigid, rts_smooth_rigid_reference
    from gnssatt.attitude.settings import AttitudeSettings
    from gnssatt.attitude.smoother import fixed_runs, rts_smooth
    from gnssatt.sim import simulate_scenario

    print(f"load average at the start {os.getloadavg()[0]:.1f}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp) / args.pass_name
        preset, over = PASSES[args.pass_name]
        simulate_scenario(preset, d, seed=SEED, overrides={"duration_s": args.minutes * 60.0, **over})
        inputs = load_inputs(files_of(d))
        settings = lambda u, cfg: AttitudeSettings.preset(args.preset, mode="dynamic", baseline_update=u,  # noqa
                                                          **cfg)
        runs = {"Table 1 forward": {}} if args.forward_only else RUNS
        for name, cfg in runs.items():
            cpu = {"additive": [], "rigid": []}
            for _ in range(args.runs):
                for u in cpu:
                    cpu[u].append(cpu_of(process, inputs, settings(u, cfg)))
            print(f"process(), {name}: " + "; ".join(f"{u} {np.median(v):.2f} s ({', '.join(f'{x:.2f}' for x in v)})"
                                                   for u, v in cpu.items()), flush=True)
        if not args.forward_only:
            sol = process(inputs, settings("rigid", {"smoother": True}))
            sd, n_bl = sol.fr.smoother_data, sol.fr.fixed.shape[1]
            _, start = fixed_runs(sol.fr)
            rec = (sd["x_post"], sd["P_post"], sd["x_prior"], sd["P_prior"], sd["Phi"], start)
            back = {"linear": [], "rigid (compiled)": []}
            for _ in range(args.runs):
                back["linear"].append(cpu_of(rts_smooth, *rec))
                back["rigid (compiled)"].append(cpu_of(rts_smooth_rigid, *rec, n_bl))
            print(f"backward pass, {len(start)} epochs: "
                  + "; ".join(f"{k} {np.median(v):.3f} s" for k, v in back.items())
                  + f"; rigid numpy reference {cpu_of(rts_smooth_rigid_reference, *rec, n_bl):.2f} s", flush=True)
    print(f"load average at the end {os.getloadavg()[0]:.1f}", flush=True)


if __name__ == "__main__":
    main()
