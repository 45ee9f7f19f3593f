"""Service load benchmark: 16 concurrent clients each upload a ~20 MB observation set, submit an `inspect`
job and poll it to the end; then the API's peak RSS while it receives one 1 GiB upload.

Runs the real API and one worker (embedded default: SQLite + Huey) in subprocesses on loopback.
Inputs are generated from seed 20261124. Writes a markdown section to stdout and, with --write, into
docs/BENCHMARKS.md ("Service load").

    .venv/bin/python bench/bench_service_load.py --runs 3 --write
"""
from __future__ import annotations

import argparse
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from datetime import datetime, timedelta
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx
import psutil

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bench._report import machine_line, replace_section  # noqa: E402
from client.local_service import LocalService  # noqa: E402
from gnssatt.sim.sample_set import obs_v3_text, platform_doc  # noqa: E402

SEED = 20261124
START = datetime(2024, 6, 24)


def make_set(out: Path, target_bytes: int = 20 * 1024 * 1024) -> list[Path]:
    """Three RINEX 3.04 files (12 sats, dual-frequency, 1 Hz) totalling ~target_bytes, plus platform.json."""
    out.mkdir(parents=True, exist_ok=True)
    sats = tuple(f"G{i:02d}" for i in (1, 3, 5, 7, 8, 10, 13, 15, 17, 19, 24, 28))
    one_epoch = len(obs_v3_text("X", n_epochs=2, sats=sats)) - len(obs_v3_text("X", n_epochs=1, sats=sats))
    n_epochs = int(target_bytes / 3 / one_epoch)
    paths = []
    for i, ant in enumerate(("GPS-2", "GPS-0", "GPS-1")):
        p = out / f"{ant}.rnx"
        p.write_text(obs_v3_text(ant, n_epochs=n_epochs, sats=sats, seed=SEED + i))
        paths.append(p)
    plat = out / "platform.json"
    import json
    plat.write_text(json.dumps(platform_doc()))
    return paths + [plat]


def make_big_obs(path: Path, target_bytes: int) -> Path:
    """One valid RINEX 3.04 observation file of about target_bytes (epoch lines advance 1 s each)."""
    text = obs_v3_text("BIG", n_epochs=1, seed=SEED)
    header, _, first = text.partition("END OF HEADER\n")
    header += "END OF HEADER\n"
    records = first.split("\n", 1)[1].encode()
    with open(path, "wb") as fh:
        fh.write(header.encode())
        written = len(header)
        k = 0
        while written < target_bytes:
            t = START + timedelta(seconds=k)
            line = f"> {t:%Y %m %d %H %M}{t.second:11.7f}  0  4\n".encode()
            fh.write(line)
            fh.write(records)
            written += len(line) + len(records)
            k += 1
    return path


def load_run(svc: LocalService, key: str, paths: list[Path], clients: int = 16) -> dict:
    upload_s: list[float] = []
    poll_s: list[float] = []
    lock = threading.Lock()

    def one(i: int) -> float:
        with httpx.Client(base_url=svc.url, headers={"Authorization": f"Bearer {key}"}, timeout=600) as c:
            files = [("files", (p.name, open(p, "rb"), "application/octet-stream")) for p in paths]
            t0 = time.perf_counter()
            r = c.post("/v1/observation-sets", files=files)
            dt = time.perf_counter() - t0
            for _, (_, fh, _) in files:
                fh.close()
            assert r.status_code == 201, r.text
            with lock:
                upload_s.append(dt)
            job = c.post("/v1/jobs", json={"type": "inspect", "observation_set_ids": [r.json()["id"]]}).json()
            while True:
                t1 = time.perf_counter()
                state = c.get(f"/v1/jobs/{job['id']}").json()["state"]
                with lock:
                    poll_s.append(time.perf_counter() - t1)
                if state in ("succeeded", "failed", "cancelled"):
                    assert state == "succeeded", state
                    return time.perf_counter() - t0
                time.sleep(0.2)

    t_start = time.perf_counter()
    with ThreadPoolExecutor(clients) as pool:
        list(pool.map(one, range(clients)))
    wall = time.perf_counter() - t_start
    up_window = max(upload_s)
    q = statistics.quantiles
    return {"uploads_per_s": clients / up_window, "upload_p50_s": statistics.median(upload_s),
            "upload_p99_s": q(upload_s, n=100)[98], "poll_p50_ms": statistics.median(poll_s) * 1e3,
            "poll_p99_ms": q(poll_s, n=100)[98] * 1e3, "all_jobs_done_s": wall, "polls": len(poll_s)}


def rss_during_upload(svc: LocalService, key: str, big: Path) -> dict:
    proc = psutil.Process(svc.api.pid)
    base = proc.memory_info().rss
    peak = base
    stop = threading.Event()

    def sample():
        nonlocal peak
        while not stop.is_set():
            try:
                peak = max(peak, proc.memory_info().rss)
            except psutil.Error:
                return
            time.sleep(0.02)

    th = threading.Thread(target=sample, daemon=True)
    th.start()
    t0 = time.perf_counter()
    with httpx.Client(base_url=svc.url, headers={"Authorization": f"Bearer {key}"}, timeout=3600) as c, \
            open(big, "rb") as fh:
        r = c.post("/v1/observation-sets", files=[("files", (big.name, fh, "application/octet-stream"))])
    dt = time.perf_counter() - t0
    stop.set()
    th.join()
    assert r.status_code == 201, r.text[:500]
    return {"size_mib": big.stat().st_size / 2**20, "seconds": dt, "rss_before_mib": base / 2**20,
            "rss_peak_mib": peak / 2**20}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--clients", type=int, default=16)
    ap.add_argument("--big-gib", type=float, default=1.0)
    ap.add_argument("--write", action="store_true")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="gnssatt-bench-") as tmp:
        tmp = Path(tmp)
        paths = make_set(tmp / "set")
        set_mb = sum(p.stat().st_size for p in paths) / 1e6
        big = make_big_obs(tmp / "big.rnx", int(args.big_gib * 2**30))
        loads, rss = [], []
        for run in range(args.runs):
            svc = LocalService(tmp / f"svc{run}", "sqlite", None, None)
            (tmp / f"svc{run}").mkdir()
            svc.env["GNSSATT_MAX_UPLOAD_BYTES"] = str(3 * 2**30)
            svc.env["GNSSATT_MAX_UPLOADS_PER_TEAM"] = str(args.clients)  # the clients share one team's key
            try:
                svc.start_api()
                svc.start_worker()
                key = svc.create_key("bench")
                loads.append(load_run(svc, key, paths, args.clients))
            finally:
                svc.shutdown()
            fresh = LocalService(tmp / f"big{run}", "sqlite", None, None)  # RSS of an API that serves only this
            (tmp / f"big{run}").mkdir()
            fresh.env["GNSSATT_MAX_UPLOAD_BYTES"] = str(3 * 2**30)
            try:
                fresh.start_api()
                rss.append(rss_during_upload(fresh, fresh.create_key("bench"), big))
            finally:
                fresh.shutdown()
            shutil.rmtree(tmp / f"svc{run}", ignore_errors=True)
            shutil.rmtree(tmp / f"big{run}", ignore_errors=True)
            print(f"run {run + 1}: {loads[-1]} {rss[-1]}", file=sys.stderr)
    med = {k: statistics.median(r[k] for r in loads) for k in loads[0]}
    med_rss = {k: statistics.median(r[k] for r in rss) for k in rss[0]}
    section = f"""Command: `.venv/bin/python bench/bench_service_load.py --runs {args.runs} --write`
({machine_line()}). Real API (uvicorn) + one worker in subprocesses, embedded default (SQLite + Huey),
loopback HTTP. Medians of {args.runs} runs; inputs generated from seed {SEED}.

| measure | value |
|---|---|
| clients | {args.clients} of one team (GNSSATT_MAX_UPLOADS_PER_TEAM={args.clients}), each uploading a {set_mb:.1f} MB set (3 RINEX 3.04 files + platform.json), submitting `inspect`, polling every 0.2 s |
| uploads/s (16 uploads / time until the last finished) | {med['uploads_per_s']:.2f} |
| upload latency p50 / p99 | {med['upload_p50_s']:.2f} s / {med['upload_p99_s']:.2f} s |
| job poll latency p50 / p99 (under load) | {med['poll_p50_ms']:.1f} ms / {med['poll_p99_ms']:.1f} ms |
| all 16 jobs done (upload to `succeeded`, one worker) | {med['all_jobs_done_s']:.1f} s |
| 1 GiB upload ({med_rss['size_mib']:.0f} MiB RINEX obs): time incl. validation | {med_rss['seconds']:.1f} s |
| API RSS before / peak during the 1 GiB upload | {med_rss['rss_before_mib']:.0f} MiB / **{med_rss['rss_peak_mib']:.0f} MiB** (target < 200 MB) |
"""
    print(section)
    if args.write:
        replace_section(REPO / "docs" / "BENCHMARKS.md", "Service load", section)


if __name__ == "__main__":
    main()
