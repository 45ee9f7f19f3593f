"""Calibration campaign benchmark (issue 8 "Done when"): accuracy of baselines and maps against the simulator's
truth, the held-out attitude comparison, campaign wall time in-process and through the service on 1..N workers,
per-set cost, and identical maps across runs.

    .venv/bin/python -m bench.bench_calibration [--sets 30] [--workers 1,2,3] [--no-service] [--ekf]

Inputs: `--sets` calibration passes + 1 held-out pass of the `calibration` preset, durations cycling over
45..100 min, 35 mm p-p PCV per antenna (~50 mm differential), Table 3 offsets, reference attitude 2 arcsec,
seed 2024 (each pass simulated as its own run, see tests/calibration/_campaign.py). A noiseless twin campaign
(no noise, no multipath, no reference noise; same geometry, PCO, PCV) gives the estimator's noiseless limit.
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

from tests.calibration._campaign import (compare_maps_mm, input_set, simulate_campaign, truth_map_mm,  # noqa: E402
                                         truth_of)

SEED = 2024


def durations_s(n: int) -> list[float]:
    mins = [45 + (i * 23) % 56 for i in range(n)]  # 45..100 min
    return [60.0 * m for m in mins]


def simulate(root: Path, n: int, overrides: dict) -> list[Path]:
    """n passes, one run each (so all share the antennas), 13 h 7 min apart (never overlapping)."""
    from worker.gnss.time import GpsTime

    t0 = GpsTime.from_iso("2018-01-10T03:00:00")
    dirs = []
    for i, dur in enumerate(durations_s(n)):
        d = simulate_campaign(root / f"d{i:03d}", 1, dur, seed=SEED, overrides={
            "reference_sigma_arcsec": 2.0, "mean_anomaly_deg": (133.2 * i) % 360.0, **overrides},
            start_gps=(t0 + i * (13 * 3600.0 + 7 * 60.0)).iso(0))[0]
        dirs.append(d)
    return dirs


def run_inprocess(dirs: list[Path], cfg: dict, tag: str, work: Path) -> tuple[dict, float, object]:
    from tests.calibration.test_pipeline import _ctx, _products
    from worker.jobs.calibration import CalibrationConfig
    from worker.pipelines.calibration import run

    sets = [input_set(d, set_id=f"{tag}{i:03d}") for i, d in enumerate(dirs)]
    ctx = _ctx(work / tag, sets)
    t0 = time.perf_counter()
    run(ctx, CalibrationConfig(**cfg))
    return _products(ctx), time.perf_counter() - t0, ctx


def run_service(dirs: list[Path], cfg: dict, workers: int, work: Path) -> dict:
    import httpx

    from tests.e2e.conftest import Service

    db = os.environ.get("GNSSATT_TEST_DATABASE_URL")
    queue = os.environ.get("GNSSATT_TEST_QUEUE_URL")
    tmp = work / f"svc{workers}"
    shutil.rmtree(tmp, ignore_errors=True)  # a fresh database and queue per run
    tmp.mkdir(parents=True)
    svc = Service(tmp, "pg" if db else "sqlite", db, queue)
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


def ekf_held_out(d: Path, calibrated: dict) -> dict:
    """The attitude job's filter (issue 6, dynamic mode) on the held-out set with a priori vs calibrated baselines
    (the filter does not apply PCV maps yet)."""
    from worker.attitude.process import load_inputs, process
    from worker.attitude.settings import AttitudeSettings

    s = input_set(d)
    inp = load_inputs([(f.name, f.kind, f.path) for f in s.files])
    out = {}
    for tag, cal in (("a_priori", {}), ("calibrated_baselines", calibrated)):
        t0 = time.perf_counter()
        sol = process(inp, AttitudeSettings(mode="dynamic", calibrated_baselines=cal))
        ref = sol.summary.get("reference", {}).get("fixed", {})
        out[tag] = {k: {"bias_deg": round(v["bias_deg"], 4), "sigma_deg": round(v["sigma_deg"], 4)}
                    for k, v in ref.items()}
        out[tag]["seconds"] = round(time.perf_counter() - t0, 1)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sets", type=int, default=30)
    ap.add_argument("--workers", default="1,2,3")
    ap.add_argument("--no-service", action="store_true")
    ap.add_argument("--ekf", action="store_true")
    ap.add_argument("--work", default="/tmp/gnssatt_bench_calibration")
    args = ap.parse_args()
    work = Path(args.work)
    n = args.sets + 1
    t0 = time.perf_counter()
    dirs = simulate(work / "campaign", n, {})
    twin = simulate(work / "twin", n, {"noise": False, "multipath": False, "cn0_jitter_db": 0.0,
                                       "reference_sigma_arcsec": 0.0})
    t_sim = time.perf_counter() - t0
    held = dirs[-1]
    cfg = {"held_out_set": "cal" + f"{n - 1:03d}"}
    prod, wall, ctx = run_inprocess(dirs, cfg, "cal", work / "jobs")
    cfg_twin = {"held_out_set": "twn" + f"{n - 1:03d}"}
    prod_twin, wall_twin, _ = run_inprocess(twin, cfg_twin, "twn", work / "jobs")
    prod_again, wall_again, _ = run_inprocess(dirs, cfg, "cal", work / "jobs_again")
    identical = all(prod[k] == prod_again[k] for k in prod if k.startswith("pcv_") and k.endswith(".json"))

    truth = truth_of(dirs[0])
    doc = json.loads(prod["baselines.json"])
    doc_twin = json.loads(prod_twin["baselines.json"])
    baselines = []
    for b, bt in zip(doc["baselines"], doc_twin["baselines"]):
        key = (b["from"], b["to"])
        cal, sig = np.asarray(b["calibrated_m"]), np.asarray(b["sigma_m"])
        phys = truth["baselines"][key]["mean_m"]
        limit = np.asarray(bt["calibrated_m"])
        baselines.append({
            "baseline": f"{key[0]}>{key[1]}",
            "a_priori_minus_physical_mm": np.round((np.asarray(b["a_priori_m"]) - phys) * 1e3, 2).tolist(),
            "calibrated_minus_physical_mm": np.round((cal - phys) * 1e3, 2).tolist(),
            "noiseless_limit_minus_physical_mm": np.round((limit - phys) * 1e3, 2).tolist(),
            "calibrated_minus_noiseless_limit_mm": np.round((cal - limit) * 1e3, 3).tolist(),
            "sigma_mm": np.round(sig * 1e3, 3).tolist(),
            "sigma_formal_mm": np.round(np.asarray(b["sigma_formal_m"]) * 1e3, 4).tolist(),
            "within_0p5mm_of_limit": bool(np.all(np.abs(cal - limit) <= 0.5e-3)),
            "within_3sigma_of_limit": bool(np.all(np.abs(cal - limit) <= 3 * sig)),
            "n_epochs": b["n_epochs"]})
    maps = []
    for (first, second) in truth["baselines"]:
        cal = np.asarray(next(b["calibrated_m"] for b in doc["baselines"] if (b["from"], b["to"]) == (first, second)))
        for sig in ("L1", "L2"):
            m = json.loads(prod[f"pcv_{first}_{second}_{sig}.json"])
            values = np.array([[np.nan if v is None else v for v in row] for row in m["values_mm"]])
            count = np.asarray(m["count"])
            az, el = np.meshgrid(m["azimuth_deg"], m["elevation_deg"])
            want = truth_map_mm(truth, (first, second, sig), cal, az, el)
            raw_pcv = truth_map_mm(truth, (first, second, sig), truth["baselines"][(first, second)]
                                   ["per_frequency_m"][sig], az, el)
            entry = {"map": f"{first}>{second} {sig}", "bins_with_value": int(np.isfinite(values).sum()),
                     "truth_p2p_mm": round(float(np.nanmax(raw_pcv[np.isfinite(values)])
                                                 - np.nanmin(raw_pcv[np.isfinite(values)])), 1),
                     "rms_vs_truth_mm": round(compare_maps_mm(values, want, count), 3)}
            for min_n in (100, 300):
                v = np.where(count >= min_n, values, np.nan)
                entry[f"rms_vs_truth_count_ge_{min_n}_mm"] = round(compare_maps_mm(v, want, count), 3)
                entry[f"bins_count_ge_{min_n}"] = int(np.isfinite(v).sum())
            entry["rms_vs_raw_injected_pcv_mm"] = round(compare_maps_mm(values, raw_pcv, count), 3)
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
        "set_minutes": [d / 60 for d in durations_s(n)],
        "simulation_s": round(t_sim, 1),
        "inprocess_wall_s": round(wall, 1), "inprocess_wall_again_s": round(wall_again, 1),
        "pass_timing_s": summary["timing_s"], "pass1_per_set_s_median": round(float(np.median(per_set)), 3),
        "maps_identical_on_rerun": identical,
        "baselines": baselines, "maps": maps, "map_iterations": [(m["pair"], m["frequency"], m["iterations"],
                                                                   m["changes_mm"]) for m in summary["maps"]],
        "held_out_attitude": held_att["cut"], "held_out_detail": held_att,
        "residual_statistics": json.loads(prod["residual_statistics.json"]),
    }
    if args.ekf:
        cal = {(b["from"], b["to"]): np.asarray(b["calibrated_m"]) for b in doc["baselines"]}
        result["ekf_held_out"] = ekf_held_out(held, cal)
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
