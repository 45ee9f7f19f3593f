"""Attitude job speed (issue 6): filter epochs/s and the whole job, upload to products, next to RTKLIB postpos on
the same files, measured in the same run.

Passes: the 106-minute CASSIOPE-like pass of seed 000 sec. 4.1 (simulator preset `earth-pointing`, seed 0, three
antennas, L1 C/A + L2 P(Y), 1 Hz), clean ({"pcv": false, "pco": false, "multipath": false,
"noise_grows_with_cn0": false}) and realistic (preset as it is), each in kinematic and dynamic mode.

- filter: CPU time (time.process_time) of gnssatt.attitude.filter.run_filter, epochs / s; median of --runs runs;
- job: the attitude pipeline itself (worker.jobs.attitude.run on a JobContext like the runner builds: parse
  the uploaded files, geometry, filter, attitude, every product text, PNG plots, report.html, each product
  hashed as the blob store does), CPU (the plot process it forks included) and wall time, median of --runs runs, and CPU per stage (the pipeline's
  StageClock line of the job log);
- service (realistic pass, both modes): upload to products through the real service as `make demo` runs it (API +
  one worker, embedded SQLite + Huey, default settings): HTTP upload of the set, job submitted, followed to
  `succeeded` by its Server-Sent Events as the CLI does, products listed; wall time split into upload, submit, queue pick-up, run, seen-succeeded, CPU of
  the API and worker processes, and the job's stage line from the worker log (--no-service skips it);
- RTKLIB: pyrtklib postpos, moving-base L1+L2 (bench_attitude_rtklib.rtklib_movingbase_options), one run per
  baseline (GPS-2>GPS-0, GPS-2>GPS-1) on the same RINEX files, CPU and wall, median of --runs runs.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_attitude_speed.py [--runs 3] [--minutes 106]
        [--no-rtklib] [--no-service] [--baseline-update additive|rigid] [--write]

--write puts the figures first in docs/BENCHMARKS.md "Attitude job speed", keeping the section's earlier figures.
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

from bench._report import machine_line, prepend_to_section  # noqa: E402
from worker.forked import cpu_s  # noqa: E402

SEED = 0
CLEAN = {"pcv": False, "pco": False, "multipath": False, "noise_grows_with_cn0": False}
PASSES = {"clean": CLEAN, "realistic": {}}
MODES = ("kinematic", "dynamic")


def files_of(d: Path) -> list[tuple[str, str, Path]]:
    files = [(f"obs/{p.name}", "rinex_obs", p) for p in sorted((d / "obs").glob("*.rnx"))]
    return files + [("nav/brdc.rnx", "rinex_nav", d / "nav/brdc.rnx"), ("platform.json", "platform",
                                                                      d / "platform.json"),
                    ("platform.sp3", "sp3", d / "platform.sp3"),
                    ("reference_attitude.csv", "reference_attitude", d / "reference_attitude.csv")]


def run_job(d: Path, mode: str, work: Path, settings: dict | None = None) -> dict:
    """One attitude job through its pipeline (settings: job fields on top of the defaults, e.g. baseline_update);
    CPU/wall of the whole job and of run_filter."""
    import gnssatt.attitude.process as P
    from bench.local_jobs import files_set, job_context
    from worker.jobs.attitude import AttitudeConfig
    from worker.jobs.attitude import run

    ctx = job_context(work, [files_set(files_of(d), name=d.name)], job_id="bench-speed")
    filt = {}
    orig = P.run_filter

    def timed(pobs, *a, **k):
        c0 = time.process_time()
        r = orig(pobs, *a, **k)
        filt["cpu_s"], filt["epochs"] = time.process_time() - c0, len(pobs.time)
        return r

    P.run_filter = timed
    try:
        t0, c0 = time.perf_counter(), cpu_s()
        run(ctx, AttitudeConfig(mode=mode, **(settings or {})))
        wall, cpu = time.perf_counter() - t0, cpu_s() - c0
    finally:
        P.run_filter = orig
    return {"job_wall_s": wall, "job_cpu_s": cpu, "filter_cpu_s": filt["cpu_s"], "epochs": filt["epochs"],
            "products": sorted(ctx.products), "stages_cpu_s": parse_stages(ctx.log_lines[-1])}


def parse_stages(line: str) -> dict[str, float]:
    """Stage -> CPU s of the pipeline's 'stages (wall s / CPU s): name w/c; ...' log line (StageClock)."""
    body = line.split("stages (wall s / CPU s): ", 1)[1]
    out = {}
    for part in body.split("; "):
        name, _, wc = part.rpartition(" ")
        out[name] = float(wc.split("/")[1])
    return out


def run_rtklib(d: Path, work: Path) -> dict:
    """RTKLIB postpos of both baselines (moving base, L1+L2) on the same files: summed CPU / wall."""
    from bench.bench_attitude_rtklib import BASELINES, load_truth, rtklib_movingbase_options
    from bench.rtklib_runner import run_postpos

    truth = load_truth(d)
    out = {"cpu_s": 0.0, "wall_s": 0.0}
    for a, b in BASELINES:
        L = float(np.linalg.norm(truth["body"][f"{a}>{b}"]))
        sol = run_postpos(d / "obs" / f"{b}.rnx", d / "obs" / f"{a}.rnx", d / "nav" / "brdc.rnx",
                          rtklib_movingbase_options(L), work / f"{b}.pos")
        out["cpu_s"] += sol.cpu_s
        out["wall_s"] += sol.elapsed_s
    return out


def _proc_cpu_s(pid: int) -> float:
    """utime + stime + cutime + cstime of a process (its threads and the children it waited for, e.g. the
    attitude job's plot process, included) from /proc, in seconds."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return sum(int(f) for f in fields[11:15]) / os.sysconf("SC_CLK_TCK")


def _tree_cpu_s(pid: int) -> float:
    """_proc_cpu_s of a process and all its live descendants: the worker, its fork server of job children and the
    job child (under process isolation a job runs in a child of the fork server, not of the worker; the children
    they reaped are in their cutime/cstime)."""
    parent: dict[int, int] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            parent[int(stat.parent.name)] = int(stat.read_text().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
    tree, todo = [], [pid]
    while todo:
        p = todo.pop()
        tree.append(p)
        todo += [c for c, pp in parent.items() if pp == p]
    total = 0.0
    for p in tree:
        try:
            total += _proc_cpu_s(p)
        except OSError:
            pass                              # exited meanwhile: its CPU is in its parent's children fields
    return total


def _iso_s(text: str) -> float:
    from datetime import datetime

    return datetime.fromisoformat(text.replace("Z", "+00:00")).timestamp()


class AttitudeService:
    """The real service as `make demo` runs it: API + one worker on the embedded default (SQLite + Huey), default
    lease/heartbeat settings, fresh data directory; the worker's consumer is up before anything is timed."""

    def __init__(self, work: Path):
        import shutil

        from client.local_service import LocalService

        shutil.rmtree(work, ignore_errors=True)
        work.mkdir(parents=True)
        self.svc = LocalService(work, "sqlite", None, None)
        for k in ("GNSSATT_LEASE_SECONDS", "GNSSATT_HEARTBEAT_SECONDS", "GNSSATT_REQUEUE_AFTER_SECONDS"):
            self.svc.env.pop(k, None)           # the service's defaults, not the e2e tests' short leases
        self.svc.env["OPENBLAS_NUM_THREADS"] = "1"
        self.svc.start_api()
        self.key = self.svc.create_key("bench")
        self.worker = self.svc.start_worker()
        self.worker_log = self.svc.logs[-1]
        deadline = time.monotonic() + 120
        while "consumer started" not in (self.worker_log.read_text(errors="replace")
                                         if self.worker_log.exists() else ""):
            if time.monotonic() > deadline or self.worker.poll() is not None:
                raise RuntimeError(f"worker did not start:\n{self.svc.logs_text()}")
            time.sleep(0.2)

    def run(self, d: Path, mode: str, poll_s: float | None = None) -> dict:
        """Upload the set over HTTP, submit the attitude job, follow it to `succeeded` (its event stream, as the CLI
        does; poll_s: GET the job every poll_s s instead), list the products: wall time of
        each part (client clock; queue pick-up and run from the job's created/started/finished times) and CPU
        of the API and worker processes; the job's own stage timings from the worker's log."""
        import httpx

        files = [("files", (p.name, p.read_bytes(), "application/octet-stream")) for _, _, p in files_of(d)]
        with self.svc.client(self.key) as c:
            c.timeout = httpx.Timeout(600)
            cpu_api0, cpu_w0 = _proc_cpu_s(self.svc.api.pid), _tree_cpu_s(self.worker.pid)
            t0 = time.perf_counter()
            r = c.post("/v1/observation-sets", files=files, data={"name": d.name})
            r.raise_for_status()
            t_up = time.perf_counter()
            cpu_api_up = _proc_cpu_s(self.svc.api.pid) - cpu_api0
            job = c.post("/v1/jobs", json={"type": "attitude", "observation_set_ids": [r.json()["id"]],
                                           "config": {"mode": mode}})
            job.raise_for_status()
            jid = job.json()["id"]
            t_sub = time.perf_counter()
            j, polls = follow_job(c, jid, poll_s)
            t_done = time.perf_counter()
            if j["state"] != "succeeded":
                raise RuntimeError(f"service run failed: {j}\n{self.svc.logs_text()}")
            listing = c.get(f"/v1/jobs/{jid}/products").json()
            t_list = time.perf_counter()
            cpu_api, cpu_w = _proc_cpu_s(self.svc.api.pid) - cpu_api0, _tree_cpu_s(self.worker.pid) - cpu_w0
        created, started, finished = (_iso_s(j[k]) for k in ("created_at", "started_at", "finished_at"))
        stages = [ln.split(" stages (wall s / CPU s): ", 1)[1] for ln in
                  self.worker_log.read_text(errors="replace").splitlines() if f"attitude job {jid} stages" in ln]
        items = listing["items"] if isinstance(listing, dict) else listing
        return {"upload_s": t_up - t0, "submit_s": t_sub - t_up, "pickup_s": started - created,
                "run_s": finished - started, "seen_s": t_done - t_sub, "list_s": t_list - t_done,
                "total_s": t_list - t0, "api_cpu_upload_s": cpu_api_up, "api_cpu_s": cpu_api,
                "worker_cpu_s": cpu_w, "polls": polls, "stages": stages[-1] if stages else "",
                "products": len(items), "upload_mb": sum(len(f[1][1]) for f in files) / 1e6}

    def shutdown(self) -> None:
        self.svc.shutdown()


def follow_job(c, jid: str, poll_s: float | None = None) -> tuple[dict, int]:
    """(the job once it has ended, events or polls seen): its Server-Sent Events (GET /v1/jobs/{id}/events, what
    `gnssatt submit` follows), or GET /v1/jobs/{id} every poll_s s."""
    import json

    n = 0
    if poll_s is None:
        with c.stream("GET", f"/v1/jobs/{jid}/events") as resp:
            resp.raise_for_status()
            event = None
            for line in resp.iter_lines():
                if line.startswith("event:"):
                    event = line[6:].strip()
                elif line.startswith("data:"):
                    n += 1
                    if event == "end":
                        return json.loads(line[5:]), n
        raise RuntimeError(f"the event stream of job {jid} ended without an end event")
    while True:
        j = c.get(f"/v1/jobs/{jid}").json()
        n += 1
        if j["state"] in ("succeeded", "failed", "cancelled"):
            return j, n
        time.sleep(poll_s)


def run_service_jobs(d: Path, mode: str, runs: int, work: Path) -> list[dict]:
    """`runs` uploads + jobs of the pass through one service (a fresh set each time; the first job also pays
    the worker's imports of the science and plotting modules)."""
    svc = AttitudeService(work)
    try:
        return [svc.run(d, mode) for _ in range(runs)]
    finally:
        svc.shutdown()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--minutes", type=float, default=106.0)
    ap.add_argument("--passes", default=",".join(PASSES))
    ap.add_argument("--no-rtklib", action="store_true")
    ap.add_argument("--no-service", action="store_true", help="skip the upload-to-products runs through the service")
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--baseline-update", choices=("additive", "rigid"), default=None,
                    help="the job's baseline_update (dynamic mode; default: the settings' default)")
    args = ap.parse_args()
    job_settings = {} if args.baseline_update is None else {"baseline_update": args.baseline_update}
    from gnssatt.sim import simulate_scenario

    med = lambda rows, key: float(np.median([r[key] for r in rows]))  # noqa: E731
    table, rtk, service = [], {}, []
    load = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        for label in args.passes.split(","):
            d = Path(tmp) / label
            simulate_scenario("earth-pointing", d, seed=SEED,
                              overrides={"duration_s": args.minutes * 60.0, **PASSES[label]})
            for mode in MODES:
                rows = [run_job(d, mode, Path(tmp) / f"work_{label}_{mode}_{i}", job_settings)
                        for i in range(args.runs)]
                r = {"pass": label, "mode": mode, "epochs": rows[0]["epochs"],
                     **{k: med(rows, k) for k in ("filter_cpu_s", "job_cpu_s", "job_wall_s")},
                     "products": rows[0]["products"],
                     "stages_cpu_s": {st: float(np.median([x["stages_cpu_s"][st] for x in rows]))
                                      for st in rows[0]["stages_cpu_s"]}}
                r["filter_eps"] = r["epochs"] / r["filter_cpu_s"]
                table.append(r)
                print({k: (round(v, 3) if isinstance(v, float) else v) for k, v in r.items()}, flush=True)
            if not args.no_rtklib:
                rows = [run_rtklib(d, Path(tmp) / f"rtk_{label}_{i}") for i in range(args.runs)]
                rtk[label] = {k: med(rows, k) for k in ("cpu_s", "wall_s")}
                print(label, "rtklib", rtk[label], flush=True)
            if not args.no_service and label == "realistic":
                for mode in MODES:
                    rows = run_service_jobs(d, mode, args.runs + 1, Path(tmp) / f"svc_{mode}")
                    rows = rows[1:]          # the first upload + job warms the API and the worker up
                    keys = [k for k, v in rows[0].items() if isinstance(v, float)]
                    r = {"pass": label, "mode": mode, **{k: med(rows, k) for k in keys},
                         "stages": rows[len(rows) // 2]["stages"]}
                    service.append(r)
                    print({k: (round(v, 3) if isinstance(v, float) else v) for k, v in r.items()}, flush=True)
    load_after = os.getloadavg()
    lines = [f"Machine: {machine_line()}. One BLAS thread. Load average {load[0]:.1f} at the start, "
             f"{load_after[0]:.1f} at the end (2 cores shared with other work: wall times are inflated by the "
             "load, CPU times much less). Simulator seed 0, preset `earth-pointing`, "
             f"{args.minutes:.0f} min at 1 Hz, three antennas (two baselines), L1 C/A + L2 P(Y). "
             f"Median of {args.runs} runs"
             + ("." if args.baseline_update is None else f"; `baseline_update: {args.baseline_update}`."), "",
             "| pass | mode | epochs | filter CPU s | filter epochs/s (CPU) | job CPU s | job wall s | "
             "RTKLIB postpos, 2 baselines, CPU / wall s | job CPU / RTKLIB CPU |", "|---|---|---|---|---|---|---|---|---|"]
    for r in table:
        p = rtk.get(r["pass"])
        peer = f"{p['cpu_s']:.1f} / {p['wall_s']:.1f}" if p else "-"
        ratio = f"{r['job_cpu_s'] / p['cpu_s']:.2f}" if p else "-"
        lines.append(f"| {r['pass']} | {r['mode']} | {r['epochs']} | {r['filter_cpu_s']:.2f} | "
                     f"{r['filter_eps']:.0f} | {r['job_cpu_s']:.1f} | {r['job_wall_s']:.1f} | {peer} | {ratio} |")
    lines += ["", "Job = worker.jobs.attitude.run on a JobContext (as the runner builds it): parsing, geometry, "
              "filter, attitude, products " + ", ".join(table[0]["products"]) + " (each hashed as stored).", "",
              "CPU s per stage of the job (the pipeline's own stage clock, worker.jobs.attitude.StageClock, "
              "as logged by the worker):", "",
              "| stage | " + " | ".join(f"{r['pass']} {r['mode']}" for r in table) + " |",
              "|---|" + "---|" * len(table)]
    stages = list(table[0]["stages_cpu_s"])
    for st in stages:
        lines.append(f"| {st} | " + " | ".join(f"{r['stages_cpu_s'].get(st, float('nan')):.2f}" for r in table)
                     + " |")
    outside = [sum(v for k, v in r["stages_cpu_s"].items() if k not in ("filtering", "total")) for r in table]
    lines.append("| all but filtering | " + " | ".join(f"{x:.2f}" for x in outside) + " |")
    if service:
        lines += ["", "Upload to products through the real service (`make demo`'s setup: API + one worker, embedded "
                  "SQLite + Huey, default settings; bench.bench_attitude_speed.AttitudeService): the set "
                  f"({service[0]['upload_mb']:.1f} MB) uploaded over HTTP, the attitude job submitted, followed to "
                  "`succeeded` by its event stream (as `gnssatt submit` does), the product list fetched. Wall s (client clock; pick-up and run from the "
                  "job's created/started/finished times) and CPU s of the API process and of the worker with its "
                  "fork server and job children. Median of "
                  f"{args.runs} runs after one warm-up upload + job.", "",
                  "| pass | mode | upload s | submit s | queue pick-up s | run s | submit to seen `succeeded` s | "
                  "upload to product list s | API CPU s (upload) | worker CPU s |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for r in service:
            lines.append(f"| {r['pass']} | {r['mode']} | {r['upload_s']:.2f} | {r['submit_s']:.2f} | "
                         f"{r['pickup_s']:.2f} | {r['run_s']:.1f} | {r['seen_s']:.1f} | {r['total_s']:.1f} | "
                         f"{r['api_cpu_s']:.2f} ({r['api_cpu_upload_s']:.2f}) | {r['worker_cpu_s']:.1f} |")
        lines += ["", "Stages of the middle run as the worker logged them (wall s / CPU s): "
                  + "; ".join(f"{r['mode']}: {r['stages']}" for r in service) + "."]
    lines += ["", f"Run: `OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_attitude_speed.py --runs {args.runs} "
              "--write`."]
    text = "\n".join(lines)
    print(text)
    if args.write:
        # first in the section, above the dated hand-written figures and their history (which it used to replace)
        prepend_to_section(ROOT / "docs" / "BENCHMARKS.md", "Attitude job speed", text)


if __name__ == "__main__":
    main()
