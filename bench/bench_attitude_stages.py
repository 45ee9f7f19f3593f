"""Attitude job stages in process (issue 24, the 3 s wall): per stage of the pipeline's StageClock, wall time, CPU of
the job process itself and CPU of the forked children reaped in that stage (the RINEX reader's, the background
geometry's, the plot process), so that work moved to a second core is seen apart from the critical path.

Same pass as bench_attitude_speed (simulator preset `earth-pointing`, seed 0, --minutes long, realistic); each job is
worker.jobs.attitude.run on a bench.local_jobs.job_context; the first run of the process is cold (imports, first
drawings) and left out of the medians.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_attitude_stages.py [--runs 3] [--mode kinematic] [--minutes 106]

Run it in two trees one after the other (interleaved, several rounds) to compare them on a shared machine; the
figures go into docs/BENCHMARKS.md "Attitude job speed" by hand.
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


def _now() -> tuple[float, float, float]:
    """(wall s, CPU s of this process, CPU s of its reaped children)."""
    t = os.times()
    return time.perf_counter(), t.user + t.system, t.children_user + t.children_system


class SplitClock:
    """worker.jobs.attitude.StageClock with the CPU split: rows (stage, wall, own CPU, children CPU)."""

    def __init__(self) -> None:
        self.rows: list[tuple[str, float, float, float]] = []
        self._stage: str | None = None
        self._t = _now()
        CLOCKS.append(self)

    def mark(self, stage: str | None) -> None:
        now = _now()
        if self._stage is not None:
            self.rows.append((self._stage, *(a - b for a, b in zip(now, self._t))))
        self._stage, self._t = stage, now

    def line(self) -> str:
        return "stages (wall s / CPU s): " + "; ".join(f"{n} {w:.2f}/{c + ch:.2f}" for n, w, c, ch in self.rows)


CLOCKS: list[SplitClock] = []


def run_jobs(d: Path, mode: str, runs: int, work: Path) -> list[dict]:
    """`runs` attitude jobs in this process: per job, stage -> (wall, own CPU, children CPU) and the load."""
    import worker.jobs.attitude as WA
    from bench.bench_attitude_speed import files_of
    from bench.local_jobs import files_set, job_context

    WA.StageClock = SplitClock
    out = []
    for i in range(runs):
        ctx = job_context(work / f"job{i}", [files_set(files_of(d), name=d.name)], job_id="bench-stages")
        t0 = _now()
        WA.run(ctx, WA.AttitudeConfig(mode=mode))
        t1 = _now()
        stages = {r[0]: r[1:] for r in CLOCKS[-1].rows}
        stages["job"] = tuple(a - b for a, b in zip(t1, t0))
        out.append({"stages": stages, "load": os.getloadavg()[0]})
        print(f"run {i}: job wall {stages['job'][0]:.2f} s, own CPU {stages['job'][1]:.2f} s, children "
              f"{stages['job'][2]:.2f} s, load {out[-1]['load']:.1f}", flush=True)
    return out


def table(rows: list[dict]) -> str:
    """Markdown table: stage, then median wall / own CPU / children CPU over the runs given."""
    lines = ["| stage | wall s | own CPU s | children CPU s |", "|---|---|---|---|"]
    for st in rows[0]["stages"]:
        med = [float(np.median([r["stages"][st][i] for r in rows])) for i in range(3)]
        lines.append(f"| {st} | {med[0]:.2f} | {med[1]:.2f} | {med[2]:.2f} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--mode", default="kinematic", choices=("kinematic", "dynamic"))
    ap.add_argument("--minutes", type=float, default=106.0)
    args = ap.parse_args()
    from gnssatt.sim import simulate_scenario

    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp) / "realistic"
        simulate_scenario("earth-pointing", d, seed=0, overrides={"duration_s": args.minutes * 60.0})
        rows = run_jobs(d, args.mode, args.runs, Path(tmp))
    warm = rows[1:] or rows
    print(f"\n{args.mode}, median of runs 2-{len(rows)} (load {min(r['load'] for r in warm):.1f}-"
          f"{max(r['load'] for r in warm):.1f}):\n{table(warm)}")


if __name__ == "__main__":
    main()
