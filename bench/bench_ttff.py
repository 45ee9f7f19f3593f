"""Time to first fix (issue 7): >= 200 realistic random starts, the paper's method next to seed 000 Table 5, the
constrained search's instant-fix and single-epoch success, a CubeSat-like 10 cm set, and the `ttff` job's run time
on one and two workers.

    .venv/bin/python -m bench.bench_ttff study   --count 200 --seed 1 --procs 2   # -> /tmp/bench_ttff_study.json
    .venv/bin/python -m bench.bench_ttff cubesat --count 4 --seed 1              # -> /tmp/bench_ttff_cubesat.json
    .venv/bin/python -m bench.bench_ttff cubesat --count 4 --seed 1 --duration 600   # the earlier 600 s sets
    .venv/bin/python -m bench.bench_ttff job     --count 200 --workers 1 2        # -> /tmp/bench_ttff_job.json
    .venv/bin/python -m bench.bench_ttff report  [--rtk A.json B.json] [--write]  # tables; --write: BENCHMARKS.md

Starts (gnssatt.ttff.starts): yaw +-180, pitch +-70, roll +-40 deg from Earth pointing, slewing back at a peak rate
uniform in 0.1-0.5 deg/s, CASSIOPE-like antennas, simulator preset `ttff` as it is (its realism: docs/ttff.md
"Realism"), 120 s per start, seed named on the command line. Same seed -> same files (RTKLIB's bench re-simulates
them: bench/bench_ttff_rtklib.py).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bench._ttff_common import BASELINES, set_files, study_payloads  # noqa: E402

SEED_000_TABLE5 = {  # instant-fix share [%] and mean non-zero TTFF [s], baselines 0-2 and 1-2
    "L1+L2": {"instant": (90, 85), "mean": (9.0, 3.3)},
    "L1": {"instant": (50, 40), "mean": (18.2, 19.4)},
    "L2": {"instant": (75, 50), "mean": (7.1, 10.9)},
}
def _task(payload: dict) -> dict:
    from worker.pipelines.ttff import set_task
    return set_task(payload, [])


def cmd_study(args) -> None:
    from multiprocessing import get_context

    pl = study_payloads(args.count, args.seed, args.duration, methods=args.methods)
    t0 = time.perf_counter()
    out = []
    with get_context("fork").Pool(args.procs) as pool:
        for i, r in enumerate(pool.imap(_task, pl)):
            out.append(r)
            Path(args.out + ".partial").write_text(json.dumps({"count": i + 1, "seed": args.seed, "duration_s":
                                                              args.duration, "procs": args.procs,
                                                              "wall_s": time.perf_counter() - t0, "results": out}))
            if (i + 1) % 10 == 0:
                print(f"{i + 1}/{len(pl)} sets, {time.perf_counter() - t0:.0f} s", flush=True)
    wall = time.perf_counter() - t0
    Path(args.out).write_text(json.dumps({"count": args.count, "seed": args.seed, "duration_s": args.duration,
                                          "procs": args.procs, "wall_s": wall, "results": out}))
    print(f"wrote {args.out} ({wall:.0f} s)")


def satellite_counts(ss, step_s: float) -> list[list[int]]:
    """Per sampled epoch (every step_s, as the study samples), per baseline: satellites with L1 phase and code
    above the Table 2 C/N0 mask on both antennas (the count epoch_problem's usability rules see)."""
    import numpy as np

    from gnssatt.ttff.single_epoch import SingleEpochOptions

    pobs, geom, t = ss.pobs, ss.geom, ss.t_s
    f = pobs.signals.index("L1")
    mask = SingleEpochOptions().cn0_mask("L1")
    sample = np.flatnonzero(np.diff(np.floor((t - t[0]) / step_s), prepend=-1) > 0)
    out = []
    for k in sample:
        cn = pobs.cn0_dbhz[:, k, :, f]
        ok = (np.isfinite(pobs.code_m[:, k, :, f]) & np.isfinite(pobs.phase_m[:, k, :, f])
              & ~(np.nan_to_num(cn, nan=np.inf) < mask) & ~((np.maximum(pobs.lli[:, k, :, f], 0) & 2).astype(bool))
              & geom.valid[k][None, :] & pobs.present[:, k][:, None])
        out.append([int((ok[a] & ok[b]).sum()) for a, b in ss.bl_idx])
    return out


def cmd_cubesat(args) -> None:
    """Single-frequency single-epoch success on CubeSat-like sets (10 cm baselines, L1 only, preset `cubesat`):
    every sampled epoch of every set counts (acquisition included unless --no-acquisition)."""
    from threadpoolctl import threadpool_limits

    from gnssatt.sim import simulate_scenario
    from gnssatt.sim.scenarios import make_params
    from gnssatt.ttff.data import load_study_set
    from gnssatt.ttff.study import StudyOptions, run_set

    threadpool_limits(1)
    duration = args.duration if args.duration else make_params("cubesat").duration_s
    res = []
    for i in range(args.count):
        tmp = Path(tempfile.mkdtemp(prefix="cubesat_"))
        try:
            ov = {"count": 1, "duration_s": duration, "truth_components": False,
                  "start_gps": f"2019-0{1 + i % 9}-1{i % 10}T0{i % 10}:00:00"}
            if args.no_acquisition:
                ov["acquisition_delays"] = False
            simulate_scenario("cubesat", tmp, seed=args.seed * 1000 + i, overrides=ov)
            ss = load_study_set(set_files(tmp), f"cubesat {i}", truth_dir=tmp / "truth")
            r = run_set(ss, StudyOptions(configurations=("L1",), methods=("epoch-lambda", "epoch-constrained"),
                                         max_duration_s=None, single_epoch_step_s=args.step))
            r["satellites_per_baseline"] = satellite_counts(ss, args.step)
            res.append(r)
            print(i, r["seconds"], flush=True)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    Path(args.out).write_text(json.dumps({"count": args.count, "seed": args.seed, "duration_s": duration,
                                          "step_s": args.step, "acquisition_delays": not args.no_acquisition,
                                          "results": res}))
    print(cubesat_lines(json.loads(Path(args.out).read_text())))


def cubesat_lines(cubesat: dict) -> str:
    """Markdown lines of a cubesat run: success per method and baseline, and the satellite-count distribution."""
    from collections import Counter

    from gnssatt.ttff.study import summarize

    cr = [row for r in cubesat["results"] for row in r["runs"]]
    cs = summarize(cr)["methods"]
    acq = cubesat.get("acquisition_delays", True)
    lines = [f"CubeSat-like (preset `cubesat`: 10 cm L-shaped baselines, L1 only, 45 dB-Hz zenith; "
             f"{cubesat['count']} sets of {cubesat.get('duration_s', 600):.0f} s, seed {cubesat['seed']}, "
             f"switch-on acquisition delays {'on (preset default)' if acq else 'off'}, every "
             f"{cubesat.get('step_s', 5):.0f} s sampled, every sampled epoch counted), single-epoch success:", ""]
    for m in ("epoch-lambda", "epoch-constrained"):
        d = cs.get(m, {}).get("L1", {})
        parts = [f"{bl}: {_pct(v['single_epoch_success'])} % of {v['single_epoch_epochs']}, wrong "
                 f"{v['single_epoch_wrong']}" for bl, v in d.items()]
        lines.append(f"- {m}: " + "; ".join(parts))
    counts = [n for r in cubesat["results"] for ep in r.get("satellites_per_baseline", []) for n in ep]
    if counts:
        c = Counter(min(n, 7) for n in counts)
        lines.append("- satellites per baseline and sampled epoch (L1 above 35 dB-Hz on both antennas): "
                     + ", ".join(f"{'>= 7' if k == 7 else k}: {v}" for k, v in sorted(c.items())))
    return "\n".join(lines)


def _proc_cpu_s(pid: int) -> float:
    """User + system CPU seconds of a process (/proc/<pid>/stat fields 14-15), all its threads."""
    f = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(f[11]) + int(f[12])) / os.sysconf("SC_CLK_TCK")


def cmd_job(args) -> None:
    """The `ttff` job over `count` simulated starts on a real service (API + N worker processes)."""
    from client.local_service import LocalService

    out = {}
    for n in args.workers:
        tmp = Path(tempfile.mkdtemp(prefix="ttff_job_"))
        svc = LocalService(tmp, "sqlite", None, None)
        try:
            svc.start_api()
            for _ in range(n):
                svc.start_worker()
            key = svc.create_key("bench")
            cl = svc.client(key)
            cfg = {"simulate": {"count": args.count, "seed": args.seed}, "duration_s": args.duration,
                   "single_epoch_step_s": args.step}
            load0 = list(os.getloadavg())
            cpu0 = [_proc_cpu_s(w.pid) for w in svc.workers]
            t0 = time.monotonic()
            r = cl.post("/v1/jobs", json={"type": "ttff", "observation_set_ids": [], "config": cfg})
            r.raise_for_status()
            job_id = r.json()["id"]
            while True:
                j = cl.get(f"/v1/jobs/{job_id}").json()
                if j["state"] in ("succeeded", "failed", "cancelled"):
                    break
                time.sleep(0.5)
            wall = time.monotonic() - t0
            worker_cpu = [round(_proc_cpu_s(w.pid) - c, 2) for w, c in zip(svc.workers, cpu0)]
            summ = cl.get(f"/v1/jobs/{job_id}/products/summary.json").json() if j["state"] == "succeeded" else None
            out[str(n)] = {"state": j["state"], "wall_s": round(wall, 1), "error": j.get("error"),
                           "task_seconds_total": summ and summ.get("task_seconds_total"),
                           "task_cpu_seconds_total": summ and summ.get("task_cpu_seconds_total"),
                           "tasks_per_worker": summ and summ.get("tasks_per_worker"),
                           "worker_cpu_s": worker_cpu,
                           "load_average_before": load0, "load_average_after": list(os.getloadavg())}
            print(n, "worker(s):", out[str(n)], flush=True)
        finally:
            svc.shutdown()
            shutil.rmtree(tmp, ignore_errors=True)
    Path(args.out).write_text(json.dumps({"count": args.count, "seed": args.seed, "duration_s": args.duration,
                                          "step_s": args.step, "workers": out}))


# ------------------------------------------------------------------------------------------------ report ---
def _pct(x) -> str:
    return "–" if x is None else f"{100 * x:.1f}"


def report(study: dict, cubesat: dict | None, job: dict | None, rtk: dict | None = None) -> str:
    from bench._report import machine_line
    from gnssatt.ttff.study import summarize

    runs = [row for r in study["results"] for row in r["runs"]]
    s = summarize(runs)["methods"]
    n = study["count"]
    rk, rtk_n = {}, "not run"
    if rtk:
        from bench.bench_ttff_rtklib import summarize_rtklib
        rk, rtk_n = summarize_rtklib(rtk), f"the first {rtk['count']}"
    lines = [f"{machine_line()}. {n} simulated starts (`ttff` preset as it is, seed {study['seed']}, "
             f"{study['duration_s']:.0f} s each), yaw ±180 / pitch ±70 / roll ±40 deg, slew back 0.1-0.5 deg/s. "
             f"Command: `python -m bench.bench_ttff study --count {n} --seed {study['seed']}` (then `report`).",
             "",
             "Instant fix [%] per baseline (0-2 = GPS-2>GPS-0, 1-2 = GPS-2>GPS-1); mean non-zero TTFF [s] in "
             "brackets; wrong first fixes (gnssatt: fixed integers against the simulator's truth integers; RTKLIB: "
             "fixed direction > 3 deg from the truth); single-epoch success (epoch methods, every 10 s; RTKLIB "
             "instantaneous mode, every epoch):", "",
             "| configuration | seed 000 Table 5 (20 real starts) | paper's method: EKF + MLAMBDA + length | "
             "epoch-wise MLAMBDA + length | epoch-wise MC-LAMBDA (constrained) | RTKLIB moving-base "
             f"({rtk_n} starts) |", "|---|---|---|---|---|---|"]
    for cfg in ("L1+L2", "L1", "L2"):
        t5 = SEED_000_TABLE5[cfg]
        cells = [f"{t5['instant'][0]} / {t5['instant'][1]} ({t5['mean'][0]} / {t5['mean'][1]})"]
        for m in ("filter", "epoch-lambda", "epoch-constrained"):
            d = s.get(m, {}).get(cfg)
            if not d:
                cells.append("–")
                continue
            a, b = (d[bl] for bl in BASELINES)
            txt = (f"{_pct(a['instant_fix_share'])} / {_pct(b['instant_fix_share'])} "
                   f"({a['mean_nonzero_ttff_s'] or '–'} / {b['mean_nonzero_ttff_s'] or '–'}); "
                   f"wrong {a['wrong_first_fixes'] + b['wrong_first_fixes']}")
            if m == "filter":
                txt += f", wrong fixed epochs {a['wrong_fixed_epochs'] + b['wrong_fixed_epochs']}"
                txt += (f" (epochs off > 3 deg with right integers or not: "
                        f"{a.get('off_3deg_fixed_epochs', 0) + b.get('off_3deg_fixed_epochs', 0)})")
                txt += f", never {a['never_fixed']} / {b['never_fixed']}"
            else:
                txt += (f"; single-epoch {_pct(a['single_epoch_success'])} / {_pct(b['single_epoch_success'])} %, "
                        f"wrong {a['single_epoch_wrong'] + b['single_epoch_wrong']} of "
                        f"{a['single_epoch_epochs'] + b['single_epoch_epochs']}")
            cells.append(txt)
        fh, ins = rk.get(cfg, {}).get("fix-and-hold"), rk.get(cfg, {}).get("instantaneous")
        if fh and ins:
            a, b = (fh[bl] for bl in BASELINES)
            ia, ib = (ins[bl] for bl in BASELINES)
            cells.append(f"{_pct(a['instant_fix_share'])} / {_pct(b['instant_fix_share'])} "
                         f"({a['mean_nonzero_ttff_s'] or '–'} / {b['mean_nonzero_ttff_s'] or '–'}); "
                         f"wrong {a['wrong_first_fixes'] + b['wrong_first_fixes']}, never {a['never_fixed']} / "
                         f"{b['never_fixed']} (fix-and-hold); instantaneous: single-epoch "
                         f"{_pct(ia['single_epoch_success'])} / {_pct(ib['single_epoch_success'])} %, wrong fixed "
                         f"epochs {ia['wrong_fixed_epochs'] + ib['wrong_fixed_epochs']}")
        else:
            cells.append("no L2-only setting" if cfg == "L2" else "–")
        lines.append(f"| {cfg} | " + " | ".join(cells) + " |")
    secs = [r.get("task_seconds", 0.0) for r in study["results"]]
    lines += ["", f"Per start (simulation + study of 3 configurations x 3 methods): median "
                  f"{sorted(secs)[len(secs) // 2]:.2f} s, {study['procs']} processes, wall {study['wall_s']:.0f} s."]
    if cubesat:
        lines += ["", cubesat_lines(cubesat)]
    if job:
        lines += ["", f"`ttff` job over {job['count']} simulated starts ({job['duration_s']:.0f} s each, single-epoch "
                      f"step {job['step_s']:.0f} s, all 3 configurations and 3 methods), submitted through the API "
                      f"(`python -m bench.bench_ttff job --count {job['count']} --workers 1 2`):", ""]
        for n_w, v in job["workers"].items():
            la = v.get("load_average_before")
            lines.append(f"- {n_w} worker(s): {v['state']}, {v['wall_s']} s wall (sum of task times "
                         f"{v['task_seconds_total']} s wall, {v.get('task_cpu_seconds_total')} s CPU; load average "
                         f"before {la and ' / '.join(f'{x:.1f}' for x in la)}; tasks per worker "
                         f"{v.get('tasks_per_worker')}; CPU of the worker processes during the job "
                         f"{v.get('worker_cpu_s')} s)")
    return "\n".join(lines) + "\n"


def cmd_report(args) -> None:
    study = json.loads(Path(args.study).read_text())
    cub = json.loads(Path(args.cubesat).read_text()) if Path(args.cubesat).exists() else None
    job = json.loads(Path(args.job).read_text()) if Path(args.job).exists() else None
    rtk = None
    if args.rtk:
        from bench.bench_ttff_rtklib import merge_parts
        rtk = merge_parts([Path(p) for p in args.rtk])
    text = report(study, cub, job, rtk)
    print(text)
    if args.write:
        from bench._report import replace_section
        replace_section(REPO / "docs" / "BENCHMARKS.md", "Time to first fix", text)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("study")
    p.add_argument("--count", type=int, default=200)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--duration", type=float, default=120.0)
    p.add_argument("--procs", type=int, default=max(1, min(2, os.cpu_count() or 1)))
    p.add_argument("--out", default="/tmp/bench_ttff_study.json")
    p.add_argument("--methods", nargs="+", default=None,
                   help="ttff methods (default the job's; add filter-constrained for the attitude job option)")
    p = sub.add_parser("cubesat")
    p.add_argument("--count", type=int, default=4)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--duration", type=float, default=None,
                   help="seconds per set (default: the preset's own duration_s, 3000 s)")
    p.add_argument("--no-acquisition", action="store_true",
                   help="receivers start already tracking (preset default: switch-on acquisition delays)")
    p.add_argument("--step", type=float, default=5.0)
    p.add_argument("--out", default="/tmp/bench_ttff_cubesat.json")
    p = sub.add_parser("job")
    p.add_argument("--count", type=int, default=200)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--duration", type=float, default=60.0)
    p.add_argument("--step", type=float, default=30.0)
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    p.add_argument("--out", default="/tmp/bench_ttff_job.json")
    p = sub.add_parser("report")
    p.add_argument("--study", default="/tmp/bench_ttff_study.json")
    p.add_argument("--cubesat", default="/tmp/bench_ttff_cubesat.json")
    p.add_argument("--job", default="/tmp/bench_ttff_job.json")
    p.add_argument("--rtk", nargs="*", default=[], help="bench_ttff_rtklib result file(s) of the same starts")
    p.add_argument("--write", action="store_true")
    args = ap.parse_args(argv)
    {"study": cmd_study, "cubesat": cmd_cubesat, "job": cmd_job, "report": cmd_report}[args.cmd](args)


if __name__ == "__main__":
    main()
