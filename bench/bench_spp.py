"""SPP throughput and accuracy on the whole GRACE-A day (8640 epochs, 10 s), broadcast and CODE precise products.

Reference: the JPL reduced-dynamic GRACE-A orbit (centre of mass; the decimetre CoM-antenna offset is not
modelled), interpolated at each solution's reception time. Reported: epochs/s (median of N runs after one warm-up,
reading excluded), RMS / median / 95th percentile of the 3-D error over epochs with a fix, and the velocity error
(phase-rate velocities: the file has no Doppler). Also the epoch-alignment timing on a simulated 3-receiver pass.

Usage: .venv/bin/python -m bench.bench_spp [--runs 3] [--write]   (--write updates docs/BENCHMARKS.md "Positioning")
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench._report import machine_line, replace_section  # noqa: E402

GRACE = ROOT.parent / "shared" / "data" / "real" / "leo_grace_a_2007080"


def _load():
    from worker.gnss.io.rinex_clock import read_rinex_clock
    from worker.gnss.io.rinex_nav import read_rinex_nav
    from worker.gnss.io.rinex_obs import read_rinex_obs
    from worker.gnss.io.sp3 import read_sp3

    return dict(nav=read_rinex_nav(GRACE / "brdc0800.07n.gz"), sp3=read_sp3(GRACE / "cod14193.sp3.gz"),
                clk=read_rinex_clock(GRACE / "cod14193.clk.gz"), ref=read_sp3(GRACE / "GRAA_07_080.sp3.gz"),
                obs=read_rinex_obs(GRACE / "graa0800.07o.gz"))


def _errors(sol, ref):
    from worker.gnss.orbits.sp3_interp import interpolate_sp3, interpolate_sp3_velocity

    pos, _ = interpolate_sp3(ref, ["L09"], sol.time)
    vel = interpolate_sp3_velocity(ref, ["L09"], sol.time)
    e3 = np.linalg.norm(sol.position_ecef_m - pos[:, 0], axis=1)
    ev = np.linalg.norm(sol.velocity_ecef_m_s - vel[:, 0], axis=1)
    return e3, ev


def run_spp(data, runs: int) -> list[dict]:
    from worker.gnss.ephemeris import BroadcastEphemeris, PreciseEphemeris
    from worker.gnss.positioning import spp

    rows = []
    cases = [("broadcast", BroadcastEphemeris(data["nav"]), None),
             ("broadcast", BroadcastEphemeris(data["nav"]), 600.0),
             ("CODE SP3/CLK", PreciseEphemeris(data["sp3"], data["clk"]), None),
             ("CODE SP3/CLK", PreciseEphemeris(data["sp3"], data["clk"]), 600.0)]
    for name, eph, smooth in cases:
        spp(data["obs"], eph, smoothing_window_s=smooth, epochs=slice(0, 50))  # warm-up
        times, sol = [], None
        for _ in range(runs):
            t0 = time.perf_counter()
            sol = spp(data["obs"], eph, smoothing_window_s=smooth)
            times.append(time.perf_counter() - t0)
        e3, ev = _errors(sol, data["ref"])
        ok = np.isfinite(e3)
        n = len(sol.clock_s)
        rows.append(dict(
            products=name, smoothing="Hatch 600 s" if smooth else "none", n=n, n_fix=int(ok.sum()),
            seconds=statistics.median(times), eps=n / statistics.median(times),
            rms=float(np.sqrt(np.mean(e3[ok] ** 2))), median=float(np.median(e3[ok])),
            p95=float(np.percentile(e3[ok], 95)), max=float(e3[ok].max()),
            vel_rms=float(np.sqrt(np.nanmean(ev ** 2))), excluded=int(sol.excluded.sum())))
        print(rows[-1], flush=True)
    return rows


def run_alignment(runs: int) -> dict:
    from worker.gnss.alignment import align_to_gps_epochs
    from worker.gnss.ephemeris import BroadcastEphemeris
    from worker.gnss.io.rinex_nav import read_rinex_nav
    from worker.gnss.io.rinex_obs import read_rinex_obs
    from worker.gnss.positioning import spp
    from worker.sim import simulate_scenario

    with tempfile.TemporaryDirectory() as d:
        res = simulate_scenario("hard", Path(d), seed=0, overrides={"duration_s": 1800.0, "truth_components": False})
        files = res.sets[0]["files"]
        eph = BroadcastEphemeris(read_rinex_nav(files["nav"]))
        obs = [read_rinex_obs(p) for p in files["obs"].values()]
        t_spp, t_al = [], []
        for _ in range(runs):
            t0 = time.perf_counter()
            sols = [spp(o, eph) for o in obs]
            t1 = time.perf_counter()
            al = align_to_gps_epochs(obs, sols, eph)
            t_al.append(time.perf_counter() - t1)
            t_spp.append(t1 - t0)
        n_ep = sum(len(o.time) for o in obs)
        return dict(n_rx=len(obs), n_epochs=n_ep, spp_s=statistics.median(t_spp), align_s=statistics.median(t_al),
                    events=len(al.events), expected=sum(a["clock_jumps"]
                                                        for a in res.sets[0]["summary"]["antennas"].values()))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--write", action="store_true", help="update the Positioning section of docs/BENCHMARKS.md")
    args = ap.parse_args(argv)
    if not GRACE.is_dir():
        print(f"GRACE-A data not found at {GRACE}", file=sys.stderr)
        return 2
    warnings.simplefilter("ignore", RuntimeWarning)
    data = _load()
    rows = run_spp(data, args.runs)
    al = run_alignment(args.runs)
    print(al)
    lines = [f"Machine: {machine_line()}. `python -m bench.bench_spp --runs {args.runs}`, median of "
             f"{args.runs} runs after a warm-up, file reading excluded.", "",
             "SPP of GRACE-A, 2007-03-21, the whole day (8640 epochs at 10 s, RINEX 2.10 P1/P2/C1, GPS only), "
             "against the JPL reduced-dynamic orbit (centre of mass; CoM-antenna offset ~0.1-0.5 m not modelled). "
             "Ionosphere-free P1/P2, chi-square RAIM (false alarm 1e-3, up to 3 exclusions), no elevation mask "
             "(spaceborne), velocity from the carrier-phase rate (no Doppler in the file). The CODE orbit ends at "
             "23:45, so the precise runs have 90 fewer fixes.", "",
             "| products | code smoothing | epochs/s | fixes | 3-D RMS m | median m | 95 % m | max m | "
             "velocity RMS m/s | RAIM exclusions |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['products']} | {r['smoothing']} | {r['eps']:.0f} | {r['n_fix']}/{r['n']} | "
                     f"{r['rms']:.2f} | {r['median']:.2f} | {r['p95']:.1f} | {r['max']:.1f} | {r['vel_rms']:.2f} | "
                     f"{r['excluded']} |")
    lines += ["",
              "Issue 4 asks for < 5 m RMS with broadcast (met) and < 2 m with CODE SP3/CLK (not met by code-only "
              "SPP: the median is below 2 m but the RMS is held up by (1) the satellite antenna offsets, which a "
              "CoM orbit needs from an ANTEX file the set does not have - per-block mean residuals of about "
              "+-0.9 m measured - and (2) a few dozen epochs of weak geometry with 20-55 m errors that RAIM cannot "
              "see; see docs/design/positioning.md).", "",
              f"Epoch alignment: simulated 'hard' pass (seed 0), {al['n_rx']} receivers, {al['n_epochs']} receiver "
              f"epochs at 1 Hz: SPP {al['spp_s']:.2f} s for all receivers, alignment {al['align_s']:.2f} s; "
              f"{al['events']} clock jumps found, {al['expected']} in the simulator's truth."]
    body = "\n".join(lines)
    print(body)
    if args.write:
        replace_section(ROOT / "docs" / "BENCHMARKS.md", "Positioning", body)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
