"""Vector-phase attitude benchmark (issue 20, seed 003): accuracy of the single-antenna attitude versus phase
noise and number of satellites, the consistency of the estimators' sigma, and the multi-antenna attitude job
re-checked on simulated data that include a real antenna's wind-up.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_vector_phase.py [--seeds 4] [--epochs 180] [--write]
        [--rate-step 0 --sats 8 9 10]   (one filter from zero rate instead of the start-hypothesis bank: its own
                                         section, the comparison for "no degradation")

1. Grid: the non-symmetric patch (asymmetry 0.5, harmonic 2) on the ground platform of
   gnssatt.vector_phase.scenario (yaw 0.5 deg/s, pitch +-10 deg, roll +-8 deg), phase noise 0.5-3 mm, 7-10
   satellites (all the scenario has above 10 deg), EKF from the known initial state (with its default bank of
   start hypotheses over the initial rate, gnssatt.vector_phase.rate_bank, unless --rate-step); per cell the RMS
   error of yaw, pitch, roll over the epochs
   after the first 30 s and all seeds, and the RMS of error / sigma. Figure: docs/figures/vector_phase_accuracy.png.
2. The batch (epoch-wise) estimator at 0.1 mm, 8 satellites, the same statistics.
3. The attitude job (gnssatt.attitude.api.solve, preset seed000) on the earth-pointing pass (clean: no PCV, PCO,
   multipath), once with the simulator's default wind-up and once with windup_antenna = the asymmetric patch:
   the largest single-difference wind-up left between the identical antennas, and the attitude errors.
Inputs are generated from the seeds named here (0..seeds-1); nothing is read from outside the repository.
"""
from __future__ import annotations

import argparse
import csv
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

NOISE_MM = (0.5, 1.0, 2.0, 3.0)
N_SATS = (7, 8, 9, 10)     # the scenario has 10 satellites above 10 deg for the whole run
L1_MM = 299792458.0 / 1575.42e6 * 1e3
SKIP_S = 30
ANTENNA = {"model": "asymmetric-patch", "asymmetry": 0.5, "harmonic": 2}


def _stats(solver, antenna, n_sats, noise_mm, seeds, epochs, skip):
    from dataclasses import replace

    from gnssatt.vector_phase.phase_model import ReceiverState
    from gnssatt.vector_phase.scenario import ScenarioSpec, simulate
    from gnssatt.vector_phase.solution import euler_rows

    errs, ratios = [], []
    for seed in range(seeds):
        obs, truth, mount = simulate(ScenarioSpec(antenna, n_sats=n_sats, n_epochs=epochs, seed=seed,
                                                  sigma_phase_cyc=noise_mm / L1_MM))
        sol = solver(obs, mount, ReceiverState(truth.position_ecef_m, 0.0, truth.R_body_from_ecef[0]))
        bore = mount.R_ant_from_body[2]
        est = euler_rows(sol, truth.R_ned_from_ecef, bore)
        tru = euler_rows(replace(sol, R_body_from_ecef=truth.R_body_from_ecef), truth.R_ned_from_ecef, bore)
        e = ((est.euler_deg - tru.euler_deg + 180.0) % 360.0 - 180.0)[skip:]
        errs.append(e)
        ratios.append(e / est.sigma_deg[skip:])
    e, r = np.concatenate(errs), np.concatenate(ratios)
    return np.sqrt(np.nanmean(e ** 2, axis=0)), np.sqrt(np.nanmean(r ** 2, axis=0))


def grid(seeds: int, epochs: int, rate_step=None, sats=N_SATS):
    from gnssatt.vector_phase.antenna import AsymmetricPatch
    from gnssatt.vector_phase.ekf import EkfOptions, ekf_solve

    ant = AsymmetricPatch(asymmetry=ANTENNA["asymmetry"], harmonic=ANTENNA["harmonic"])
    opt = EkfOptions() if rate_step is None else EkfOptions(rate_hypotheses_step_deg_s=rate_step)

    def solver(obs, mount, initial):
        return ekf_solve(obs, mount, initial, opt)
    out = {}
    for n in sats:
        for mm in NOISE_MM:
            t0 = time.perf_counter()
            out[(n, mm)] = (*_stats(solver, ant, n, mm, seeds, epochs, SKIP_S), time.perf_counter() - t0)
            print(f"  n_sats {n:2d} noise {mm:.1f} mm: rms err {np.round(out[(n, mm)][0], 2)} deg, "
                  f"err/sigma {np.round(out[(n, mm)][1], 2)}", flush=True)
    return out


def plot(out, path: Path):
    from gnssatt.plots.common import figure_png, new_figure

    fig = new_figure(10.0, 4.5)
    axes = fig.subplots(1, 3, sharey=True)
    for i, (ax, name) in enumerate(zip(axes, ("yaw", "pitch", "roll"))):
        for n in N_SATS:
            ax.plot(NOISE_MM, [out[(n, mm)][0][i] for mm in NOISE_MM], "o-", label=f"{n} satellites")
        ax.set_title(name)
        ax.set_xlabel("phase noise (mm, 1 sigma)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("RMS error (deg)")
    axes[0].legend(fontsize=8)
    fig.suptitle("Single-antenna vector-phase attitude (EKF), non-symmetric patch, platform rotating slowly")
    path.write_bytes(figure_png(fig))


def batch_check(seeds: int):
    from gnssatt.vector_phase.antenna import AsymmetricPatch
    from gnssatt.vector_phase.batch import batch_solve

    return _stats(batch_solve, AsymmetricPatch(), 8, 0.1, max(seeds, 16), 20, 1)


def _sd_windup(truth_dir: Path, first: str, second: str) -> float:
    def load(a):
        return {(r["time_gps"], r["sat"]): float(r["windup_cyc"])
                for r in csv.DictReader(open(truth_dir / f"observations_{a}.csv"))}
    a, b = load(first), load(second)
    d = np.array([b[k] - a[k] for k in set(a) & set(b)])
    return float(np.max(np.abs(d - np.round(d))))


def attitude_recheck(minutes: float):
    """{variant: (max |SD wind-up| cycles, fixed fraction, RMS rotation error over fixed epochs deg, yaw/pitch/roll
    error std over fixed epochs deg, epochs)} and the largest per-epoch attitude difference between the two runs
    over the epochs fixed in both (deg)."""
    from bench.bench_attitude import CLEAN, files_of
    from gnssatt.attitude.api import solve
    from gnssatt.attitude.settings import AttitudeSettings
    from gnssatt.attitude.truth import attitude_errors_deg
    from gnssatt.gnss.rotations import attitude_error_deg
    from gnssatt.sim import simulate_set

    out, sols = {}, []
    with tempfile.TemporaryDirectory() as tmp:
        for label, extra in (("Wu wind-up (default)", {}), ("asymmetric patch wind-up", {"windup_antenna": ANTENNA})):
            s = simulate_set("earth-pointing", Path(tmp) / label[:4], seed=0, duration_s=minutes * 60.0,
                             **CLEAN, **extra)
            sd = max(_sd_windup(s.truth_dir, "GPS-2", b) for b in ("GPS-0", "GPS-1"))
            sol = solve([p for _, _, p in files_of(s.dir)], settings=AttitudeSettings.preset("seed000"))
            ang, de = attitude_errors_deg(s.dir, sol)
            fx = np.asarray(sol.att_fixed, bool)
            out[label] = (sd, float(fx.mean()), float(np.sqrt(np.mean(ang[fx] ** 2))), np.std(de[fx], axis=0),
                          len(ang))
            sols.append(sol)
            print(f"  {label}: max SD wind-up {sd:.2e} cyc, fixed {fx.mean():.3f}, rms error fixed "
                  f"{out[label][2]:.4f} deg", flush=True)
    a, b = sols
    common, ia, ib = np.intersect1d(a.att_epochs, b.att_epochs, return_indices=True)
    both = np.asarray(a.att_fixed, bool)[ia] & np.asarray(b.att_fixed, bool)[ib]
    diff = attitude_error_deg(a.q_body_from_ecef[ia][both], b.q_body_from_ecef[ib][both])
    return out, float(diff.max()) if diff.size else float("nan")


def _load(loads) -> str:
    return "load average (1 min) " + " -> ".join(f"{v:.1f}" for v in loads) + " (start -> end)"


def report(out, batch, seeds, epochs, seconds, loads, extra_args: str = "") -> str:
    start = ("start-hypothesis bank (default)" if "--rate-step" not in extra_args
             else "one filter from zero rate (no start hypotheses)")
    lines = [f"Machine: {machine_line()}, {_load(loads)}. Command: `OPENBLAS_NUM_THREADS=1 .venv/bin/python "
             f"bench/bench_vector_phase.py --seeds {seeds} --epochs {epochs}{extra_args} --write` "
             f"({seconds:.0f} s, one run).",
             "", f"EKF ({start}) from the known initial state, non-symmetric patch (asymmetry {ANTENNA['asymmetry']}, harmonic "
             f"{ANTENNA['harmonic']}), {seeds} seeds x {epochs} s at 1 Hz, statistics after the first {SKIP_S} s. "
             "Figure: docs/figures/vector_phase_accuracy.png.", "",
             "| satellites | phase noise (mm) | RMS error yaw / pitch / roll (deg) | RMS error/sigma yaw / pitch / roll |",
             "|---|---|---|---|"]
    for (n, mm), (rms, ratio, _) in out.items():
        lines.append(f"| {n} | {mm:.1f} | {' / '.join(f'{v:.2f}' for v in rms)} | "
                     f"{' / '.join(f'{v:.2f}' for v in ratio)} |")
    if batch is None:
        return "\n".join(lines)
    lines += ["", f"Batch (epoch-wise) estimator, 8 satellites, 0.1 mm, 16 seeds x 20 s: RMS error "
              f"{' / '.join(f'{v:.2f}' for v in batch[0])} deg, error/sigma {' / '.join(f'{v:.2f}' for v in batch[1])}."]
    return "\n".join(lines)


def recheck_report(recheck, minutes: float, seconds: float) -> str:
    rows, max_diff = recheck
    lines = [f"Machine: {machine_line()}. Command: `OPENBLAS_NUM_THREADS=1 .venv/bin/python "
             f"bench/bench_vector_phase.py --recheck-only --minutes {minutes:g} --write` ({seconds:.0f} s, one run).",
             "", f"Attitude job (preset seed000) on the first {minutes:g} min of the clean earth-pointing pass (seed 0; "
             "no PCV, PCO, multipath), with the simulator's default wind-up (Wu) and with every antenna's wind-up "
             f"that of the asymmetric patch {ANTENNA} (option windup_antenna, seed 003 eq. 32). Errors over the "
             "epochs with every baseline fixed.", "",
             "| simulated wind-up | max single-difference wind-up (cycles) | fixed epochs | RMS rotation error, "
             "fixed (deg) | std yaw / pitch / roll, fixed (deg) | epochs |", "|---|---|---|---|---|---|"]
    for label, (sd, fixed, rms, std, n) in rows.items():
        lines.append(f"| {label} | {sd:.1e} | {fixed:.3f} | {rms:.4f} | {' / '.join(f'{v:.4f}' for v in std)} "
                     f"| {n} |")
    lines += ["", f"Largest attitude difference between the two runs over the epochs fixed in both: {max_diff:.2e} deg."]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--epochs", type=int, default=180)
    ap.add_argument("--minutes", type=float, default=20.0, help="length of the attitude re-check pass")
    ap.add_argument("--recheck-only", action="store_true", help="only the attitude job re-check (its own section)")
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--rate-step", type=float, default=None,
                    help="EKF start-hypothesis spacing (deg/s); 0: one filter from zero rate (own section)")
    ap.add_argument("--sats", type=int, nargs="+", default=list(N_SATS))
    a = ap.parse_args()
    t0 = time.perf_counter()
    loads = [os.getloadavg()[0]]
    if a.recheck_only:
        text = recheck_report(attitude_recheck(a.minutes), a.minutes, time.perf_counter() - t0)
        print(text)
        if a.write:
            replace_section(ROOT / "docs" / "BENCHMARKS.md", "Vector-phase: attitude job with a real antenna's "
                            "wind-up", text)
        return
    out = grid(a.seeds, a.epochs, a.rate_step, tuple(a.sats))
    if a.rate_step is not None:
        extra = f" --rate-step {a.rate_step:g} --sats {' '.join(map(str, a.sats))}"
        text = report(out, None, a.seeds, a.epochs, time.perf_counter() - t0, loads + [os.getloadavg()[0]], extra)
        print(text)
        if a.write:
            replace_section(ROOT / "docs" / "BENCHMARKS.md", "Vector-phase: one filter from zero rate", text)
        return
    batch = batch_check(a.seeds)
    text = report(out, batch, a.seeds, a.epochs, time.perf_counter() - t0, loads + [os.getloadavg()[0]])
    print(text)
    if a.write:
        plot(out, ROOT / "docs" / "figures" / "vector_phase_accuracy.png")
        replace_section(ROOT / "docs" / "BENCHMARKS.md", "Vector-phase single-antenna attitude", text)


if __name__ == "__main__":
    main()
