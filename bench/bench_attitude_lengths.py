"""Dynamic-mode baseline lengths (issue 21 item 2): the length error over the four 106-minute passes, without and
with the soft length constraint (settings.length_constraint_sigma_m, gnssatt/attitude/length_constraint.py) and with
the rigid update (settings.baseline_update "rigid", gnssatt/attitude/rigid_update.py; its smoother's backward step
gnssatt/attitude/rigid_smoother.py), forward filter, smoother and smoother_adaptive_noise, with the attitude errors
of the same runs (so a change of the length handling shows what it costs or gives the attitude).

Two truths for the length: the body length (platform.json, the antennas' reference points) and the phase-centre
length, which is what GNSS phases observe and what the dynamic mode's baselines.csv length is measured against
(docs/attitude.md "Dynamic-mode lengths"): the body baseline plus the difference of the two antennas' phase-centre
offsets (truth/model.json pco_ant_m turned to the body by R_ant_from_body), the mean of the L1 and L2 lengths (the
filter fits one baseline to both frequencies with equal phase sigmas in metres). The PCV of the realistic and hard
passes shifts the observed length further (uncalibrated, elevation-dependent: not in this truth).

Passes (simulator seed 0, 106 min at 1 Hz, three antennas, L1 C/A + L2 P(Y)): `clean` (preset `earth-pointing`
without PCV/PCO/multipath: the body length is the truth), `realistic` (`earth-pointing` as it is: PCO scatter and
PCV make the phase-centre baselines 2-3 mm (L1) off the body lengths), `hard` (preset `hard`, 25 mm PCV), `slew`
(preset `slew`, clean). Selection "all phases" (settings.ALL_PHASES), as bench_attitude.py.

Per run and baseline, against each truth: mean length error over fixed epochs, min / max of its 5-minute means
(every 300 epochs), the mean over the last 5 minutes (body only); attitude: yaw / pitch / roll error RMS and max
over fixed epochs, the max rotation error.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_attitude_lengths.py [--minutes 106] [--write]
        [--passes clean,slew] [--runs "forward, rigid update"]      (one pass / one run: print only)
        [--true-maps]       (the simulator's differential PCV maps, truth/pcv, applied as a calibrated platform's
                             settings.calibration.pcv_maps: print only)
        [--true-baselines]  (with --true-maps: also the phase-centre baselines, mean of L1 and L2, as
                             settings.calibration.calibrated_baselines, and each frequency's offset from it in its
                             map: a platform calibrated exactly, CONVENTIONS.md split; print only)
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from bench._report import machine_line, replace_section  # noqa: E402
from bench.bench_attitude import files_of  # noqa: E402

SEED = 0
CLEAN = {"pcv": False, "pco": False, "multipath": False, "noise_grows_with_cn0": False}
PASSES = {"clean": ("earth-pointing", CLEAN), "realistic": ("earth-pointing", {}), "hard": ("hard", {}),
          "slew": ("slew", CLEAN)}
SIGMA_M = 5e-4
ADD = {"baseline_update": "additive"}
RUNS = {"forward, no constraint": {**ADD, "length_constraint_sigma_m": 0.0},
        f"forward, constraint {SIGMA_M * 1e3:.1f} mm": {**ADD, "length_constraint_sigma_m": SIGMA_M},
        "smoother_adaptive_noise, no constraint": {**ADD, "length_constraint_sigma_m": 0.0, "smoother": True,
                                                   "smoother_adaptive_noise": True},
        f"smoother_adaptive_noise, constraint {SIGMA_M * 1e3:.1f} mm": {**ADD, "length_constraint_sigma_m": SIGMA_M,
                                                                        "smoother": True,
                                                                        "smoother_adaptive_noise": True},
        "forward, rigid update": {"baseline_update": "rigid"},
        "smoother_adaptive_noise, rigid update": {"baseline_update": "rigid", "smoother": True,
                                                  "smoother_adaptive_noise": True},
        "smoother, no constraint": {**ADD, "length_constraint_sigma_m": 0.0, "smoother": True},
        "smoother, rigid update": {"baseline_update": "rigid", "smoother": True}}


def simulated_pass(base: Path, label: str, seed: int, minutes: float) -> Path:
    """The set of pass `label` (PASSES) for `seed`, `minutes` long, at base/seed<seed>_<label>: simulated once,
    then reused (the benches' --sets folder)."""
    from gnssatt.sim import simulate_scenario

    preset, over = PASSES[label]
    d = Path(base) / f"seed{seed}_{label}"
    if not (d / "platform.json").exists():
        simulate_scenario(preset, d, seed=seed, overrides={"duration_s": minutes * 60.0, **over})
    return d


def phase_centre_lengths_m(d: Path, baselines: list) -> np.ndarray:
    """(n_bl,) phase-centre lengths of the simulated set d (m): |body baseline + PCO_b - PCO_a| with the PCOs
    (truth/model.json, antenna frame) turned to the body, mean of L1 and L2 (module doc)."""
    ants = json.loads((d / "truth" / "model.json").read_text())["antennas"]

    def pc(a: str, f: str) -> np.ndarray:
        A = ants[a]
        return np.array(A["arp_true_body_m"]) + np.array(A["R_ant_from_body"]).T @ np.array(A["pco_ant_m"][f])

    return np.array([np.mean([np.linalg.norm(pc(b, f) - pc(a, f)) for f in ("L1", "L2")]) for a, b in baselines])


def true_maps(d: Path, with_offsets: bool = False) -> dict:
    """(first, second, signal) -> the simulator's differential PCV map of the set d (truth/pcv, CONVENTIONS layout on
    the grid nodes; exact with parallel antenna frames), as settings.calibration.pcv_maps of a calibrated platform.
    with_offsets: each frequency's phase-centre offset from the mean of L1 and L2 folded into its map,
    -g . (b_f - b_mean) (gnssatt.calibration.simulated.truth_map_mm: the offset/variation split of CONVENTIONS.md
    with b_mean as the calibrated baseline)."""
    from gnssatt.calibration.simulated import truth_map_mm, truth_of

    truth = truth_of(d) if with_offsets else None
    out = {}
    for p in sorted((d / "truth" / "pcv").glob("*.json")):
        doc = json.loads(p.read_text())
        key = (doc["pair"][0], doc["pair"][1], doc["frequency"])
        out[key] = {k: doc[k] for k in ("platform", "pair", "frequency", "azimuth_deg", "elevation_deg", "values_mm")}
        if with_offsets:
            A, E = np.meshgrid(np.asarray(doc["azimuth_deg"], float), np.asarray(doc["elevation_deg"], float))
            b_mean = truth["baselines"][key[:2]]["mean_m"]
            bore = json.loads((d / "platform.json").read_text())["antennas"][key[0]]["boresight"]
            out[key]["values_mm"] = np.round(truth_map_mm(truth, key, b_mean, A, E, bore), 6).tolist()
    return out


def run(d: Path, cfg: dict) -> list[dict]:
    """Length and attitude figures of one dynamic-mode run on the set d (one dict per baseline)."""
    from gnssatt.attitude.process import load_inputs, process
    from gnssatt.attitude.settings import ALL_PHASES, AttitudeSettings
    from gnssatt.attitude.truth import attitude_errors_deg

    sol = process(load_inputs(files_of(d)), AttitudeSettings.preset("seed000", **{**ALL_PHASES, "mode": "dynamic",
                                                                                  **cfg}))
    fr = sol.fr
    pl = json.loads((d / "platform.json").read_text())
    pos = {k: np.array(v["position_m"]) for k, v in pl["antennas"].items()}
    ang, de = attitude_errors_deg(d, sol)
    f_att = sol.att_fixed
    L_pc = phase_centre_lengths_m(d, pl["baselines"])
    out = []
    for j, (a, b) in enumerate(pl["baselines"]):
        L = np.linalg.norm(fr.b_ecef_m[:, j], axis=1)
        r = {"baseline": f"{a}>{b}", "att_rms": np.sqrt(np.mean(de[f_att] ** 2, 0)),
             "att_max_axis": np.abs(de[f_att]).max(0), "att_max": float(ang[f_att].max())}
        for key, truth_m in (("body", np.linalg.norm(pos[b] - pos[a])), ("pc", L_pc[j])):
            e = np.where(fr.fixed[:, j], (L - truth_m) * 1e3, np.nan)
            means = np.array([np.nanmean(e[i:i + 300]) for i in range(0, e.size - 299, 300)
                              if np.isfinite(e[i:i + 300]).any()])
            r[key] = (np.nanmean(e), means.min(), means.max(), np.nanmean(e[-300:]))
        out.append(r)
    return out


def validation_rows(d: Path, label: str) -> list[str]:
    """ambiguity.length_validation filter / single-epoch / both in both modes on the set d (the job's default data
    selection): fix and fix_rejected events, wrong integers against truth/arcs.csv, attitude fix rate."""
    from gnssatt.attitude.process import load_inputs, process
    from gnssatt.attitude.settings import AttitudeSettings
    from gnssatt.attitude.truth import score_fixes

    out = []
    inputs = load_inputs(files_of(d))
    for mode in ("dynamic", "kinematic"):
        for val in ("filter", "single-epoch", "both"):
            sol = process(inputs, AttitudeSettings.preset("seed000", mode=mode,
                                                          ambiguity={"length_validation": val}))
            ev = [e["event"] for e in sol.fr.events]
            sc = score_fixes(sol, d / "truth")
            out.append(f"| {label} | {mode} | {val} | {ev.count('fix')} | {ev.count('fix_rejected')} | "
                       f"{sc['wrong_constraints']} of {sc['constraints']} | {sol.att_fixed.mean():.4f} |")
            print(out[-1], flush=True)
    return out


def row(label: str, name: str, r: dict) -> str:
    """One table row of run()'s figures for a baseline."""
    b, p = r["body"], r["pc"]
    return (f"| {label} | {name} | {r['baseline']} | {b[0]:+.3f} / {b[1]:+.3f} / {b[2]:+.3f} / {b[3]:+.3f} | "
            f"{p[0]:+.3f} / {p[1]:+.3f} / {p[2]:+.3f} | {' / '.join(f'{v:.4f}' for v in r['att_rms'])} | "
            f"{' / '.join(f'{v:.2f}' for v in r['att_max_axis'])} | {r['att_max']:.2f} |")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--minutes", type=float, default=106.0)
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--validation-only", action="store_true", help="only the length-validation table (all passes)")
    ap.add_argument("--passes", default=",".join(PASSES), help="comma-separated subset of " + ",".join(PASSES))
    ap.add_argument("--runs", default=None, help="one run name of RUNS (print only, no validation table)")
    ap.add_argument("--true-maps", action="store_true", help="apply the simulator's PCV maps (print only)")
    ap.add_argument("--true-baselines", action="store_true", help="with --true-maps: the phase-centre baselines too")
    args = ap.parse_args()
    passes = args.passes.split(",")
    runs = RUNS if args.runs is None else {args.runs: RUNS[args.runs]}
    if args.write and (len(passes) < len(PASSES) or args.runs is not None or args.minutes != 106.0
                       or args.true_maps or args.true_baselines):
        ap.error("--write needs every pass and run at 106 min, without --true-maps")
    from gnssatt.sim import simulate_scenario

    lines = [f"Machine: {machine_line()}. One BLAS thread. Simulator seed {SEED}, {args.minutes:.0f} min at 1 Hz, "
             "three antennas, L1 C/A + L2 P(Y), dynamic mode, \"all phases\". Length error = |b| - truth over fixed "
             "epochs, mm, against the body length (platform.json) and the phase-centre length (body baseline + PCO "
             "difference, mean of L1 and L2: what GNSS observes and what baselines.csv is measured against; "
             "clean and slew have no PCO, the two are one): mean, min / max of the 5-minute means, last 5 minutes "
             "(body); attitude: error RMS and max per axis yaw / pitch / roll over fixed epochs, the max rotation "
             "error (deg).", "",
             "| pass | run | baseline | body: mean / 5-min min / max / last 5 min mm | phase centre: mean / 5-min "
             "min / max mm | RMS yaw / pitch / roll deg | max yaw / pitch / roll deg | max deg |",
             "|---|---|---|---|---|---|---|---|"]
    val_lines = ["Length validation of first fixes (`ambiguity.length_validation`: filter = today's test on the "
                 "filter's conditional baseline; single-epoch = seed 000's, the epoch's own phases with the "
                 "candidate integers; both), the job's default data selection (Table 2 masks), same passes:", "",
                 "| pass | mode | length validation | fix events | fix_rejected events | wrong integers (truth) | "
                 "attitude fix rate |", "|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        for label, (preset, over) in PASSES.items():
            if label not in passes:
                continue
            d = Path(tmp) / label
            simulate_scenario(preset, d, seed=SEED, overrides={"duration_s": args.minutes * 60.0, **over})
            if args.runs is None and (args.validation_only or label in ("realistic", "hard")):
                val_lines += validation_rows(d, label)
            if args.validation_only:
                continue
            maps = {"calibration": {"pcv_maps": true_maps(d, args.true_baselines)}} if args.true_maps else {}
            if args.true_maps and args.true_baselines:
                from gnssatt.calibration.simulated import truth_of
                maps["calibration"]["calibrated_baselines"] = {k: v["mean_m"].tolist()
                                                               for k, v in truth_of(d)["baselines"].items()}
            tag = (", true PCV maps" if maps else "") + (" and baselines" if args.true_baselines and maps else "")
            for name, cfg in runs.items():
                for r in run(d, {**cfg, **maps}):
                    lines.append(row(label, name + tag, r))
                    print(lines[-1], flush=True)
    lines += ["", "Run: `OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_attitude_lengths.py --write`."]
    val_lines[0] = f"Machine: {machine_line()}. " + val_lines[0]
    val_lines += ["", "Run: `OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_attitude_lengths.py --validation-only "
                  "--write` (without --validation-only the realistic and hard rows are printed, not written)."]
    print("\n".join(val_lines))
    if args.write:
        if not args.validation_only:
            replace_section(ROOT / "docs" / "BENCHMARKS.md", "Dynamic-mode lengths", "\n".join(lines))
        else:       # the validation table covers every pass only with --validation-only
            replace_section(ROOT / "docs" / "BENCHMARKS.md", "Single-epoch length validation", "\n".join(val_lines))


if __name__ == "__main__":
    main()
