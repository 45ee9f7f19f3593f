"""Simulator benchmark: a 106-minute 1 Hz three-antenna dual-frequency set (preset `earth-pointing`, seed 0,
CASSIOPE-like, all realism on) must be written in < 20 s (issue 5). One warm-up, then the median of N runs;
per-stage times from the progress callback; peak RSS of one run measured in a separate process.

    .venv/bin/python bench/bench_simulator.py --runs 3 [--write]

With --write the markdown goes into docs/BENCHMARKS.md, section "Simulator" (other sections untouched).
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench._report import machine_line, replace_section  # noqa: E402

SCENARIO = "earth-pointing"
SEED = 0
LIMIT_S = 20.0


def one_run(out: Path, overrides: dict) -> tuple[float, dict, dict]:
    from gnssatt.sim import simulate_scenario

    marks = []
    t0 = time.perf_counter()
    res = simulate_scenario(SCENARIO, out, seed=SEED, overrides=overrides,
                            progress=lambda f, s: marks.append((time.perf_counter() - t0, s)))
    total = time.perf_counter() - t0
    stages: dict[str, float] = {}
    for (t_a, s_a), (t_b, _) in zip(marks, marks[1:]):
        key = s_a.split(" ")[0]
        stages[key] = stages.get(key, 0.0) + (t_b - t_a)
    return total, stages, res.sets[0]["summary"]


def _rss_child(overrides_json: str) -> None:
    import resource
    with tempfile.TemporaryDirectory() as tmp:
        one_run(Path(tmp), json.loads(overrides_json))
    print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--rss-child", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.rss_child is not None:
        _rss_child(args.rss_child)
        return
    rows = []
    for label, ov in (("full (with per-observation truth components)", {}),
                      ("without truth/observations_*.csv", {"truth_components": False}),
                      ("GPS + GLONASS (systems G+R, 24 more satellites)", {"systems": "G+R"})):
        with tempfile.TemporaryDirectory() as tmp:
            one_run(Path(tmp) / "warm", ov)                       # warm-up
            runs = [one_run(Path(tmp) / f"r{k}", ov) for k in range(args.runs)]
            sizes = sum(p.stat().st_size for p in (Path(tmp) / "r0").rglob("*") if p.is_file())
        totals = [r[0] for r in runs]
        med = statistics.median(totals)
        stages = {k: statistics.median(r[1].get(k, 0.0) for r in runs) for k in runs[0][1]}
        summ = runs[0][2]
        n_obs = sum(v["signals"][f]["n_obs"] for v in summ["antennas"].values() for f in v["signals"])
        rss = float(subprocess.run([sys.executable, __file__, "--rss-child", json.dumps(ov)], capture_output=True,
                                   text=True, check=True, cwd=ROOT).stdout.strip().splitlines()[-1])
        rows.append((label, med, min(totals), max(totals), stages, n_obs, summ["n_epochs"], sizes, rss))
    lines = [f"Machine: {machine_line()}.", "",
             f"Preset `{SCENARIO}`, seed {SEED}: 106 min at 1 Hz (6361 epochs), 3 antennas (one receiver each) x 2 signals "
             "(L1 C/A + L2 P(Y): code, phase, Doppler, C/N0), 12-channel tracking, multipath, PCV/PCO, ionosphere, "
             f"wind-up, C/N0-dependent noise. Requirement: < {LIMIT_S:.0f} s. One warm-up, median of {args.runs} runs; "
             "peak RSS of one run in a separate process.", "",
             "| variant | median s | min-max s | signal observations | files MB | peak RSS MiB | verdict |",
             "|---|---|---|---|---|---|---|"]
    for label, med, lo, hi, stages, n_obs, n_ep, sizes, rss in rows:
        lines.append(f"| {label} | {med:.2f} | {lo:.2f}-{hi:.2f} | {n_obs} | {sizes / 1e6:.1f} | {rss:.0f} | "
                     f"{'PASS' if med < LIMIT_S else 'FAIL'} |")
    lines += ["", "Stage medians of the full run (s): " + ", ".join(f"{k} {v:.2f}" for k, v in rows[0][4].items()),
              "", "Reproduce: `.venv/bin/python bench/bench_simulator.py --runs 3 --write`."]
    body = "\n".join(lines)
    print(body)
    if args.write:
        replace_section(ROOT / "docs" / "BENCHMARKS.md", "Simulator", body)


if __name__ == "__main__":
    main()
