"""Benchmark and Done-when evidence of the gyro-fusion job (seed 002 Table 1): simulate one orbit (+10 min) of
the 0.6 m three-antenna set with a 10 Hz gyro, GPS faults of 35 % of a wavelength every 60 s, a 30 s GPS
outage and a 10x gyro drift fault after the orbit; run gnssatt.gyro.fuse and score against the truth.

    PYTHONPATH=. python bench/bench_gyro_fusion.py [--orbit equatorial|polar] [--seed 2] [--out DIR]
        [--clean] [--duration-s S] [--runs N] [--kappa K] [--threshold-model chi2|gaussian]

Prints one JSON document (timings: median of --runs runs of the job after one warm-up; scores of the last run).
"""
from __future__ import annotations

import argparse
import json
import os
import platform as _platform
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--orbit", default="equatorial")
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--out", default=None)
    ap.add_argument("--clean", action="store_true", help="no GPS or gyro faults, no outage")
    ap.add_argument("--duration-s", type=float, default=None)
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--step", action="store_true", help="gyro fault as a step (default: ramp over 300 s)")
    ap.add_argument("--kappa", type=float, default=3.0, help="GPS threshold control parameter")
    ap.add_argument("--threshold-model", default="chi2", choices=["chi2", "gaussian"],
                    help="GPS threshold: chi-square quantile (default) or the paper's mu + kappa sigma")
    ap.add_argument("--no-products", action="store_true", help="time the fusion only")
    a = ap.parse_args()
    from gnssatt.gyro.api import fuse
    from gnssatt.gyro.truth import attitude_scores, fdi_scores, gyro_delays, integer_failures
    from gnssatt.sim.gyro import DriftFault, GyroErrorModel
    from gnssatt.sim.gyro_scenario import ORBIT_PERIOD_650KM_S, GyroScenario, simulate_gyro_set

    orbit_s = ORBIT_PERIOD_650KM_S
    dur = a.duration_s or orbit_s + 600.0
    faults = () if a.clean else (DriftFault(axis=1, start_s=min(orbit_s, dur - 600.0), size_rad_s=10 * 48.48e-6,
                                            ramp_s=0.0 if a.step else 300.0),)
    sc = GyroScenario(orbit=a.orbit, duration_s=dur, gps_fault_interval_s=0.0 if a.clean else 60.0,
                      outages=() if a.clean else ((1800.0, 30.0),), gyro=GyroErrorModel(faults=faults))
    out = Path(a.out or tempfile.mkdtemp(prefix="gyrobench_"))
    t = time.perf_counter()
    gs = simulate_gyro_set(sc, out / "set", seed=a.seed)
    sim_s = time.perf_counter() - t
    settings = {"gps_fdi": {"kappa": a.kappa, "threshold_model": a.threshold_model}}
    fuse(gs.files, settings)                             # warm-up (numba cache)
    times, cpu = [], []
    for _ in range(a.runs):
        t, c = time.perf_counter(), time.process_time()
        res = fuse(gs.files, settings)
        times.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    t = time.perf_counter()
    if not a.no_products:
        res.write_products(out / "products")
    write_s = time.perf_counter() - t
    until = faults[0].start_s if faults else float("inf")
    sc_att = attitude_scores(gs.sim.dir, res.run, res.gps, until_s=until)    # before the gyro fault
    for k in ("fused_errors_rad", "fused_sigma_rad", "fused_time_s"):
        sc_att.pop(k)
    if faults:
        after = attitude_scores(gs.sim.dir, res.run, res.gps)
        sc_att["whole_run_with_gyro_fault_fused"] = after["fused"]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    doc = {"orbit": a.orbit, "seed": a.seed, "kappa": a.kappa, "threshold_model": a.threshold_model, "gyro_fault": "step" if a.step else "ramp 300 s",
           "duration_s": dur, "clean": a.clean, "commit": commit,
           "machine": f"{_platform.processor() or _platform.machine()}, {os.cpu_count()} cpu",
           "simulate_s": round(sim_s, 2), "fuse_s_median": round(float(np.median(times)), 2),
           "fuse_cpu_s_median": round(float(np.median(cpu)), 2), "write_products_s": round(write_s, 2),
           "faster_than_real_time": round(dur / (float(np.median(times)) + write_s), 1),
           "attitude": sc_att, "gps_fdi": fdi_scores(gs.sim.dir, res.run, res.gps),
           "integers": integer_failures(gs.sim.dir, res.run, res.gps),
           "gyro_fdi": gyro_delays(gs.sim.dir, res.run, res.gps),
           "outage": res.summary.get("outages", [])}
    print(json.dumps(doc, indent=1, default=float))


if __name__ == "__main__":
    main()
