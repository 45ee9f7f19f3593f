"""Gyro fault detection delay per delayed propagator (seed 002 Table 2) over several seeds and both orbits, with
the GPS FDI figures and the gyro false events of the same runs; sets are simulated once into --sets and reused.

    PYTHONPATH=. python bench/bench_gyro_delays.py --sets DIR [--orbits equatorial polar] [--seeds 2 3 4]
        [--clean] [--step] [--simulate-only] [--settings JSON] [--out RESULTS.jsonl]
    PYTHONPATH=. python bench/bench_gyro_delays.py --table RESULTS.jsonl      # the docs/BENCHMARKS.md tables

The scenario is bench/bench_gyro_fusion.py's (one orbit + 600 s, GPS faults every 60 s, a 30 s outage at 1800 s,
a 10x y-axis drift fault after the orbit: a ramp over 300 s, or a step with --step). Prints one JSON line per run.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np


def scenario(orbit: str, clean: bool, step: bool):
    from gnssatt.sim.gyro import DriftFault, GyroErrorModel
    from gnssatt.sim.gyro_scenario import ORBIT_PERIOD_650KM_S, GyroScenario

    dur = ORBIT_PERIOD_650KM_S + 600.0
    faults = () if clean else (DriftFault(axis=1, start_s=ORBIT_PERIOD_650KM_S, size_rad_s=10 * 48.48e-6,
                                          ramp_s=0.0 if step else 300.0),)
    return GyroScenario(orbit=orbit, duration_s=dur, gps_fault_interval_s=0.0 if clean else 60.0,
                        outages=() if clean else ((1800.0, 30.0),), gyro=GyroErrorModel(faults=faults))


def cached_set(root: Path, orbit: str, seed: int, clean: bool, step: bool):
    """The simulated set (files list, set dir), simulated on first use."""
    from gnssatt.gnss.io.sniff import identify
    from gnssatt.sim.gyro_scenario import simulate_gyro_set

    kind = "clean" if clean else ("step" if step else "ramp")
    d = root / f"{orbit}_{seed}_{kind}"
    done = d / "set" / "DONE"
    if not done.exists():
        gs = simulate_gyro_set(scenario(orbit, clean, step), d / "set", seed=seed)
        done.write_text(json.dumps([str(p) for p in gs.files]))
    files = [Path(p) for p in json.loads(done.read_text())]
    return files, d / "set"


def residual_rms(run, gps, fault_start_s: float) -> dict:
    """rms and max of the propagators' normalised residuals per propagator and axis, before the gyro fault."""
    rows = np.array(run.gyro_tests)
    if not len(rows):
        return {}
    t_e = np.asarray(gps.time - gps.time[0], float)
    keep = t_e[rows[:, 0].astype(int)] < fault_start_s
    out = {}
    for j in np.unique(rows[:, 1]).astype(int):
        z = rows[keep & (rows[:, 1] == j), 2:5]
        out[str(j)] = {"rms": np.round(np.sqrt((z ** 2).mean(0)), 3).tolist(),
                       "max": round(float(np.abs(z).max()), 2), "n": int(len(z))}
    return out


def fault_axis_numbers(run, gps, fault_start_s: float, axis: int = 1) -> dict:
    """Per propagator on the faulty axis: median theoretical sigma before the fault (mrad) and the largest
    |residual| (mrad) within 125, 250 and 400 s after the fault's start (from gyro_tests x gyro_test_sigmas)."""
    z, sg = np.array(run.gyro_tests), np.array(run.gyro_test_sigmas)
    if not len(z) or not len(sg) or not np.isfinite(fault_start_s):
        return {}
    t = np.asarray(gps.time - gps.time[0], float)[z[:, 0].astype(int)] - fault_start_s
    r_mrad = 1e3 * z[:, 2 + axis] * sg[:, 2 + axis]
    out = {}
    for j in np.unique(z[:, 1]).astype(int):
        m = z[:, 1] == j
        out[str(j)] = {"sigma_mrad_before": round(float(np.median(1e3 * sg[m & (t < 0), 2 + axis])), 2),
                       **{f"max_r_mrad_{w}s": round(float(r_mrad[m & (t >= 0) & (t <= w)].max()), 1)
                          for w in (125, 250, 400) if (m & (t >= 0) & (t <= w)).any()}}
    return out


def one_run(files, set_dir: Path, settings: dict, clean: bool) -> dict:
    from gnssatt.gyro.api import fuse
    from gnssatt.gyro.truth import fdi_scores, gyro_delays, integer_failures
    from gnssatt.sim.gyro_scenario import ORBIT_PERIOD_650KM_S

    t, c = time.perf_counter(), time.process_time()
    res = fuse(files, settings)
    wall, cpu = time.perf_counter() - t, time.process_time() - c
    fault_start = float("inf") if clean else ORBIT_PERIOD_650KM_S
    g = gyro_delays(set_dir, res.run, res.gps)
    f = fdi_scores(set_dir, res.run, res.gps)
    return {"fuse_s": round(wall, 1), "fuse_cpu_s": round(cpu, 1), "gyro_false_events": g["false_events"],
            "gyro_delay_s": g["faults"][0]["delay_s_by_propagator"] if g["faults"] else None,
            "gyro_axis": g["faults"][0]["axis_isolated"] if g["faults"] else None,
            "residual": residual_rms(res.run, res.gps, fault_start),
            "fault_axis": fault_axis_numbers(res.run, res.gps, fault_start),
            "gps": {k: f[k] for k in ("faults_on_used_satellites", "missed", "detected", "isolated_right",
                                      "false_alarms", "clean_epochs", "false_share_of_detections")},
            "wrong_integers": integer_failures(set_dir, res.run, res.gps)["epochs_with_wrong_integer"]}


F_RAD_S = 10 * 48.48e-6      # the fault's full size
RAMP_S = 300.0


def integrated_fault_rad(tau_s: float, step: bool) -> float:
    """Integral of the fault over its first tau_s seconds (a step of F, or a ramp to F over RAMP_S)."""
    if step:
        return F_RAD_S * tau_s
    if tau_s <= RAMP_S:
        return F_RAD_S * tau_s ** 2 / (2 * RAMP_S)
    return F_RAD_S * (RAMP_S / 2 + tau_s - RAMP_S)


def earliest_delay_s(threshold_rad: float, step: bool) -> float:
    """The first tau at which the integrated fault reaches threshold_rad (no noise, nothing absorbed)."""
    taus = np.arange(0.0, 2000.0, 1.0)
    vals = np.array([integrated_fault_rad(t, step) for t in taus])
    return float(taus[np.argmax(vals >= threshold_rad)])


def _fmt(d: dict | None, j: int) -> str:
    return f"{d[str(j)]:.0f}" if d and str(j) in d else "-"


def table(path: str, kappa: float = 5.0, delay_step_s: float = 60.0) -> None:
    """Markdown tables of a results file (docs/BENCHMARKS.md "Gyro fault detection delay per propagator")."""
    docs = [json.loads(ln) for ln in open(path) if ln.strip()]
    faults = [d for d in docs if d["kind"] != "clean"]
    _delay_table(faults)
    print()
    _why_table(faults, kappa, delay_step_s)
    print()
    _clean_table([d for d in docs if d["kind"] == "clean"])


def _delay_table(faults: list) -> None:
    print("| fault | orbit | seed | delay s, propagator 1 / 2 / 3 / 4 / 5 | "
          "first detection, bank of 1 / 2 / 3 / 4 / 5 | axis | gyro false events | GPS missed | isolated right | GPS false alarms / fault-free epochs |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for d in faults:
        g, dl = d["gps"], d["gyro_delay_s"] or {}
        bank = []
        for n in range(1, 6):
            v = [dl[str(j)] for j in range(1, n + 1) if str(j) in dl]
            bank.append(f"{min(v):.0f}" if v else "-")
        print(f"| {d['kind']} | {d['orbit']} | {d['seed']} | {' / '.join(_fmt(dl, j) for j in range(1, 6))} | "
              f"{' / '.join(bank)} | {''.join(d['gyro_axis'] or [])} | {d['gyro_false_events']} | "
              f"{g['missed']}/{g['faults_on_used_satellites']} | {g['isolated_right']}/{g['detected']} | "
              f"{g['false_alarms']}/{g['clean_epochs']} |")


def _why_table(faults: list, kappa: float, delay_step_s: float) -> None:
    print("| propagator (delay) | sigma_y before the fault, mrad (median over runs) | 5 sigma, mrad | fault over one "
          "delay F D_j, mrad | earliest delay ramp / step, s | measured ramp: median (runs detected) | "
          "measured step: median (runs detected) |")
    print("|---|---|---|---|---|---|---|")
    for j in range(1, 6):
        sig = np.median([d["fault_axis"][str(j)]["sigma_mrad_before"] for d in faults])
        thr = kappa * sig * 1e-3
        meas = []
        for kind in ("ramp", "step"):
            runs = [d for d in faults if d["kind"] == kind]
            v = [d["gyro_delay_s"][str(j)] for d in runs if str(j) in (d["gyro_delay_s"] or {})]
            meas.append(f"{np.median(v):.0f} ({len(v)} of {len(runs)})" if v else f"- (0 of {len(runs)})")
        window_mrad = 1e3 * F_RAD_S * j * delay_step_s
        print(f"| {j} ({j * delay_step_s:.0f} s) | {sig:.1f} | {1e3 * thr:.0f} | {window_mrad:.0f} | "
              f"{earliest_delay_s(thr, False):.0f} / {earliest_delay_s(thr, True):.0f} | {meas[0]} | {meas[1]} |")


def _clean_table(clean: list) -> None:
    print("| clean run | gyro false events | residual / sigma rms per propagator (x, y, z: min-max) | max |")
    print("|---|---|---|---|")
    for d in clean:
        rms = np.array([v["rms"] for v in d["residual"].values()])
        mx = max(v["max"] for v in d["residual"].values())
        print(f"| {d['orbit']} seed {d['seed']} | {d['gyro_false_events']} | {rms.min():.2f}-{rms.max():.2f} | "
              f"{mx:.1f} |")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sets", default=None)
    ap.add_argument("--table", default=None, help="print the markdown tables of this results file and stop")
    ap.add_argument("--orbits", nargs="+", default=["equatorial", "polar"])
    ap.add_argument("--seeds", nargs="+", type=int, default=[2, 3, 4])
    ap.add_argument("--clean", action="store_true")
    ap.add_argument("--step", action="store_true")
    ap.add_argument("--simulate-only", action="store_true")
    ap.add_argument("--settings", default="{}", help="fusion settings as JSON (FusionSettings.from_dict)")
    ap.add_argument("--out", default=None, help="append the JSON lines to this file too")
    a = ap.parse_args()
    if a.table:
        table(a.table)
        return
    root = Path(a.sets)
    for orbit in a.orbits:
        for seed in a.seeds:
            files, set_dir = cached_set(root, orbit, seed, a.clean, a.step)
            if a.simulate_only:
                continue
            doc = {"orbit": orbit, "seed": seed, "kind": "clean" if a.clean else ("step" if a.step else "ramp"),
                   "settings": json.loads(a.settings), **one_run(files, set_dir, json.loads(a.settings), a.clean)}
            line = json.dumps(doc, default=float)
            print(line, flush=True)
            if a.out:
                with open(a.out, "a") as fh:
                    fh.write(line + "\n")


if __name__ == "__main__":
    main()
