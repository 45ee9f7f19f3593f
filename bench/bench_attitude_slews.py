"""Slews from the first fixed epoch (issue 21 item 3): seed 000 Fig. 6's two manoeuvres (bench_attitude.SLEWS), clean,
simulator seeds 0-7, dynamic mode, "all phases", `smoother_adaptive_noise` without and with the angular-acceleration
state (settings.angular_acceleration_state, gnssatt/attitude/angular_acceleration.py, its default noise), and with it
`smoother_quiet_jerk_share` 0.04 (the second pass's jerk rate following the omega profile, jerk_rate_profile).

Per run: max attitude error over every fixed epoch (from the first fixed epoch) with its time after the first fix,
max after the first 30 s, the smoothed pitch / roll sigma at the first fixed epoch (the larger), the smoother's
tilt chi-square (pitch and roll error over their predicted sigmas, squared and summed: 2 degrees of freedom) as the
mean over the first 10 fixed epochs and over the rest, and per degree of freedom (that sum / 2: 1 for honest sigmas)
over every fixed epoch from the first one (issue 21's "smoother chi-square 1.0-1.5 from the first fixed epoch").

With --passes also the four 106-minute passes of bench_attitude_lengths.py (wrong integers, attitude std, chi-square).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_attitude_slews.py [--seeds 0,1,2,3,4,5,6,7] [--passes] [--write]

--write replaces the section "Slews from the first fixed epoch"; without --passes it keeps the passes block there.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from bench._report import machine_line, replace_section  # noqa: E402
from bench.bench_attitude import CLEAN, SLEWS, files_of  # noqa: E402

RUNS = {"smoother, adaptive noise": {"smoother": True, "smoother_adaptive_noise": True},
        "+ angular acceleration state": {"smoother": True, "smoother_adaptive_noise": True,
                                         "angular_acceleration_state": True},
        "+ quiet jerk share 0.04": {"smoother": True, "smoother_adaptive_noise": True,
                                    "angular_acceleration_state": True, "smoother_quiet_jerk_share": 0.04}}
#: not in the default table (--runs): the floor of the adaptive noise estimated from the pass (process_noise_em)
EXTRA_RUNS = {"+ noise_em 4": {"smoother": True, "smoother_adaptive_noise": True, "smoother_noise_em_iterations": 4},
              "+ acceleration, noise_em 4": {"smoother": True, "smoother_adaptive_noise": True,
                                             "angular_acceleration_state": True, "smoother_noise_em_iterations": 4}}
#: not in the default table: the multipath scale from the residuals' lag-1 autocovariance (multipath_vce)
EXTRA_RUNS.update({f"{name}, autocovariance{tag}": {**cfg, "multipath_adaptive_method": "autocovariance", **k}
                   for name, cfg in RUNS.items()
                   for tag, k in (("", {}), (" k 1", {"multipath_correlation_factor": 1.0}))})


def figures(d: Path, inputs, cfg: dict) -> dict:
    """Max error (deg) over fixed epochs and its time after the first fix (s), max after 30 s, the larger smoothed
    tilt sigma at the first fixed epoch (deg), tilt chi-square."""
    from gnssatt.attitude.process import process
    from gnssatt.attitude.settings import AttitudeSettings
    from gnssatt.attitude.truth import attitude_errors_deg

    sol = process(inputs, AttitudeSettings.preset("all-phases", mode="dynamic", **cfg))
    ang, de = attitude_errors_deg(d, sol)
    fi = np.flatnonzero(sol.att_fixed)
    t = np.asarray(sol.pobs.time - sol.pobs.time[0], float)[sol.att_epochs]
    t0 = t[fi[0]]
    chi2 = (de[:, 1] / sol.sigma_euler_deg[:, 1]) ** 2 + (de[:, 2] / sol.sigma_euler_deg[:, 2]) ** 2
    i = fi[int(np.argmax(ang[fi]))]
    late = fi[t[fi] > t0 + 30.0]
    return {"max": float(ang[i]), "at_s": float(t[i] - t0), "late": float(ang[late].max()),
            "sigma0": float(sol.sigma_euler_deg[fi[0], 1:3].max()),
            "chi2_first": float(chi2[fi[:10]].mean()), "chi2_rest": float(chi2[fi[10:]].mean()),
            "chi2_dof_all": float(chi2[fi].mean() / 2.0)}


def pass_rows(tmp: Path, minutes: float) -> list[str]:
    """The four 106-minute passes of bench_attitude_lengths.py (seed 0, "all phases", dynamic mode): forward and
    smoother_adaptive_noise, each without and with the acceleration state: wrong integers against truth/arcs.csv,
    attitude fix rate, yaw / pitch / roll error std over fixed epochs, max error, tilt chi-square first 10 / rest."""
    from bench.bench_attitude_lengths import PASSES, SEED
    from gnssatt.attitude.process import load_inputs, process
    from gnssatt.attitude.settings import ALL_PHASES, AttitudeSettings
    from gnssatt.attitude.truth import attitude_errors_deg, score_fixes
    from gnssatt.sim import simulate_scenario

    runs = {"forward": {}, "forward + acceleration": {"angular_acceleration_state": True},
            "smoother, adaptive noise": RUNS["smoother, adaptive noise"],
            "+ angular acceleration state": RUNS["+ angular acceleration state"],
            "+ quiet jerk share 0.04": RUNS["+ quiet jerk share 0.04"]}
    out = ["", f"The four {minutes:.0f}-minute passes (bench_attitude_lengths.py, simulator seed {SEED}, "
           "\"all phases\", dynamic mode):", "",
           "| pass | run | wrong integers | attitude fix rate | std yaw / pitch / roll deg | max deg | "
           "tilt chi-square first 10 / rest | per dof from the first fixed epoch |", "|---|---|---|---|---|---|---|---|"]
    for label, (preset, over) in PASSES.items():
        d = tmp / f"pass_{label}"
        simulate_scenario(preset, d, seed=SEED, overrides={"duration_s": minutes * 60.0, **over})
        inputs = load_inputs(files_of(d))
        for name, cfg in runs.items():
            sol = process(inputs, AttitudeSettings.preset("seed000", **{**ALL_PHASES, "mode": "dynamic", **cfg}))
            ang, de = attitude_errors_deg(d, sol)
            f = sol.att_fixed
            fi = np.flatnonzero(f)
            sc = score_fixes(sol, d / "truth")
            chi2 = (de[:, 1] / sol.sigma_euler_deg[:, 1]) ** 2 + (de[:, 2] / sol.sigma_euler_deg[:, 2]) ** 2
            sd = de[f].std(0)
            out.append(f"| {label} | {name} | {sc['wrong_constraints']} of {sc['constraints']} | {f.mean():.4f} | "
                       f"{sd[0]:.4f} / {sd[1]:.4f} / {sd[2]:.4f} | {ang[f].max():.2f} | "
                       f"{chi2[fi[:10]].mean():.2f} / {chi2[fi[10:]].mean():.2f} | {chi2[fi].mean() / 2:.2f} |")
            print(out[-1], flush=True)
    return out


def kept_passes(path: Path) -> list[str]:
    """--write without --passes: the section's earlier passes block (from "The four" up to its "Run:" line), kept
    with a note of the run it came from, so that a slews-only re-measure does not drop it."""
    import re

    text = path.read_text()
    m = re.search(r"^## Slews from the first fixed epoch\n(.*?)(?=^## |\Z)", text, re.S | re.M)
    start = re.search(r"^(\(kept from [^)]*\) )?The four ", m.group(1), re.M) if m else None
    if start is None:
        return []
    body = m.group(1)
    origin = re.search(r"commit (\w+), (\d{4}-\d\d-\d\d)", body)
    block = body[start.start():]
    block = block[:block.rindex("\nRun:")] if "\nRun:" in block else block
    block = block.strip()
    if origin and not block.startswith("(kept from"):      # a block kept before carries its own origin already
        block = f"(kept from the --passes run of commit {origin.group(1)}, {origin.group(2)}; not re-run) " + block
    return ["", block]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", default="0,1,2,3,4,5,6,7")
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--passes", action="store_true", help="also the four 106-minute passes")
    ap.add_argument("--minutes", type=float, default=106.0, help="length of those passes")
    ap.add_argument("--runs", default=None, help="slews only, print only: ';'-separated names of RUNS / EXTRA_RUNS")
    args = ap.parse_args()
    runs = RUNS if args.runs is None else {n: {**RUNS, **EXTRA_RUNS}[n] for n in args.runs.split(";")}
    if args.runs is not None and (args.write or args.passes):
        ap.error("--runs is for the slews, without --write / --passes")
    from gnssatt.attitude.process import load_inputs
    from gnssatt.sim import simulate_scenario

    seeds = [int(x) for x in args.seeds.split(",")]
    lines = [f"Machine: {machine_line()}. One BLAS thread. Seed 000 Fig. 6's slews (bench_attitude.py `SLEWS`), clean, "
             f"simulator seeds {', '.join(map(str, seeds))}, dynamic mode, \"all phases\"; `smoother_adaptive_noise` "
             "without and with `angular_acceleration_state` (its defaults: jerk 0.0005 deg/s^2 per sqrt(s), omega "
             "random walk 0.01 deg/s per sqrt(s), sigma0 0.05 deg/s^2), and with it `smoother_quiet_jerk_share` 0.04. "
             "Max error over every fixed epoch from the first one (s after the first fix), max after the first 30 s, "
             "the smoothed tilt sigma at the first fixed epoch (larger of pitch / roll), smoother tilt chi-square "
             "(2 dof) over the first 10 fixed epochs / the rest, and per degree of freedom (/ 2) over every fixed "
             "epoch from the first one:", "",
             "| slew | seed | settings | max error deg (s after fix) | max after 30 s | sigma at first fix deg | "
             "chi-square first 10 / rest | per dof from the first |",
             "|---|---|---|---|---|---|---|---|"]
    summary = {name: [] for name in runs}
    with tempfile.TemporaryDirectory() as tmp:
        for label, over in SLEWS.items():
            for seed in seeds:
                d = Path(tmp) / f"{label.split()[0].replace('/', '')}_{seed}"
                simulate_scenario("slew", d, seed=seed, overrides={**over, **CLEAN})
                inputs = load_inputs(files_of(d))
                for name, cfg in runs.items():
                    r = figures(d, inputs, cfg)
                    summary[name].append(r)
                    lines.append(f"| {label} | {seed} | {name} | {r['max']:.2f} ({r['at_s']:.0f} s) | {r['late']:.2f} "
                                 f"| {r['sigma0']:.2f} | {r['chi2_first']:.2f} / {r['chi2_rest']:.2f} "
                                 f"| {r['chi2_dof_all']:.2f} |")
                    print(lines[-1], flush=True)
        pass_lines = pass_rows(Path(tmp), args.minutes) if args.passes else []
    lines.append("")
    for name, rs in summary.items():
        mx = np.array([r["max"] for r in rs])
        c1 = np.array([r["chi2_first"] for r in rs])
        ca = np.array([r["chi2_dof_all"] for r in rs])
        lines.append(f"- {name}: max error over all fixed epochs above 0.3 deg on {int((mx > 0.3).sum())} of {mx.size} "
                     f"runs (worst {mx.max():.2f}, median {np.median(mx):.2f}); chi-square over the first 10 fixed "
                     f"epochs {c1.min():.2f}-{c1.max():.2f} (median {np.median(c1):.2f}); per dof from the first fixed "
                     f"epoch {ca.min():.2f}-{ca.max():.2f} (median {np.median(ca):.2f}).")
    if args.write and not args.passes:
        pass_lines = kept_passes(ROOT / "docs" / "BENCHMARKS.md")
    lines += pass_lines
    lines += ["", "Run: `OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_attitude_slews.py --passes --write`."]
    print("\n".join(lines[-len(runs) - 2:]))
    if args.write:
        replace_section(ROOT / "docs" / "BENCHMARKS.md", "Slews from the first fixed epoch", "\n".join(lines))


if __name__ == "__main__":
    main()
