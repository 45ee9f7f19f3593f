"""The epochs around the first fixed epoch of one slew run (issue 21 item 3: why the slews' error peaks there).

Seed 000 Fig. 6's manoeuvres (bench_attitude.SLEWS), clean, one simulator seed, dynamic mode, "all phases",
`smoother_adaptive_noise` + `angular_acceleration_state`. Per fixed epoch from the first one: float ambiguities in
the filter, forward and smoothed pitch / roll error and sigma (deg), smoothed tilt chi-square (2 dof). Two ablations
locate the cause:
  --no-omega-reset  a fix never resets omega (OMEGA_RESET_TURN_DEG raised to 1e9 for the run);
  --run-delay N     the smoother's first all-fixed run starts N epochs after the first fixed epoch (the epochs before
                    stay as filtered): if the smoothed epochs after the delay do not change, the early epochs' data
                    are not what biases them;
  --no-corr-share   the smoother reports its RTS covariance alone (corr_share set to 0: no correlated share of the
                    phase variance kept at its filtered size; gnssatt.attitude.smoother.smooth_filter_result).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_slew_first_fix.py --slew pitch --seed 4 [--run-delay 12]
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

from bench.bench_attitude import CLEAN, SLEWS, files_of  # noqa: E402

SETTINGS = {"smoother": True, "smoother_adaptive_noise": True, "angular_acceleration_state": True}


def _count_floats(n_float: dict):
    """Wrap the filter's output box to record the float ambiguities in the state per epoch into n_float."""
    import gnssatt.attitude.filter as filt

    box = filt.output

    def output(run, ep):
        box(run, ep)
        n_float[ep.k] = int((~run.st.amb_fixed).sum())
    filt.output = output


def _delay_first_run(delay: int) -> None:
    """The smoother's all-fixed runs (smoother.fixed_runs) with the first one starting `delay` epochs later."""
    import gnssatt.attitude.smoother as sm

    runs = sm.fixed_runs

    def fixed_runs(fr):
        fixed_all, start = runs(fr)
        fixed_all = fixed_all.copy()
        fixed_all[:int(np.argmax(fixed_all)) + delay] = False
        start = start | ~fixed_all
        start[1:] |= ~fixed_all[:-1]
        return fixed_all, start
    sm.fixed_runs = fixed_runs


def _no_corr_share() -> None:
    """smooth_filter_result with the recorded correlated share of the phase variance set to 0."""
    import gnssatt.attitude.smoother as sm

    smooth = sm.smooth_filter_result

    def smooth_filter_result(fr, settings=None):
        fr.smoother_data["corr_share"] = np.zeros_like(fr.smoother_data["corr_share"])
        return smooth(fr, settings)
    sm.smooth_filter_result = smooth_filter_result


def epoch_rows(d: Path, n_rows: int, n_float: dict) -> list[str]:
    """Forward and smoothed errors / sigmas per fixed epoch from the first fixed one (module doc)."""
    from gnssatt.attitude.process import load_inputs, process
    from gnssatt.attitude.settings import AttitudeSettings
    from gnssatt.attitude.truth import attitude_errors_deg

    inputs = load_inputs(files_of(d))
    fwd = process(inputs, AttitudeSettings.preset("all-phases", mode="dynamic", angular_acceleration_state=True))
    sol = process(inputs, AttitudeSettings.preset("all-phases", mode="dynamic", **SETTINGS))
    _, de_f = attitude_errors_deg(d, fwd)
    ang, de = attitude_errors_deg(d, sol)
    sig, sig_f = sol.sigma_euler_deg, fwd.sigma_euler_deg
    chi2 = (de[:, 1] / sig[:, 1]) ** 2 + (de[:, 2] / sig[:, 2]) ** 2
    fi = np.flatnonzero(sol.att_fixed)
    t = np.asarray(sol.pobs.time - sol.pobs.time[0], float)[sol.att_epochs]
    out = ["| t s | floats | fwd pitch / roll err (sigma) | smoothed pitch / roll err (sigma) | angle | chi-square |",
           "|---|---|---|---|---|---|"]
    for i in fi[:n_rows]:
        k = int(sol.att_epochs[i])
        out.append(f"| {t[i]:.0f} | {n_float.get(k, -1)} | {de_f[i, 1]:+.3f} ({sig_f[i, 1]:.3f}) / {de_f[i, 2]:+.3f} "
                   f"({sig_f[i, 2]:.3f}) | {de[i, 1]:+.3f} ({sig[i, 1]:.3f}) / {de[i, 2]:+.3f} ({sig[i, 2]:.3f}) | "
                   f"{ang[i]:.3f} | {chi2[i]:.2f} |")
    out.append(f"chi-square over the first 10 fixed epochs {chi2[fi[:10]].mean():.2f}, "
               f"rest {chi2[fi[10:]].mean():.2f}; max angle {ang[fi].max():.3f} deg")
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--slew", choices=("pitch", "yaw"), default="pitch")
    ap.add_argument("--seed", type=int, default=4)
    ap.add_argument("--rows", type=int, default=30)
    ap.add_argument("--no-omega-reset", action="store_true")
    ap.add_argument("--run-delay", type=int, default=0)
    ap.add_argument("--no-corr-share", action="store_true")
    args = ap.parse_args()
    from gnssatt.sim import simulate_scenario

    n_float: dict = {}
    _count_floats(n_float)
    if args.no_omega_reset:
        import gnssatt.attitude.boxes.ambiguity_resolution as ar
        ar.OMEGA_RESET_TURN_DEG = 1e9
    if args.run_delay:
        _delay_first_run(args.run_delay)
    if args.no_corr_share:
        _no_corr_share()
    label = next(k for k in SLEWS if k.startswith(args.slew))
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp) / "slew"
        simulate_scenario("slew", d, seed=args.seed, overrides={**SLEWS[label], **CLEAN})
        print(f"{label}, seed {args.seed}, omega reset {'off' if args.no_omega_reset else 'on'}, "
              f"first run delayed by {args.run_delay} epochs, corr_share {'0' if args.no_corr_share else 'kept'}")
        print("\n".join(epoch_rows(d, args.rows, n_float)))


if __name__ == "__main__":
    main()
