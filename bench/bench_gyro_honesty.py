"""Fused attitude error / own sigma per body axis pooled over N simulated clean runs (the Done-when "attitude
honest 0.8-1.25", docs/BENCHMARKS.md "GPS + gyro fusion"): one orbit holds few independent samples of an error
correlated over ~600 s (x axis), so single runs scatter by +- 0.2; N runs narrow the mean's interval.

    PYTHONPATH=. python bench/bench_gyro_honesty.py --seeds 10 11 ... [--orbits equatorial polar]
        [--duration-s S] [--settle-s 300] [--out RESULTS.jsonl] [--summary RESULTS.jsonl]

Each run: a clean seed 002 Table 1 set (bench_gyro_fusion.py --clean), fused with the defaults; the ratio is the
rms of error / sigma over the gyro-rate samples after --settle-s, with its sampling sd (truth.ratio_sampling_sd).
One JSON line per run; --summary reads such lines and prints the pooled figures: the mean of the per-run ratios
with its 95 % t interval over runs, and the rms of all samples pooled.
"""
from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np


def one_run(orbit: str, seed: int, duration_s: float, settle_s: float) -> dict:
    from gnssatt.gyro.api import fuse
    from gnssatt.gyro.truth import attitude_scores, ratio_sampling_sd
    from gnssatt.sim.gyro import GyroErrorModel
    from gnssatt.sim.gyro_scenario import GyroScenario, simulate_gyro_set

    tmp = Path(tempfile.mkdtemp(prefix="gyrohonest_"))
    try:
        t = time.perf_counter()
        gs = simulate_gyro_set(GyroScenario(orbit=orbit, duration_s=duration_s, gyro=GyroErrorModel()),
                               tmp / "set", seed=seed)
        res = fuse(gs.files)
        sc = attitude_scores(gs.sim.dir, res.run, res.gps)
        keep = sc["fused_time_s"] >= settle_s
        z = sc["fused_errors_rad"][keep] / sc["fused_sigma_rad"][keep]
        tt = sc["fused_time_s"][keep]
        per_axis = [ratio_sampling_sd(z[:, a], tt) for a in range(3)]
        return {"orbit": orbit, "seed": seed, "duration_s": duration_s, "settle_s": settle_s,
                "ratio": [round(r, 4) for r, _ in per_axis], "ratio_sd": [round(s, 4) for _, s in per_axis],
                "sum_z2": (z ** 2).sum(axis=0).tolist(), "n": int(len(z)),
                "fused_rms_deg": sc["fused"]["rms_deg"], "gyro_events": len(res.run.gyro_events),
                "gps_detections": len(res.run.gps_events), "gps_epochs": len(res.gps.time),
                "wall_s": round(time.perf_counter() - t, 1)}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def summary(docs: list[dict]) -> dict:
    """Pooled figures per axis: mean of the run ratios with its 95 % t interval, and the pooled rms."""
    from scipy.stats import t as student_t

    r = np.array([d["ratio"] for d in docs])
    n = len(r)
    half = student_t.ppf(0.975, n - 1) * r.std(axis=0, ddof=1) / np.sqrt(n) if n > 1 else np.full(3, np.nan)
    pooled = np.sqrt(np.sum([d["sum_z2"] for d in docs], axis=0) / np.sum([d["n"] for d in docs]))
    sd_model = np.sqrt(np.sum(np.array([d["ratio_sd"] for d in docs]) ** 2, axis=0)) / n
    return {"runs": n, "mean_ratio": r.mean(0).round(3).tolist(), "ci95_low": (r.mean(0) - half).round(3).tolist(),
            "ci95_high": (r.mean(0) + half).round(3).tolist(), "across_run_sd": r.std(0, ddof=1).round(3).tolist(),
            "pooled_rms": pooled.round(3).tolist(), "mean_sampling_sd_model": sd_model.round(3).tolist(),
            "min": r.min(0).round(3).tolist(), "max": r.max(0).round(3).tolist(),
            "gyro_events": sum(d.get("gyro_events", 0) for d in docs),
            "runs_with_gyro_count": sum(1 for d in docs if "gyro_events" in d)}


def main() -> None:
    from gnssatt.sim.gyro_scenario import ORBIT_PERIOD_650KM_S

    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", nargs="+", type=int, default=list(range(10, 30)))
    ap.add_argument("--orbits", nargs="+", default=["equatorial", "polar"], help="alternated over the seeds")
    ap.add_argument("--duration-s", type=float, default=ORBIT_PERIOD_650KM_S)
    ap.add_argument("--settle-s", type=float, default=300.0)
    ap.add_argument("--out", default=None, help="append one JSON line per run to this file")
    ap.add_argument("--summary", default=None, help="print the pooled figures of this file's runs and stop")
    a = ap.parse_args()
    if a.summary:
        docs = [json.loads(ln) for ln in open(a.summary) if ln.strip()]
        out = {"all": summary(docs)}
        for orbit in sorted({d["orbit"] for d in docs}):
            out[orbit] = summary([d for d in docs if d["orbit"] == orbit])
        print(json.dumps(out))
        return
    for i, seed in enumerate(a.seeds):
        doc = one_run(a.orbits[i % len(a.orbits)], seed, a.duration_s, a.settle_s)
        line = json.dumps(doc)
        print(line, flush=True)
        if a.out:
            with open(a.out, "a") as fh:
                fh.write(line + "\n")


if __name__ == "__main__":
    main()
