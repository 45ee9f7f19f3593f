"""SPP throughput and accuracy on the whole GRACE-A day (8640 epochs, 10 s), broadcast and CODE precise products.

Reference: the JPL reduced-dynamic GRACE-A orbit (centre of mass; the GPS antenna's offset from it, about half a
metre up, is not modelled and shows as the mean radial error), interpolated at each solution's reception time.
Reported: epochs/s (median of N runs after one warm-up, reading excluded), RMS / median / 95th percentile / max of
the 3-D error over all epochs with a fix and the RMS over the clean ones (no RAIM failure, no untested fix, PDOP
below the limit), the mean radial error, and the velocity error (phase-rate velocities: the file has no Doppler).
Two ablations (one run each) show what the satellite antenna offsets and the weighting/calibration/arc screening
buy. Also the epoch-alignment timing on a simulated 3-receiver pass.

Usage: .venv/bin/python -m bench.bench_spp [--runs 3] [--write]   (--write updates docs/BENCHMARKS.md "Positioning")
"""
from __future__ import annotations

import argparse
import os
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
    from gnssatt.gnss.io.rinex_clock import read_rinex_clock
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs
    from gnssatt.gnss.io.sp3 import read_sp3

    return dict(nav=read_rinex_nav(GRACE / "brdc0800.07n.gz"), sp3=read_sp3(GRACE / "cod14193.sp3.gz"),
                clk=read_rinex_clock(GRACE / "cod14193.clk.gz"), ref=read_sp3(GRACE / "GRAA_07_080.sp3.gz"),
                obs=read_rinex_obs(GRACE / "graa0800.07o.gz"))


def _errors(sol, ref):
    """(3-D error (n,), radial error (n,), velocity error (n,)) against the reference orbit."""
    from gnssatt.gnss.orbits.sp3_interp import interpolate_sp3, interpolate_sp3_velocity

    pos, _ = interpolate_sp3(ref, ["L09"], sol.time)
    vel = interpolate_sp3_velocity(ref, ["L09"], sol.time)
    d = sol.position_ecef_m - pos[:, 0]
    up = pos[:, 0] / np.linalg.norm(pos[:, 0], axis=1, keepdims=True)
    e3 = np.linalg.norm(d, axis=1)
    ev = np.linalg.norm(sol.velocity_ecef_m_s - vel[:, 0], axis=1)
    return e3, np.einsum("ki,ki->k", d, up), ev


def _row(name, smoothing, sol, data, seconds):
    from gnssatt.gnss.positioning import FLAG_HIGH_PDOP, FLAG_RAIM_FAILED, FLAG_RAIM_UNTESTED

    e3, rad, ev = _errors(sol, data["ref"])
    ok = np.isfinite(e3)
    clean = ok & ((sol.flags & (FLAG_RAIM_FAILED | FLAG_RAIM_UNTESTED | FLAG_HIGH_PDOP)) == 0)
    n = len(sol.clock_s)
    return dict(
        products=name, smoothing=smoothing, n=n, n_fix=int(ok.sum()), n_clean=int(clean.sum()),
        seconds=seconds, eps=n / seconds if seconds else float("nan"),
        rms=float(np.sqrt(np.mean(e3[ok] ** 2))), rms_clean=float(np.sqrt(np.mean(e3[clean] ** 2))),
        median=float(np.median(e3[ok])), p95=float(np.percentile(e3[ok], 95)), max=float(e3[ok].max()),
        radial_mean=float(np.mean(rad[ok])), vel_rms=float(np.sqrt(np.nanmean(ev ** 2))),
        excluded=int(sol.excluded.sum()),
        arc_excluded=int(sol.arc_excluded.sum()) if sol.arc_excluded is not None else 0,
        weighting=sol.weighting, variance_factor=sol.variance_factor)


def run_spp(data, runs: int) -> list[dict]:
    from gnssatt.gnss.ephemeris import BroadcastEphemeris, PreciseEphemeris
    from gnssatt.gnss.positioning import SppOptions, spp

    rows = []
    cases = [("broadcast", BroadcastEphemeris(data["nav"]), None),
             ("broadcast", BroadcastEphemeris(data["nav"]), 600.0),
             ("CODE SP3/CLK", PreciseEphemeris(data["sp3"], data["clk"]), None),
             ("CODE SP3/CLK", PreciseEphemeris(data["sp3"], data["clk"]), 600.0)]
    for name, eph, smooth in cases:
        spp(data["obs"], eph, SppOptions(smoothing_window_s=smooth), epochs=slice(0, 50))  # warm-up
        times, sol = [], None
        for _ in range(runs):
            t0 = time.perf_counter()
            sol = spp(data["obs"], eph, SppOptions(smoothing_window_s=smooth))
            times.append(time.perf_counter() - t0)
        rows.append(_row(name, "Hatch 600 s" if smooth else "none", sol, data, statistics.median(times)))
        print(rows[-1], flush=True)
    return rows


def run_ablations(data) -> list[dict]:
    """CODE, code only: without the satellite antenna offsets, and with the previous model (elevation weights,
    no variance calibration, no arc screening), one run each."""
    from gnssatt.gnss.ephemeris import PreciseEphemeris
    from gnssatt.gnss.positioning import SppOptions, spp

    rows = []
    for label, eph, kw in (
            ("CODE, CoM orbit (no satellite antenna offsets)",
             PreciseEphemeris(data["sp3"], data["clk"], antenna_offsets=None), {}),
            ("CODE, previous model (elevation weights, no calibration, no arc screening)",
             PreciseEphemeris(data["sp3"], data["clk"]),
             dict(weighting="elevation", calibrate_variance=False, arc_screening=False, smooth_variance=False))):
        t0 = time.perf_counter()
        sol = spp(data["obs"], eph, SppOptions(**kw))
        rows.append(_row(label, "none", sol, data, time.perf_counter() - t0))
        print(rows[-1], flush=True)
    return rows


def run_alignment(runs: int) -> dict:
    from gnssatt.gnss.alignment import align_to_gps_epochs
    from gnssatt.gnss.ephemeris import BroadcastEphemeris
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs
    from gnssatt.gnss.positioning import spp
    from gnssatt.sim import simulate_scenario

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
    abl = run_ablations(data)
    al = run_alignment(args.runs)
    print(al)
    load1, _, _ = os.getloadavg()
    old = next(r for r in abl if r["products"].startswith("CODE, previous"))
    lines = [f"Machine: {machine_line()}, load average {load1:.1f} at the end of the run (other jobs share the "
             f"cores: compare epochs/s within this table only). `python -m bench.bench_spp --runs {args.runs}`, "
             f"median of {args.runs} runs after a warm-up, file reading excluded. The default model costs "
             f"{old['eps'] / rows[2]['eps']:.1f}x the time of the previous one (CODE, code only: up to three "
             "batch solves -- calibration, arc screening -- instead of one).", "",
             "SPP of GRACE-A, 2007-03-21, the whole day (8640 epochs at 10 s, RINEX 2.10 P1/P2/C1, GPS only), "
             "against the JPL reduced-dynamic orbit of the centre of mass (the GPS antenna's offset from it, "
             "about 0.5 m up, is not modelled: it is the mean radial error). Default `spp`: ionosphere-free "
             "P1/P2, C/N0 weights from the RINEX signal-strength digits, batch variance calibration, chi-square "
             "RAIM (false alarm 1e-3, up to 3 exclusions) and arc screening, no elevation mask (spaceborne), "
             "velocity from the carrier-phase rate (no Doppler in the file). CODE: satellite antenna offsets "
             "from the built-in igs05.atx table (the product is IGS05). The CODE orbit ends at 23:45, so the "
             "precise runs have 90 fewer fixes. 'Clean' fixes: no RAIM failure, no untested fix, PDOP <= 20 "
             "(the flagged ones are kept in the product and in the 'all fixes' figures).", "",
             "| products | code smoothing | epochs/s | fixes | 3-D RMS m (all fixes) | clean fixes | 3-D RMS m "
             "(clean) | median m | 95 % m | max m | mean radial m | velocity RMS m/s | RAIM exclusions (arc "
             "screening) | variance factor |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows + abl:
        lines.append(f"| {r['products']} | {r['smoothing']} | {r['eps']:.0f} | {r['n_fix']}/{r['n']} | "
                     f"{r['rms']:.2f} | {r['n_clean']} ({100 * r['n_clean'] / r['n_fix']:.2f} %) | "
                     f"{r['rms_clean']:.2f} | {r['median']:.2f} | {r['p95']:.2f} | {r['max']:.1f} | "
                     f"{r['radial_mean']:+.2f} | {r['vel_rms']:.2f} | {r['excluded']} ({r['arc_excluded']}) | "
                     f"{r['variance_factor']:.3f} |")
    code = [r for r in rows if r["products"].startswith("CODE")]
    brdc = [r for r in rows if r["products"] == "broadcast"]
    lines += ["",
              f"Issue 4 asks for < 5 m RMS with broadcast orbits (met: {brdc[0]['rms']:.2f} m code only, "
              f"{brdc[1]['rms']:.2f} m smoothed) and < 2 m with the CODE SP3/CLK (met: {code[0]['rms']:.2f} m "
              f"code only, {code[1]['rms']:.2f} m smoothed, over all fixes). The last two rows are ablations "
              "(one run, code only): the CoM orbit leaves each satellite's range long by its antenna z offset "
              "(0.6-2.7 m by block), and the previous flat model (elevation weights, a-priori sigma, no arc "
              "screening) lets whole passes of 15-80 m biased code into the 5-6-satellite epochs. See "
              "docs/design/positioning.md.", "",
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
