"""Attitude job benchmark (issue 6): the 106-minute CASSIOPE-like pass of seed 000 sec. 4.1 (simulator preset
`earth-pointing`, seed 0, three antennas, L1 C/A + L2 P(Y)), processed in kinematic and dynamic mode.

Reports, in one run on the same files:
- filter speed (epochs/s, one BLAS thread) and the whole job "upload to products" wall time (parse the files,
  geometry, filter, attitude, every product text) for each mode;
- accuracy against truth/attitude.csv next to seed 000 Table 4 (DOPs, expected sigmas by eq. 3-4, measured):
  bias and standard deviation of the yaw/pitch/roll errors over fixed epochs, the product's own predicted sigma,
  fix rate, wrong fixes (error > 1 deg while fixed);
- the same for the "realistic" pass (preset as it is: C/N0-dependent noise, multipath, 10 mm PCV, PCO scatter).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_attitude.py [--minutes 106] [--write]

The clean pass of the Done-when is the preset with {"pcv": false, "pco": false, "multipath": false,
"noise_grows_with_cn0": false}: white noise of 3 mm (phase) and 0.3 m (code) per receiver.

Also the `hard` preset (30 min: free-running clocks with 1 ms jumps, slips with and without LLI, gaps, outages,
strong multipath, 25 mm PCV) as it is, the same events without multipath/PCV/PCO/C/N0 noise ("hard events"),
and a clean 30-minute pass with the same 1 deg wobble as its reference. Every integer the filter fixed is
checked against truth/arcs.csv (gnssatt/attitude/truth.py): "wrong integers" counts constraints that differ from
the truth at any epoch they were held; "> 1 deg fixed" is the issue's wrong-fix count (error > 1 deg while fixed).
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

from bench._report import machine_line, replace_section  # noqa: E402

SEED = 0
CLEAN = {"pcv": False, "pco": False, "multipath": False, "noise_grows_with_cn0": False}
TABLE4 = {"GPS-2>GPS-0": {"hdop": 1.27, "vdop": 1.94, "exp_yaw": 0.20, "exp_tilt": 0.30, "meas_yaw": 0.08,
                          "meas_tilt": 0.32},
          "GPS-2>GPS-1": {"hdop": 1.07, "vdop": 2.15, "exp_yaw": 0.16, "exp_tilt": 0.33, "meas_yaw": 0.08,
                          "meas_tilt": 0.26}}


def files_of(d: Path):
    files = [(f"obs/{p.name}", "rinex_obs", p) for p in sorted((d / "obs").glob("*.rnx"))]
    return files + [("nav/brdc.rnx", "rinex_nav", d / "nav/brdc.rnx"), ("platform.json", "platform",
                                                                      d / "platform.json"),
                    ("platform.sp3", "sp3", d / "platform.sp3"),
                    ("reference_attitude.csv", "reference_attitude", d / "reference_attitude.csv")]


#: extra rows of the main table: label -> (passes it runs on, settings on top of the mode's); "table2" = the job's
#: default data selection (seed 000 Table 2's C/N0 and antenna-frame masks) instead of "all phases"
EXTRA_ROWS = {"kinematic, Table 2 masks (default)": (("clean", "realistic"), {"mode": "kinematic", "table2": True}),
              "dynamic, Table 2 masks (default)": (("clean", "realistic"), {"mode": "dynamic", "table2": True}),
              "dynamic + smoother_adaptive_noise": (("clean", "realistic", "hard"),
                                                    {"mode": "dynamic", "smoother": True,
                                                     "smoother_adaptive_noise": True}),
              "dynamic + smoother_adaptive_noise, Table 2 masks": (("clean", "realistic"),
                                                                   {"mode": "dynamic", "smoother": True,
                                                                    "smoother_adaptive_noise": True,
                                                                    "table2": True})}


def warm_up_kernels() -> None:
    """Load (or compile, the first time from this checkout) the filter's numba kernels before anything is timed, as
    the worker does at start (worker.main._warm_up_kernels)."""
    from gnssatt.attitude.kernels import warm_up as warm_up_attitude
    from gnssatt.attitude.qc_kernels import warm_up as warm_up_qc
    from gnssatt.attitude.update_kernels import warm_up as warm_up_update
    from gnssatt.estimation.ekf_kernels import warm_up as warm_up_ekf

    for f in (warm_up_ekf, warm_up_attitude, warm_up_qc, warm_up_update):
        f()


def run_mode(d: Path, mode: str, extra: dict | None = None) -> dict:
    """One run of the attitude processing on the set d: mode "kinematic"/"dynamic" on "all phases", or the settings
    of an EXTRA_ROWS entry (extra)."""
    import gnssatt.attitude.process as P
    from gnssatt.attitude.process import load_inputs, process
    from gnssatt.attitude.products import all_products
    from gnssatt.attitude.settings import ALL_PHASES, TABLE2_MASKS, AttitudeSettings
    from gnssatt.attitude.truth import attitude_errors_deg, score_fixes

    cfg = dict(extra or {"mode": mode})
    selection = TABLE2_MASKS if cfg.pop("table2", False) else ALL_PHASES   # the benches' default: "all phases"

    tf = [0.0]
    orig = P.run_filter

    def timed(*a, **k):
        t = time.perf_counter()
        r = orig(*a, **k)
        tf[0] = time.perf_counter() - t
        return r

    P.run_filter = timed
    try:
        t0 = time.perf_counter()
        sol = process(load_inputs(files_of(d)), AttitudeSettings.preset("seed000", **{**selection, **cfg}))
        prods = all_products(sol)
        wall = time.perf_counter() - t0
    finally:
        P.run_filter = orig
    n = len(sol.pobs.time)
    ang, de = attitude_errors_deg(d, sol)
    f = sol.att_fixed
    sc = score_fixes(sol, d / "truth")
    t_att = np.asarray(sol.pobs.time - sol.pobs.time[0], float)[sol.att_epochs]
    out = {"epochs": n, "filter_s": tf[0], "epochs_per_s": n / tf[0], "wall_s": wall,
           "fix_rate": float(f.mean()), "wrong_fix": int(np.sum(f & (ang > 1.0))),
           "wrong_int": sc["wrong_constraints"], "constraints": sc["constraints"],
           "bias": de[f].mean(0), "std": de[f].std(0), "pred": np.sqrt(np.mean(sol.sigma_euler_deg[f] ** 2, 0)),
           "max_err": float(ang[f].max()), "summary": sol.summary, "products": sorted(prods),
           "de": de, "fixed": f, "t_att": t_att}
    if "hard" in d.name:
        out.update(event_check(sol, d))
    return out


def event_check(sol, d: Path) -> dict:
    """Truth slips a single difference can see (phase on both antennas of a baseline at the slip epoch and the one
    before) and truth clock jumps, against events.csv."""
    from gnssatt.attitude.truth import clock_jump_match, slips_seen_by_single_differences

    t = np.asarray(sol.pobs.time - sol.pobs.time[0], float)
    seen = [(e["sat"], e["signal"], t[e["epoch"]]) for e in sol.fr.events if e["event"] == "cycle_slip"]
    slips = slips_seen_by_single_differences(sol, d / "truth")
    found = sum(any(s == x[0] and f == x[1] and abs(tt - x[2]) < 1.5 for s, f, tt in seen) for x in slips)
    jumps, missed, spurious = clock_jump_match(sol, d / "truth")
    return {"slips_truth": len(slips), "slips_found": int(found), "jumps_truth": len(jumps),
            "jumps_found": len(jumps) - len(missed), "jump_spurious": len(spurious)}


PASSES = {  # label: (preset, minutes or None for --minutes, overrides)
    "clean": ("earth-pointing", None, CLEAN),
    "realistic": ("earth-pointing", None, {}),
    "hard": ("hard", 30.0, {}),
    "hard events": ("hard", 30.0, CLEAN),
    "clean 1deg wobble": ("earth-pointing", 30.0, {**CLEAN, "wobble_amp_deg": [1.0, 1.0, 1.0]}),
}


#: seed 000 Fig. 6: the yaw/roll slew (preset `slew`, 17 min) and the pitch manoeuvre of 6 June 2018 16:31-16:42
#: (Earth pointing, pitch 0 -> 50 deg within one minute, then gradually to -40 deg), clean passes
SLEWS = {"yaw/roll slew (17 min)": {"duration_s": 1020.0},
         "pitch manoeuvre (11 min)": {"start_gps": "2018-06-06T16:31:00", "duration_s": 660.0,
                                      "waypoints": [[0.0, 0.0, 0.0, 0.0], [60.0, 0.0, 0.0, 0.0],
                                                    [120.0, 0.0, 50.0, 0.0], [600.0, 0.0, -40.0, 0.0]]}}


#: settings compared on the slews (dynamic mode, "all phases"); Table 1 = the defaults
SLEW_SETTINGS = {"Table 1": {}, "adaptive": {"adaptive_omega_noise": True}, "Table 1 + smoother": {"smoother": True},
                 "adaptive + smoother": {"adaptive_omega_noise": True, "smoother": True},
                 "smoother, adaptive noise": {"smoother": True, "smoother_adaptive_noise": True}}


def run_slews(tmp: Path, seeds=(SEED,)) -> list[str]:
    """Dynamic mode on the two slews with each of SLEW_SETTINGS: max error over fixed epochs (with its time after
    the first fix and that epoch's predicted sigma), max error after the first 30 s of fix (the convergence), the lag
    (max of the 15-s running mean of the Euler errors), 95 % error, std(error / predicted sigma) after 30 s."""
    from gnssatt.attitude.truth import attitude_errors_deg, lag_deg
    from gnssatt.attitude.process import load_inputs, process
    from gnssatt.attitude.settings import AttitudeSettings  # the benches measure the "all phases" selection
    from gnssatt.sim import simulate_scenario

    lines = ["", f"Slews (seed 000 Fig. 6; clean, simulator seed{'s' if len(seeds) > 1 else ''} "
             f"{', '.join(map(str, seeds))}, dynamic mode, \"all phases\"; Table 1 = default settings; adaptive = "
             "`adaptive_omega_noise` with its defaults: causal manoeuvre detection, constant-acceleration "
             "hypotheses (prior 0.05 deg/s^2) against Table 1's random walk, estimate mixed by their weight "
             "(half-way at log-likelihood ratio 0), detection at 5 raises the random walk to 0.3 deg/s per sqrt(s) "
             "along the acceleration axis for 30 updates; smoother = "
             "`smoother`, the fixed-interval RTS smoother after the forward pass; smoother, adaptive noise = "
             "`smoother_adaptive_noise`, the omega random walk per epoch from the smoothed angular "
             "acceleration of a first pass, then the whole filter again with it and smoothed, docs/attitude.md). Lag = max over fixed epochs after "
             "the first 30 s of the 15-s running mean of the yaw/pitch/roll errors (noise averages out, a lag does "
             "not); max error: over all fixed epochs, with its time after the first fix and its predicted "
             "(1-sigma) tilt; z = std(error / predicted sigma) after 30 s, yaw / pitch / roll:", "",
             "| slew | seed | settings | fixed after first fix | fix lost | max error deg (s after fix, sigma) | "
             "max after first 30 s | lag deg | 95 % error deg | z |", "|---|---|---|---|---|---|---|---|---|---|"]
    for label, over in SLEWS.items():
        for seed in seeds:
            d = tmp / ("slew_" + label.split()[0].replace("/", "") + f"_{seed}")
            simulate_scenario("slew", d, seed=seed, overrides={**over, **CLEAN})
            inputs = load_inputs(files_of(d))
            for name, cfg in SLEW_SETTINGS.items():
                sol = process(inputs, AttitudeSettings.preset("all-phases", mode="dynamic", **cfg))
                ang, de = attitude_errors_deg(d, sol)
                f = sol.att_fixed
                t = np.asarray(sol.pobs.time - sol.pobs.time[0], float)[sol.att_epochs]
                t0 = t[int(np.argmax(f))]
                lag = lag_deg(d, sol, t0 + 30.0)
                late = f & (t > t0 + 30.0)
                i = np.flatnonzero(f)[int(np.argmax(ang[f]))]
                tilt = float(np.hypot(sol.sigma_euler_deg[i, 1], sol.sigma_euler_deg[i, 2]))
                z = " / ".join(f"{x:.2f}" for x in (de[late] / sol.sigma_euler_deg[late]).std(0))
                lines.append(f"| {label} | {seed} | {name} | {f[int(np.argmax(f)):].mean():.4f} | "
                             f"{'yes' if 'fix_lost' in sol.summary['events'] else 'no'} | {ang[i]:.2f} "
                             f"({t[i] - t0:.0f} s, {tilt:.2f}) | {ang[late].max():.2f} | {lag:.2f} | "
                             f"{np.percentile(ang[f], 95):.2f} | {z} |")
                print(lines[-1], flush=True)
    return lines


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--minutes", type=float, default=106.0)
    ap.add_argument("--passes", default=",".join(PASSES))
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--no-slews", action="store_true", help="skip the two slews")
    ap.add_argument("--slews-only", action="store_true", help="only the two slews (prints their table; no --write)")
    ap.add_argument("--slew-seeds", default=str(SEED), help="simulator seeds of the slews, comma-separated")
    args = ap.parse_args()
    slew_seeds = tuple(int(x) for x in args.slew_seeds.split(","))
    if args.slews_only:
        with tempfile.TemporaryDirectory() as tmp:
            lines = [f"Machine: {machine_line()}. One BLAS thread."] + run_slews(Path(tmp), slew_seeds)
        print("\n".join(lines))
        return
    from gnssatt.sim import simulate_scenario

    warm_up_kernels()
    lines = [f"Machine: {machine_line()}. One BLAS thread. Simulator seed {SEED}, 1 Hz, three antennas, "
             f"L1 C/A + L2 P(Y); clean and realistic: preset `earth-pointing`, {args.minutes:.0f} min; hard: preset "
             f"`hard`, 30 min. Load average at the start {os.getloadavg()[0]:.1f} (2 cores); speed: docs/BENCHMARKS.md "
             "\"Attitude job speed\". Rows: \"kinematic\" / \"dynamic\" on the \"all phases\" selection "
             "(settings.ALL_PHASES); the EXTRA_ROWS of the bench as labelled (Table 2 masks = the job's default "
             "selection; smoother_adaptive_noise = two forward passes + the fixed-interval smoother, its filter "
             "epochs/s is of one pass, its wall time of both).", ""]
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for label in args.passes.split(","):
            preset, minutes, over = PASSES[label]
            d = Path(tmp) / label.replace(" ", "_")
            simulate_scenario(preset, d, seed=SEED,
                              overrides={"duration_s": (minutes or args.minutes) * 60.0, **over})
            rows = [(m, None) for m in ("kinematic", "dynamic")] + [
                (name, cfg) for name, (on, cfg) in EXTRA_ROWS.items() if label in on]
            for mode, extra in rows:
                results[(label, mode)] = r = run_mode(d, mode, extra)
                print(label, mode, {k: (np.round(v, 3) if isinstance(v, np.ndarray) else v)
                                    for k, v in r.items() if k not in ("summary", "products", "de", "fixed",
                                                                       "t_att")}, flush=True)
        slew_lines = [] if args.no_slews else run_slews(Path(tmp), slew_seeds)
    lines += ["| pass | mode | epochs | filter epochs/s | job wall s | fix rate | wrong integers (truth) | "
              "> 1 deg fixed | yaw bias / std / predicted (deg) | pitch | roll | std / predicted | "
              "max error fixed (deg) |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for (label, mode), r in results.items():
        ang = " | ".join(f"{r['bias'][i]:+.3f} / {r['std'][i]:.3f} / {r['pred'][i]:.3f}" for i in range(3))
        ratio = " / ".join(f"{r['std'][i] / r['pred'][i]:.2f}" for i in range(3))
        lines.append(f"| {label} | {mode} | {r['epochs']} | {r['epochs_per_s']:.0f} | {r['wall_s']:.1f} | "
                     f"{r['fix_rate']:.4f} | {r['wrong_int']} of {r['constraints']} | {r['wrong_fix']} | {ang} | "
                     f"{ratio} | {r['max_err']:.2f} |")
    hard = [(k, r) for k, r in results.items() if "slips_truth" in r]
    if hard:
        lines += ["", "Hard passes, events against truth (slips on a phase that forms a single difference at the "
                  "slip epoch and the one before; clock jumps per receiver):", "",
                  "| pass | mode | slips in truth | reported as cycle_slip | clock jumps in truth | reported | "
                  "spurious clock_jump events |", "|---|---|---|---|---|---|---|"]
        for (label, mode), r in hard:
            lines.append(f"| {label} | {mode} | {r['slips_truth']} | {r['slips_found']} | {r['jumps_truth']} | "
                         f"{r['jumps_found']} | {r['jump_spurious']} |")
    ref = "clean 1deg wobble"
    if any(k[0] == "hard events" for k in results) and any(k[0] == ref for k in results):
        lines += ["", "Accuracy after re-fix: the hard events (slips, clock jumps, gaps, outages incl. all receivers "
                  "15 s at 1200 s) against the clean pass with the same wobble; error std (deg) over fixed epochs, "
                  "all of them and after the all-receiver outage (t > 1215 s):", "",
                  "| mode | pass | yaw / pitch / roll, all fixed | after the outage |", "|---|---|---|---|"]
        for mode in ("kinematic", "dynamic"):
            for label in ("hard events", ref):
                r = results[(label, mode)]
                f, de, t = r["fixed"], r["de"], r["t_att"]
                late = f & (t > 1215.0)
                a = " / ".join(f"{x:.3f}" for x in de[f].std(0))
                b = " / ".join(f"{x:.3f}" for x in de[late].std(0))
                lines.append(f"| {mode} | {label} | {a} | {b} |")
    if ("clean", "kinematic") in results:
        lines += ["", "Seed 000 Table 4 next to the product's summary.json (clean pass, kinematic; expected sigmas "
                  "by eq. 3-4 with the configured sigma_phase 3 mm):", "",
                  "| baseline | HDOP paper / ours | VDOP paper / ours | expected yaw paper / ours | expected tilt "
                  "paper / ours | measured yaw paper | measured tilt paper |", "|---|---|---|---|---|---|---|"]
        for b in results[("clean", "kinematic")]["summary"]["baselines"]:
            t = TABLE4.get(b["baseline"], {})
            tilt = b.get("expected_sigma_pitch_deg", b.get("expected_sigma_roll_deg"))
            lines.append(f"| {b['baseline']} | {t.get('hdop')} / {b['hdop']:.2f} | {t.get('vdop')} / "
                         f"{b['vdop']:.2f} | {t.get('exp_yaw')} / {b['expected_sigma_yaw_deg']:.2f} | "
                         f"{t.get('exp_tilt')} / {tilt:.2f} | {t.get('meas_yaw')} | {t.get('meas_tilt')} |")
    lines += slew_lines
    text = "\n".join(lines)
    print(text)
    if args.write:
        replace_section(ROOT / "docs" / "BENCHMARKS.md", "Attitude job", text + "\n\n" + NOTES)


NOTES = """Done-when status (issue 6) from these tables (figures quoted from the run above; "kinematic" / "dynamic" rows
use every tracked phase ("all phases"), the job's default keeps seed 000 Table 2's C/N0 and antenna masks: the
"Table 2 masks (default)" rows; docs/attitude.md "Quality control", "Accuracy floor"):

- Clean 106 min: kinematic |bias| <= 0.006 deg, std/predicted 0.96-1.01 with either selection (limit 0.02 deg and
  1.3x: met); dynamic errors smaller than kinematic on every angle (met); fix rate 99.94 % (met); no wrong integer
  (truth arcs) in any row; no dynamic epoch above 1 deg (max 0.88; 0.18 / 0.25 with smoother_adaptive_noise).
  Kinematic epochs are single-epoch solutions at the true-integer least-squares floor (pitch sigma 0.25 deg; with
  Table 2's masks 0.34): 17 of 6354 exceed 1 deg (max 1.28) with the right integers, 138 with the default masks
  (6 / 69 with attitude_method "ml", docs/attitude.md) - "no wrong fix" by the 1-deg definition is not met in
  kinematic mode, and cannot be by an epoch-wise estimator (the floor itself has such epochs; seed 000's own
  kinematic errors, pitch 0.32 / roll 0.26 deg 1-sigma, put ~0.2 % of epochs per angle beyond 1 deg).
- Realistic 106 min (earth-pointing preset as it is): no wrong integer in any row (~2600-4700 constraints);
  std/predicted 0.88-1.03 (forward filter), 1.07-1.29 (smoother_adaptive_noise). Epochs above 1 deg while fixed,
  all with the right integers: forward dynamic 82 (179 with the default masks), kinematic 950 (1426): the 0.28 deg
  yaw bias of the uncalibrated PCO plus 3-sigma excursions of the tilt sigma (dynamic 0.27 deg). With
  smoother_adaptive_noise: 0 (max 0.87 deg) on all phases, 47 (max 1.16, one excursion at 103-104 min that every
  estimator shows) with the default masks.
- Hard 30 min (free clocks with 1 ms jumps, slips with/without LLI, gaps, outages, strong multipath, 25 mm PCV):
  completes; no wrong integer; every slip a single difference can see is reported (490/490; 43 more happen on
  satellites the partner antenna does not track: no single difference, never used); every clock jump is reported
  and none invented (4/4, 0 spurious). Epochs above 1 deg (500 dynamic, 318 with smoother_adaptive_noise): right
  integers, pitch bias -0.64 deg from the uncalibrated 25 mm PCV and tilt sigma 0.40 deg.
- Accuracy after re-fix: the hard events without multipath/PCV ("hard events") against the clean pass with the
  same 1 deg wobble (table above): equal within 0.005 deg, also after the all-receiver outage.
- Slews (seeds 0-7): no fix lost in any row. Table 1's forward filter: max over fixed epochs 0.64-1.68 (yaw/roll)
  / 0.87-1.67 deg (pitch), lag (15-s mean) 0.17-0.28 / 0.57-0.76 deg (the paper saw up to 1 deg). The causal
  `adaptive` option brings the pitch lag to 0.17-0.28 deg (all 8 below 0.3; thin margin), but no causal filter
  brings the instantaneous maximum below 0.3 deg (0.47-0.85 after 30 s: the pitch-up is detectable only ~10 s in,
  and the tilt noise alone reaches 0.45-0.6 deg over ~1000 epochs). `smoother_adaptive_noise` (post-processing:
  the omega process noise adapted per epoch from a first pass, a second forward pass, the fixed-interval
  smoother): max after the first 30 s of fix 0.12-0.21 / 0.15-0.26 deg, all 16 runs below 0.3 (plain smoother
  0.19-0.27 / 0.20-0.39), lag 0.11-0.19 / 0.12-0.19; over all fixed epochs 0.15-0.53 / 0.16-0.38 deg, 6 of 16
  runs at or above 0.3 deg, each at the first fixed epoch (a one-epoch solution on the satellites acquired so
  far, within 1.6 of its predicted sigma).
- Speed: see "Attitude job speed" (filter 8,853-12,209 epochs/s of CPU, upload to products 4.5 s).

Run: `OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_attitude.py --slew-seeds 0,1,2,3,4,5,6,7 --write`
(~2 min on an idle machine).
"""


if __name__ == "__main__":
    main()
