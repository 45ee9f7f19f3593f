"""Calibration campaign benchmark (issue 8 "Done when"): accuracy of baselines and maps against the simulator's
truth, the held-out attitude comparison, campaign wall time in-process and through the service on 1..N workers,
per-set cost, and identical maps across runs.

    .venv/bin/python -m bench.bench_calibration [--sets 30] [--workers 1,2,3] [--no-service] [--ekf] [--twin]
    .venv/bin/python -m bench.bench_calibration --scale [--workers 1,2,3] [--repeat 3] [--backend pg] [--write]

`--scale` runs only the service timing (campaign wall time per worker count, median of --repeat jobs on one
service with the sets uploaded once, per-set CPU cost, tasks per worker, identical maps) and with --write rewrites
its block of the "Calibration" section of docs/BENCHMARKS.md.

Inputs: `--sets` calibration passes + 1 held-out pass of the `calibration` preset, durations cycling over
45..100 min, 35 mm p-p PCV per antenna (~50 mm differential), Table 3 offsets, reference attitude 2 arcsec,
seed 2024 (each pass simulated as its own run, see gnssatt/calibration/simulated.py). Truth: the injected antenna
offsets, PCO and PCV expressed in the calibration's baseline/map split (gnssatt/calibration/simulated.py
`truth_split`, gnssatt/calibration/decomposition.py); `--twin` also calibrates a noiseless twin campaign (no noise,
no multipath, no reference noise). `--ekf`: the attitude filter on the held-out set with a priori baselines,
calibrated baselines, and calibrated baselines + the PCV maps. `--budget`: the held-out error budget (a priori,
true and calibrated baselines and maps in every combination, and the pass re-simulated without multipath and
without noise). `--held-out-config '{...}'`: the calibration's held_out_attitude_config (attitude job config of
the held-out comparison), also used by --ekf and --budget. The campaign is simulated once into --work and reused.
Service runs use SQLite + the SQLite queue unless GNSSATT_TEST_DATABASE_URL / GNSSATT_TEST_QUEUE_URL are set.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform as _platform
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bench.local_jobs import input_set, job_context, product_bytes  # noqa: E402
from gnssatt.calibration.simulated import (compare_maps_mm, simulate_campaign, truth_of,  # noqa: E402
                                           truth_split)

SEED = 2024


def durations_s(n: int) -> list[float]:
    mins = [45 + (i * 23) % 56 for i in range(n)]  # 45..100 min
    return [60.0 * m for m in mins]


def simulate(root: Path, n: int, overrides: dict) -> list[Path]:
    """n passes, one run each (so all share the antennas), 13 h 7 min apart (never overlapping)."""
    from gnssatt.gnss.time import GpsTime

    t0 = GpsTime.from_iso("2018-01-10T03:00:00")
    dirs = []
    for i, dur in enumerate(durations_s(n)):
        d = simulate_campaign(root / f"d{i:03d}", 1, dur, seed=SEED, overrides={
            "reference_sigma_arcsec": 2.0, "mean_anomaly_deg": (133.2 * i) % 360.0, **overrides},
            start_gps=(t0 + i * (13 * 3600.0 + 7 * 60.0)).iso(0))[0]
        dirs.append(d)
    return dirs


def run_inprocess(dirs: list[Path], cfg: dict, tag: str, work: Path, skip: tuple = ()) -> tuple[dict, float, object]:
    """(products, wall s, context) of the calibration job run in-process; `skip`: files left out of every set
    (e.g. ("platform.sp3",): the platform position then comes from the code)."""
    from worker.jobs.calibration import CalibrationConfig
    from worker.jobs.calibration import run

    sets = [input_set(d, set_id=f"{tag}{i:03d}", skip=skip) for i, d in enumerate(dirs)]
    ctx = job_context(work / tag, sets)
    t0 = time.perf_counter()
    run(ctx, CalibrationConfig(**cfg))
    return product_bytes(ctx), time.perf_counter() - t0, ctx


def run_service(dirs: list[Path], cfg: dict, workers: int, work: Path) -> dict:
    import httpx

    from client.local_service import LocalService

    db = os.environ.get("GNSSATT_TEST_DATABASE_URL")
    queue = os.environ.get("GNSSATT_TEST_QUEUE_URL")
    tmp = work / f"svc{workers}"
    shutil.rmtree(tmp, ignore_errors=True)  # a fresh database and queue per run
    tmp.mkdir(parents=True)
    svc = LocalService(tmp, "pg" if db else "sqlite", db, queue)
    try:
        svc.start_api()
        for _ in range(workers):
            svc.start_worker()
        key = svc.create_key("bench")
        with svc.client(key) as c:
            c.timeout = httpx.Timeout(600)
            ids = []
            t_up = time.perf_counter()
            for d in dirs:
                paths = [p for p in sorted(d.rglob("*")) if p.is_file() and "truth" not in p.parts]
                files = [("files", (p.name, p.read_bytes(), "application/octet-stream")) for p in paths]
                r = c.post("/v1/observation-sets", files=files, data={"name": d.parent.name})
                r.raise_for_status()
                ids.append(r.json()["id"])
            t_up = time.perf_counter() - t_up
            t0 = time.perf_counter()
            job = c.post("/v1/jobs", json={"type": "calibration", "observation_set_ids": ids, "config": cfg})
            job.raise_for_status()
            jid = job.json()["id"]
            while True:
                j = c.get(f"/v1/jobs/{jid}").json()
                if j["state"] in ("succeeded", "failed", "cancelled"):
                    break
                time.sleep(0.5)
            wall = time.perf_counter() - t0
            if j["state"] != "succeeded":
                raise RuntimeError(f"service run failed: {json.dumps(j)[:3000]}\n{svc.logs_text()}")
            maps = {}
            listing = c.get(f"/v1/jobs/{jid}/products").json()
            for p in (listing["items"] if isinstance(listing, dict) else listing):
                if p["name"].startswith("pcv_") and p["name"].endswith(".json"):
                    maps[p["name"]] = hashlib.sha256(c.get(f"/v1/jobs/{jid}/products/{p['name']}").content).hexdigest()
        # the fan-out in the workers' logs: "task <id> of job <id> (#<set>) done by <worker> in <s> s"
        task_lines = [ln.strip() for p in svc.logs if p.name.startswith("worker") and p.exists()
                      for ln in p.read_text(errors="replace").splitlines() if "gnssatt.fanout: task" in ln]
        workers_used = sorted({ln.split(" done by ")[1].split()[0] for ln in task_lines if " done by " in ln})
        per_worker = {w: sum(1 for ln in task_lines if f" done by {w} " in ln) for w in workers_used}
        return {"workers": workers, "backend": svc.backend, "upload_s": round(t_up, 1), "wall_s": round(wall, 1),
                "map_sha256": maps, "tasks_per_worker": per_worker, "task_log_sample": task_lines[:3]}
    finally:
        svc.shutdown()


SCALE_BEGIN = "<!-- bench_calibration --scale: begin (generated, do not edit by hand) -->"
SCALE_END = "<!-- bench_calibration --scale: end -->"


class ScaleService:
    """One API + database (fresh: SQLite file, or a scratch PostgreSQL database + unique Redis queue) with the
    campaign uploaded once; the number of worker processes is changed between jobs (workers wait idle, warm)."""

    def __init__(self, work: Path, pg: tuple[str, str] | None, own_session: bool = False):
        from client.local_service import LocalService

        self.scratch_db = None
        self.admin_engine = None
        db_url = queue_url = None
        if pg:
            import uuid

            from sqlalchemy import create_engine, text
            from sqlalchemy.engine import make_url

            base_db, queue_url = pg
            self.admin_engine = create_engine(base_db, isolation_level="AUTOCOMMIT")
            self.scratch_db = f"gnssatt_bench_{uuid.uuid4().hex[:12]}"
            with self.admin_engine.connect() as conn:
                conn.execute(text(f'CREATE DATABASE "{self.scratch_db}"'))
            db_url = make_url(base_db).set(database=self.scratch_db).render_as_string(hide_password=False)
        shutil.rmtree(work, ignore_errors=True)
        work.mkdir(parents=True)
        self.svc = LocalService(work, "pg" if pg else "sqlite", db_url, queue_url)
        if own_session:
            # each worker in its own session, as separate service units would be: with the kernel's autogroup
            # scheduling (sched_autogroup_enabled=1) all processes of one session share ONE fair CPU share, so on
            # a machine busy with other sessions' work 2 workers started from one shell get no more CPU than 1
            svc = self.svc

            def spawn(args, log_name):
                log = svc.tmp / f"{log_name}-{len(svc.logs)}.log"
                svc.logs.append(log)
                return subprocess.Popen([sys.executable, "-m", "client.cli", *args], cwd=REPO, env=svc.env,
                                        stdout=open(log, "wb"), stderr=subprocess.STDOUT,
                                        start_new_session=log_name == "worker")

            svc._spawn = spawn
        self.svc.env["GNSSATT_LEASE_SECONDS"] = "60"  # heavy tasks under load must not lose their lease
        self.svc.env["GNSSATT_HEARTBEAT_SECONDS"] = "5"
        self.svc.env["OPENBLAS_NUM_THREADS"] = "1"
        self.svc.start_api()
        self.key = self.svc.create_key("bench")
        self.ids: list[str] = []

    def client(self):
        import httpx

        c = self.svc.client(self.key)
        c.timeout = httpx.Timeout(600)
        return c

    def upload(self, dirs: list[Path]) -> float:
        t0 = time.perf_counter()
        with self.client() as c:
            for d in dirs:
                paths = [p for p in sorted(d.rglob("*")) if p.is_file() and "truth" not in p.relative_to(d).parts]
                files = [("files", (p.name, p.read_bytes(), "application/octet-stream")) for p in paths]
                r = c.post("/v1/observation-sets", files=files, data={"name": d.parent.name})  # d<i>/set_000
                r.raise_for_status()
                self.ids.append(r.json()["id"])
        return time.perf_counter() - t0

    def set_workers(self, n: int) -> None:
        """Exactly n worker processes, each with its consumer started (so start-up is not timed)."""
        while len(self.svc.workers) > n:
            self.svc.kill_worker(self.svc.workers[-1], sig=2)
        while len(self.svc.workers) < n:
            self.svc.start_worker()
            log = self.svc.logs[-1]
            deadline = time.monotonic() + 120
            while "consumer started" not in (log.read_text(errors="replace") if log.exists() else ""):
                if time.monotonic() > deadline:
                    raise RuntimeError(f"worker did not start:\n{self.svc.logs_text()}")
                time.sleep(0.2)

    def run_job(self, cfg: dict) -> dict:
        import csv
        import io

        with self.client() as c:
            load0 = os.getloadavg()
            t0 = time.perf_counter()
            job = c.post("/v1/jobs", json={"type": "calibration", "observation_set_ids": self.ids, "config": cfg})
            job.raise_for_status()
            jid = job.json()["id"]
            while True:
                j = c.get(f"/v1/jobs/{jid}").json()
                if j["state"] in ("succeeded", "failed", "cancelled"):
                    break
                time.sleep(0.25)
            wall = time.perf_counter() - t0
            load1 = os.getloadavg()
            if j["state"] != "succeeded":
                raise RuntimeError(f"service run failed: {json.dumps(j)[:3000]}\n{self.svc.logs_text()}")
            get = lambda name: c.get(f"/v1/jobs/{jid}/products/{name}").content  # noqa: E731
            listing = c.get(f"/v1/jobs/{jid}/products").json()
            names = [p["name"] for p in (listing["items"] if isinstance(listing, dict) else listing)]
            hashes = {n: hashlib.sha256(get(n)).hexdigest() for n in names
                      if n == "baselines.json" or (n.startswith("pcv_") and n.endswith(".json"))}
            summary = json.loads(get("calibration_summary.json"))
            tasks = list(csv.DictReader(io.StringIO(get("tasks.csv").decode())))
        return {"job": jid, "wall_s": wall, "load_before": load0, "load_after": load1, "sha256": hashes,
                "timing_s": summary["timing_s"], "workers": summary["workers"], "tasks": tasks,
                "per_set": summary["per_set"]}

    def shutdown(self) -> None:
        self.svc.shutdown()
        if self.scratch_db and self.admin_engine is not None:
            from sqlalchemy import text

            with self.admin_engine.connect() as conn:
                conn.execute(text(f'DROP DATABASE IF EXISTS "{self.scratch_db}" WITH (FORCE)'))
            self.admin_engine.dispose()


def scale(args, dirs: list[Path], work: Path) -> dict:
    """Campaign wall time through the real service on 1..N workers, `--repeat` jobs each (interleaved), with
    identical-map check across all runs, per-set CPU cost and the fan-out (tasks per worker)."""
    workers = [int(x) for x in args.workers.split(",") if x]
    pg = None
    if args.backend == "pg":
        pg = (os.environ.get("GNSSATT_TEST_DATABASE_URL", "postgresql+psycopg://postgres@127.0.0.1:5432/test"),
              os.environ.get("GNSSATT_TEST_QUEUE_URL", "redis://127.0.0.1:6379/0"))
    svc = ScaleService(work / f"scale_{args.backend}", pg, own_session=args.own_session)
    runs: list[dict] = []
    try:
        t_up = svc.upload(dirs)
        print(f"uploaded {len(dirs)} sets in {t_up:.1f} s", flush=True)
        for rep in range(args.repeat):
            for w in workers:
                svc.set_workers(w)
                r = svc.run_job(cfg_service(len(dirs)))
                r.update(n_workers=w, rep=rep)
                runs.append(r)
                print(json.dumps({k: v for k, v in r.items() if k not in ("tasks", "per_set", "sha256")}),
                      flush=True)
    finally:
        svc.shutdown()
    shas = [r["sha256"] for r in runs]
    med = {w: float(np.median([r["wall_s"] for r in runs if r["n_workers"] == w])) for w in workers}
    return {"backend": args.backend, "own_session": args.own_session, "sets": len(dirs) - 1, "upload_s": t_up,
            "runs": runs, "autogroup": _autogroup(),
            "identical": all(s == shas[0] for s in shas) and len(shas[0]) >= 2, "median_wall_s": med,
            "speedup": {w: med[workers[0]] / med[w] for w in workers}}


def _autogroup() -> str:
    try:
        return Path("/proc/sys/kernel/sched_autogroup_enabled").read_text().strip()
    except OSError:
        return "?"


def scale_markdown(res: dict, command: str) -> str:
    from bench._report import machine_line

    runs = res["runs"]
    workers = sorted({r["n_workers"] for r in runs})
    loads = [x for r in runs for x in (r["load_before"][0], r["load_after"][0])]
    cpu1 = [s["pass1_cpu_s"] for r in runs for s in r["per_set"]]
    cpu2 = [s["pass2_cpu_s"] for r in runs for s in r["per_set"]]
    held = [x for r in runs for x in r["timing_s"].get("held_out_cpu_s", [])]
    lines = [f"**Scale** (the real service, {'PostgreSQL + Redis' if res['backend'] == 'pg' else 'SQLite + Huey'}; "
             f"{machine_line()}): `{command}`. {res['sets']} calibration sets + 1 held out (the campaign above, "
             f"default grid), uploaded once ({res['upload_s']:.0f} s); each job timed submit to `succeeded`, "
             f"workers already running and idle; {len(runs) // len(workers)} job(s) per worker count, interleaved. "
             f"**Load average (1 min) during the runs: {min(loads):.1f} to {max(loads):.1f}** on 2 cores (other "
             f"sessions' work); wall times and the speed-up are only meaningful on a quiet machine. Workers "
             + ("each in their own session (own CPU share under the kernel's autogroup scheduling, as separate "
                "service units)" if res.get("own_session") else "started from the bench's session (with "
                "sched_autogroup_enabled=" + str(res.get("autogroup")) + " they share one CPU share while other "
                "sessions are busy)") + ".", "",
             "| workers | wall s (median) | runs | speed-up vs 1 | parent stages s (checks / pass 1 / maps / pass 2 / "
             "products) | tasks per worker (busy s) |", "|---|---|---|---|---|---|"]
    for w in workers:
        rw = [r for r in runs if r["n_workers"] == w]
        mid = sorted(rw, key=lambda r: r["wall_s"])[len(rw) // 2]
        t = mid["timing_s"]
        stages = " / ".join(f"{t.get(k, float('nan')):.1f}" for k in ("checks", "pass1", "maps", "pass2",
                                                                        "maps_products_and_plots"))
        per_w = ", ".join(f"{v['tasks']} ({v['busy_s']:.0f})" for _, v in sorted(mid["workers"].items()))
        walls = ", ".join(f"{r['wall_s']:.1f}" for r in rw)
        lines.append(f"| {w} | {res['median_wall_s'][w]:.1f} | {walls} | "
                     f"{res['speedup'][w]:.2f}x | {stages} | {per_w} |")
    lines += ["", f"Per-set cost (CPU, median over all runs): pass 1 {np.median(cpu1):.2f} s, pass 2 "
              f"{np.median(cpu2):.2f} s, held-out set (pass 2, three extractions + two filter runs) "
              f"{np.median(held) if held else float('nan'):.2f} s. Maps and baselines byte-identical (sha256) "
              f"over all {len(runs)} runs: {'yes' if res['identical'] else 'NO'}. The fan-out of every job is its "
              "`tasks.csv` product (pass, queue position, set, worker, start/end s); the held-out task is first "
              "in pass 2's queue and the sets go longest first."]
    two = [r for r in runs if r["n_workers"] == (2 if 2 in workers else workers[-1])]
    if two:
        mid = sorted(two, key=lambda r: r["wall_s"])[len(two) // 2]
        names = {w: f"worker-{i + 1}" for i, w in enumerate(sorted({t["worker"] for t in mid["tasks"]}))}
        lines += ["", f"Excerpt of that job's `tasks.csv` ({mid['n_workers']} workers, {mid['wall_s']:.1f} s; "
                  "worker names shortened; first and last tasks of each pass):", "", "```",
                  "pass,task,set,worker,attempts,start_s,end_s,seconds"]
        for p in ("1", "2"):
            rows = [t for t in mid["tasks"] if t["pass"] == p]
            shown = rows[:4] + ([{"pass": "..."}] if len(rows) > 7 else []) + rows[max(4, len(rows) - 3):]
            for t in shown:
                lines.append("..." if t["pass"] == "..." else ",".join(
                    [t["pass"], t["task"], t["set"], names[t["worker"]], t["attempts"], t["start_s"], t["end_s"],
                     t["seconds"]]))
        lines.append("```")
    return "\n".join(lines)


def write_scale_block(path: Path, text: str) -> None:
    """Replace the generated scale block inside the Calibration section (the rest is left alone)."""
    doc = path.read_text()
    block = f"{SCALE_BEGIN}\n{text.strip()}\n{SCALE_END}"
    if SCALE_BEGIN in doc and SCALE_END in doc:
        a, b = doc.index(SCALE_BEGIN), doc.index(SCALE_END) + len(SCALE_END)
        doc = doc[:a] + block + doc[b:]
    else:
        raise SystemExit(f"no scale block markers in {path}")
    path.write_text(doc)


def _settings_of(config: dict) -> dict:
    """AttitudeSettings keyword arguments of an attitude job config (worker.jobs.attitude.AttitudeConfig) that
    differ from the settings' defaults (so the budget runs the filter the held-out comparison runs)."""
    if not config:
        return {}
    from dataclasses import asdict

    from gnssatt.attitude.settings import AttitudeSettings
    from worker.jobs.attitude import AttitudeConfig

    s, d = asdict(AttitudeConfig(**config).to_settings()), asdict(AttitudeSettings())
    return {k: v for k, v in s.items() if v != d[k]}


def ekf_held_out(d: Path, calibrated: dict, maps: dict | None = None, config: dict | None = None) -> dict:
    """The attitude job's filter (issue 6, dynamic mode) on the held-out set with a priori baselines, calibrated
    baselines, and calibrated baselines + PCV maps ((first, second, freq) -> map JSON) applied by the filter."""
    from gnssatt.attitude.process import load_inputs, process
    from gnssatt.attitude.settings import AttitudeSettings

    s = input_set(d)
    inp = load_inputs([(f.name, f.kind, f.path) for f in s.files])
    out = {}
    runs = [("a_priori", {}, {}, "exclude"), ("calibrated_baselines", calibrated, {}, "exclude")]
    if maps:
        runs.append(("calibrated_baselines_and_maps", calibrated, maps, "exclude"))
        runs.append(("calibrated_baselines_and_maps_empty_bins_kept", calibrated, maps, "keep"))
    for tag, cal, pcv, empty in runs:
        t0 = time.perf_counter()
        sol = process(inp, AttitudeSettings.preset("seed000", **{"mode": "dynamic", **_settings_of(config or {}),
                                               "calibrated_baselines": cal, "pcv_maps": pcv,
                                               "pcv_empty_bins": empty}))
        ref = sol.summary.get("reference", {}).get("fixed", {})
        out[tag] = {k: {"bias_deg": round(v["bias_deg"], 4), "sigma_deg": round(v["sigma_deg"], 4)}
                    for k, v in ref.items()}
        out[tag]["seconds"] = round(time.perf_counter() - t0, 1)
    a0 = out["a_priori"]
    for tag in [r[0] for r in runs[1:]]:
        out[tag]["cut_percent"] = {k: {"bias": round(100 * (1 - abs(out[tag][k]["bias_deg"]) / abs(a0[k]["bias_deg"])), 1)
                                       if a0[k]["bias_deg"] else None,
                                       "sigma": round(100 * (1 - out[tag][k]["sigma_deg"] / a0[k]["sigma_deg"]), 1)
                                       if a0[k]["sigma_deg"] else None}
                                   for k in a0 if isinstance(a0[k], dict) and k in out[tag]}
    return out


def held_out_budget(held: Path, prod: dict, extra: dict | None = None, twins: bool = True) -> dict:
    """Error budget of the held-out comparison (docs/calibration.md "Held-out attitude"): the attitude filter
    (dynamic mode, the attitude job's defaults + `extra` settings) on the held-out pass with a priori, true and
    calibrated baselines and maps in every combination; truth = the injected offsets/PCO/PCV in the calibration's
    split (truth_split), on the calibrated maps' filled bins and on the full grid. With `twins`, the same pass
    re-simulated without multipath and without any noise (the reference attitude keeps its 2 arcsec) bounds what
    noise and multipath leave."""
    from gnssatt.attitude.process import load_inputs
    from gnssatt.attitude.settings import AttitudeSettings
    from gnssatt.calibration.held_out import cut_percent, filter_errors

    truth = truth_of(held)
    doc = json.loads(prod["baselines.json"])
    cal = {(b["from"], b["to"]): [float(x) for x in b["calibrated_m"]] for b in doc["baselines"]}
    cmaps, tmaps, tfull, tb, tbf = {}, {}, {}, {}, {}
    for key in cal:
        ms, counts = {}, {}
        for sig in ("L1", "L2"):
            m = json.loads(prod[f"pcv_{key[0]}_{key[1]}_{sig}.json"])
            v = np.array([[np.nan if x is None else x for x in row] for row in m["values_mm"]])
            counts[sig], ms[sig] = np.where(np.isfinite(v), np.asarray(m["count"]), 0), m
            cmaps[key + (sig,)] = m
        tb[key], mt = truth_split(truth, key, m["azimuth_deg"], m["elevation_deg"], counts)
        tbf[key], mtf = truth_split(truth, key, m["azimuth_deg"], m["elevation_deg"],
                                    {s_: np.ones_like(c) for s_, c in counts.items()})
        for sig in ("L1", "L2"):
            tmaps[key + (sig,)] = {**ms[sig], "values_mm": [[None if not np.isfinite(x) else float(x) for x in r]
                                                            for r in mt[sig]]}
            tfull[key + (sig,)] = {**ms[sig], "values_mm": mtf[sig].tolist()}
    sets = {"held": held}
    if twins:
        i = int(held.parent.name[1:])
        from gnssatt.gnss.time import GpsTime
        t0 = GpsTime.from_iso("2018-01-10T03:00:00")
        for tag, ov in (("no_multipath", {"multipath": False}),
                        ("no_noise_no_multipath", {"multipath": False, "noise": False, "cn0_jitter_db": 0.0})):
            sets[tag] = simulate_campaign(held.parents[1].parent / f"twin_{tag}" / held.parent.name, 1,
                                          durations_s(i + 1)[i], seed=SEED, overrides={
                                              "reference_sigma_arcsec": 2.0, "mean_anomaly_deg": (133.2 * i) % 360.0,
                                              **ov}, start_gps=(t0 + i * (13 * 3600.0 + 7 * 60.0)).iso(0))[0]
    runs = [("a_priori", {}, {}), ("calibrated_baselines", cal, {}), ("true_baselines", tb, {}),
            ("calibrated_baselines_and_maps", cal, cmaps), ("true_baselines_and_maps_filled_bins", tb, tmaps),
            ("true_baselines_and_maps_full_grid", tbf, tfull), ("true_baselines_calibrated_maps", tb, cmaps),
            ("calibrated_baselines_true_maps", cal, tmaps)]
    out = {"settings": extra or {}}
    for sk, d in sets.items():
        inputs = load_inputs([(f.name, f.kind, f.path) for f in input_set(d).files])
        res = {}
        for tag, b, m in runs if sk == "held" else [r for r in runs if r[0] in (
                "a_priori", "calibrated_baselines_and_maps", "true_baselines_and_maps_full_grid")]:
            res[tag] = filter_errors(inputs, AttitudeSettings.preset("seed000", mode="dynamic", **(extra or {}))
                                     .override(calibration={"calibrated_baselines": b, "pcv_maps": m}))
            if tag != "a_priori":
                res[tag]["cut"] = cut_percent(res["a_priori"], res[tag])
            print(sk, tag, {a: (res[tag][a]["bias_deg"], res[tag][a]["std_deg"]) for a in ("yaw", "pitch", "roll")},
                  res[tag].get("cut"), flush=True)
        out[sk] = res
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sets", type=int, default=30)
    ap.add_argument("--workers", default="1,2,3")
    ap.add_argument("--no-service", action="store_true")
    ap.add_argument("--ekf", action="store_true")
    ap.add_argument("--twin", action="store_true", help="also calibrate the noiseless twin campaign")
    ap.add_argument("--held-out-config", default=None,
                    help="JSON: the calibration's held_out_attitude_config (attitude job config of the held-out "
                         "comparison), also used by --ekf and --budget; default: the calibration's default "
                         "(smoother, all phases); '{}' = the attitude job's defaults")
    ap.add_argument("--budget", action="store_true",
                    help="error budget of the held-out comparison: true/calibrated baselines and maps, twins "
                         "without multipath and noise (held_out_budget)")
    ap.add_argument("--no-rerun", action="store_true", help="skip the in-process re-run (identical maps check)")
    ap.add_argument("--no-platform-sp3", action="store_true",
                    help="leave the platform's SP3 out of every set (position and velocity from the code)")
    ap.add_argument("--config", default=None, help="JSON: more calibration job config (e.g. epoch_baselines)")
    ap.add_argument("--work", default="/tmp/gnssatt_bench_calibration")
    ap.add_argument("--scale", action="store_true",
                    help="only the service timing: --repeat jobs per worker count on one service")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--backend", choices=("pg", "sqlite"), default="pg",
                    help="--scale: PostgreSQL + Redis (GNSSATT_TEST_DATABASE_URL / GNSSATT_TEST_QUEUE_URL or the "
                         "local defaults) or SQLite + Huey")
    ap.add_argument("--own-session", action="store_true",
                    help="--scale: start each worker in its own session (own CPU share under autogroup scheduling)")
    ap.add_argument("--write", action="store_true", help="--scale: rewrite the scale block of docs/BENCHMARKS.md")
    args = ap.parse_args()
    work = Path(args.work)
    n = args.sets + 1
    t0 = time.perf_counter()
    dirs = simulate(work / "campaign", n, {})
    if args.scale:
        res = scale(args, dirs, work)
        (work / "scale.json").write_text(json.dumps(res, indent=1, default=str))
        text = scale_markdown(res, "OPENBLAS_NUM_THREADS=1 .venv/bin/python -m bench.bench_calibration --scale "
                              + " ".join(a for a in sys.argv[1:] if a != "--scale"))
        print(text)
        if args.write:
            write_scale_block(REPO / "docs" / "BENCHMARKS.md", text)
        return
    twin = simulate(work / "twin", n, {"noise": False, "multipath": False, "cn0_jitter_db": 0.0,
                                       "reference_sigma_arcsec": 0.0}) if args.twin else None
    t_sim = time.perf_counter() - t0
    held = dirs[-1]
    from worker.jobs.calibration import HELD_OUT_ATTITUDE_DEFAULT

    held_cfg = HELD_OUT_ATTITUDE_DEFAULT if args.held_out_config is None else json.loads(args.held_out_config)
    cfg = {"held_out_set": "cal" + f"{n - 1:03d}", "held_out_attitude_config": held_cfg,
           **(json.loads(args.config) if args.config else {})}
    skip = ("platform.sp3",) if args.no_platform_sp3 else ()
    prod, wall, ctx = run_inprocess(dirs, cfg, "cal", work / "jobs", skip)
    cfg_twin = {"held_out_set": "twn" + f"{n - 1:03d}"}
    prod_twin = run_inprocess(twin, cfg_twin, "twn", work / "jobs")[0] if twin else None
    if args.no_rerun:
        wall_again, identical = float("nan"), None
    else:
        prod_again, wall_again, _ = run_inprocess(dirs, cfg, "cal", work / "jobs_again", skip)
        identical = all(prod[k] == prod_again[k] for k in prod if k.startswith("pcv_") and k.endswith(".json"))

    truth = truth_of(dirs[0])
    doc = json.loads(prod["baselines.json"])
    doc_twin = json.loads(prod_twin["baselines.json"]) if prod_twin else None
    baselines, maps = [], []
    for i, b in enumerate(doc["baselines"]):
        key = (b["from"], b["to"])
        est, counts = {}, {}
        for sig in ("L1", "L2"):
            m = json.loads(prod[f"pcv_{key[0]}_{key[1]}_{sig}.json"])
            est[sig] = np.array([[np.nan if v is None else v for v in row] for row in m["values_mm"]])
            counts[sig] = np.where(np.isfinite(est[sig]), np.asarray(m["count"]), 0)
        # the injected truth in the calibration's baseline/map split (gnssatt/calibration/decomposition.py)
        bt, mt = truth_split(truth, key, m["azimuth_deg"], m["elevation_deg"], counts)
        cal, sig_m = np.asarray(b["calibrated_m"]), np.asarray(b["sigma_m"])
        phys = truth["baselines"][key]["mean_m"]
        entry = {
            "baseline": f"{key[0]}>{key[1]}",
            "a_priori_minus_truth_mm": np.round((np.asarray(b["a_priori_m"]) - bt) * 1e3, 2).tolist(),
            "calibrated_minus_truth_mm": np.round((cal - bt) * 1e3, 3).tolist(),
            "truth_minus_physical_mean_mm": np.round((bt - phys) * 1e3, 2).tolist(),
            "sigma_mm": np.round(sig_m * 1e3, 3).tolist(),
            "sigma_formal_mm": np.round(np.asarray(b["sigma_formal_m"]) * 1e3, 4).tolist(),
            "within_0p3mm": bool(np.all(np.abs(cal - bt) <= 0.3e-3)),
            "split": b.get("split"),
            "within_3sigma": bool(np.all(np.abs(cal - bt) <= 3 * sig_m)),
            "n_epochs": b["n_epochs"]}
        if doc_twin:
            entry["calibrated_minus_noiseless_twin_mm"] = np.round(
                (cal - np.asarray(doc_twin["baselines"][i]["calibrated_m"])) * 1e3, 3).tolist()
        baselines.append(entry)
        for sig in ("L1", "L2"):
            values, count = est[sig], counts[sig]
            entry = {"map": f"{key[0]}>{key[1]} {sig}", "bins_with_value": int(np.isfinite(values).sum()),
                     "truth_p2p_mm": round(float(np.nanmax(mt[sig][count > 0]) - np.nanmin(mt[sig][count > 0])), 1),
                     "rms_vs_truth_mm": round(compare_maps_mm(values, mt[sig], count), 3)}
            for min_n in (100, 300):
                v = np.where(count >= min_n, values, np.nan)
                entry[f"rms_vs_truth_count_ge_{min_n}_mm"] = round(compare_maps_mm(v, mt[sig], count), 3)
                entry[f"bins_count_ge_{min_n}"] = int(np.isfinite(v).sum())
            maps.append(entry)
    held_att = json.loads(prod["held_out_attitude.json"])
    summary = json.loads(prod["calibration_summary.json"])
    per_set = [s["pass1_seconds"] for s in summary["per_set"]]
    result = {
        "machine": {"cpu": _platform.processor() or _platform.machine(), "cores": os.cpu_count(),
                    "python": _platform.python_version()},
        "commit": subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True,
                                 text=True).stdout.strip(),
        "date": time.strftime("%Y-%m-%d"), "seed": SEED, "sets": args.sets, "held_out": held.parent.name,
        "platform_sp3": not args.no_platform_sp3, "config": cfg, "extractor": summary.get("extractor"),
        "platform_position": sorted({s.get("platform_position", "") for s in summary["per_set"]}),
        "set_minutes": [d / 60 for d in durations_s(n)],
        "simulation_s": round(t_sim, 1),
        "inprocess_wall_s": round(wall, 1), "inprocess_wall_again_s": round(wall_again, 1),
        "pass_timing_s": summary["timing_s"], "pass1_per_set_s_median": round(float(np.median(per_set)), 3),
        "maps_identical_on_rerun": identical,
        "baselines": baselines, "maps": maps, "map_iterations": [(m["pair"], m["frequency"], m["iterations"],
                                                                   m["changes_mm"]) for m in summary["maps"]],
        "held_out_attitude": held_att.get("cut"), "held_out_epoch_wise": held_att.get("epoch_wise", {}).get("cut"),
        "held_out_detail": held_att,
        "residual_statistics": json.loads(prod["residual_statistics.json"]),
    }
    if args.ekf:
        cal = {(b["from"], b["to"]): np.asarray(b["calibrated_m"]) for b in doc["baselines"]}
        pcv = {}
        for (first, second) in cal:
            for sig in ("L1", "L2"):
                name = f"pcv_{first}_{second}_{sig}.json"
                if name in prod:
                    pcv[(first, second, sig)] = json.loads(prod[name])
        result["ekf_held_out"] = ekf_held_out(held, cal, pcv, held_cfg)
    if args.budget:
        result["held_out_budget"] = held_out_budget(held, prod, _settings_of(held_cfg))
    if not args.no_service:
        runs = []
        for w in [int(x) for x in args.workers.split(",") if x]:
            runs.append(run_service(dirs, cfg_service(n), w, work))
            print(json.dumps(runs[-1]), flush=True)
        result["service"] = runs
        shas = [r["map_sha256"] for r in runs]
        result["service_maps_identical"] = all(s == shas[0] for s in shas)
        inproc = {k: hashlib.sha256(v).hexdigest() for k, v in prod.items() if k.startswith("pcv_") and k.endswith(".json")}
        result["service_maps_equal_inprocess"] = all(s == inproc for s in shas)
    out = work / "result.json"
    out.write_text(json.dumps(result, indent=1, default=str))
    print(json.dumps(result, indent=1, default=str))


def cfg_service(n: int) -> dict:
    return {"held_out_set": f"d{n - 1:03d}"}


if __name__ == "__main__":
    main()
