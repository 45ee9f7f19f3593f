"""Attitude job stages in process (issue 24, the 3 s wall): per stage of the pipeline's StageClock, wall time, CPU of
the job process itself and CPU of the forked children reaped in that stage (the RINEX reader's, the background
geometry's, the plot process), so that work moved to a second core is seen apart from the critical path.

Same pass as bench_attitude_speed (simulator preset `earth-pointing`, seed 0, --minutes long, realistic); each job is
worker.jobs.attitude.run on a bench.local_jobs.job_context; the first run of the process is cold (imports, first
drawings) and left out of the medians.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_attitude_stages.py [--runs 3] [--mode kinematic] [--minutes 106]
        [--fork-server]

--fork-server runs each job as the service does: in a child forked from a process that has imported worker.zygote
(the fork server's preload: pipelines, kernels, warm-up) and done nothing else, so every run pays what a service
job pays (lazy imports, first drawings, copy-on-write faults); all runs then count in the medians.

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


def run_jobs(d: Path, mode: str, runs: int, work: Path, quiet: bool = False) -> list[dict]:
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
        if not quiet:
                print(f"run {i}: job wall {stages['job'][0]:.2f} s, own CPU {stages['job'][1]:.2f} s, children "
                  f"{stages['job'][2]:.2f} s, load {out[-1]['load']:.1f}", flush=True)
    return out


def run_jobs_forked(d: Path, mode: str, runs: int, work: Path) -> list[dict]:
    """Like run_jobs, each job in a child forked from this process after `import worker.zygote` (the fork server's
    preload), its figures sent back through a pipe."""
    import pickle

    import worker.zygote  # noqa: F401 - what the service's fork server loads before its first fork

    out = []
    for i in range(runs):
        read_fd, write_fd = os.pipe()
        pid = os.fork()
        if pid == 0:                                      # the job child
            code = 1
            try:
                os.close(read_fd)
                row = run_jobs(d, mode, 1, work / f"fork{i}", quiet=True)[0]
                with os.fdopen(write_fd, "wb") as fh:
                    pickle.dump(row, fh)
                code = 0
            finally:
                os._exit(code)
        os.close(write_fd)
        with os.fdopen(read_fd, "rb") as fh:
            data = fh.read()
        os.waitpid(pid, 0)
        row = pickle.loads(data)
        out.append(row)
        job = row["stages"]["job"]
        print(f"run {i} (forked): job wall {job[0]:.2f} s, own CPU {job[1]:.2f} s, children {job[2]:.2f} s, "
              f"load {row['load']:.1f}", flush=True)
    return out


def table(rows: list[dict]) -> str:
    """Markdown table: stage, then median wall / own CPU / children CPU over the runs given."""
    lines = ["| stage | wall s | own CPU s | children CPU s |", "|---|---|---|---|"]
    for st in rows[0]["stages"]:
        med = [float(np.median([r["stages"][st][i] for r in rows])) for i in range(3)]
        lines.append(f"| {st} | {med[0]:.2f} | {med[1]:.2f} | {med[2]:.2f} |")
    return "\n".join(lines)


def _simulate(d: Path, minutes: float) -> None:
    """The pass, simulated in a forked child: this process imports nothing of the simulator (a job forked from it
    would find modules loaded that the service's job children do not have)."""
    pid = os.fork()
    if pid == 0:
        code = 1
        try:
            from gnssatt.sim import simulate_scenario

            simulate_scenario("earth-pointing", d, seed=0, overrides={"duration_s": minutes * 60.0})
            code = 0
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    if status != 0:
        raise RuntimeError("simulating the pass failed")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--mode", default="kinematic", choices=("kinematic", "dynamic"))
    ap.add_argument("--minutes", type=float, default=106.0)
    ap.add_argument("--fork-server", action="store_true", help="each job in a child forked after the fork "
                    "server's preload (worker.zygote), as the service runs it")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp) / "realistic"
        _simulate(d, args.minutes)
        if args.fork_server:
            rows = run_jobs_forked(d, args.mode, args.runs, Path(tmp))
        else:
            rows = run_jobs(d, args.mode, args.runs, Path(tmp))
    warm = rows if args.fork_server else (rows[1:] or rows)
    first = 1 if args.fork_server else 2
    how = " (forked)" if args.fork_server else ""
    print(f"\n{args.mode}{how}, median of runs {first}-{len(rows)} (load {min(r['load'] for r in warm):.1f}-"
          f"{max(r['load'] for r in warm):.1f}):\n{table(warm)}")


if __name__ == "__main__":
    main()
