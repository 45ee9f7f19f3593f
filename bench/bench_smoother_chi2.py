"""Smoother chi-square from the first fixed epoch (issue 21 item 7) on the four 106-minute passes of
bench_attitude_lengths.py, for any simulator seed: per pass and run the wrong integers, the yaw / pitch / roll error
std over fixed epochs (the estimates: a covariance change must leave them as they are), the tilt chi-square per
degree of freedom ((pitch / sigma)^2 + (roll / sigma)^2) / 2 over every fixed epoch from the first one, the same with
the pass mean error removed (what a constant error contributes), the pitch / roll mean error, the antenna
consider term of summary.json (antenna_consider: median sigmas) and the pass mean error over it, squared, per dof
(one draw of the constant error: its mean over seeds is 1 for an honest consider term).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_smoother_chi2.py [--passes clean,realistic,hard,slew]
        [--seed 0] [--runs kinematic,forward,forward-adaptive,plain,adaptive,acceleration] [--sets DIR (keep the simulated sets)]

Every run also as NAME-vce: multipath_adaptive_method "autocovariance" (gnssatt/attitude/multipath_vce.py), and
NAME-vce1: that with multipath_correlation_factor 1.

Prints a markdown table; writes nothing into docs/BENCHMARKS.md (its section is hand-written).
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

from bench._report import machine_line  # noqa: E402
from bench.bench_attitude import files_of  # noqa: E402

RUNS = {"kinematic": {"mode": "kinematic"}, "forward": {}, "forward-adaptive": {"adaptive_omega_noise": True}, "plain": {"smoother": True},
        "adaptive": {"smoother": True, "smoother_adaptive_noise": True},
        "acceleration": {"smoother": True, "smoother_adaptive_noise": True, "angular_acceleration_state": True},
        "adaptive-em": {"smoother": True, "smoother_adaptive_noise": True, "smoother_noise_em_iterations": 4},
        "acceleration-em": {"smoother": True, "smoother_adaptive_noise": True, "angular_acceleration_state": True,
                            "smoother_noise_em_iterations": 4}}
#: the same runs with the multipath scale from the residuals' lag-1 autocovariance (gnssatt.attitude.multipath_vce)
VCE = {"multipath_adaptive_method": "autocovariance"}
#: and with the time-correlation factor 1 (the lag-1 scale is the whole correlated variance; docs/attitude.md)
VCE1 = {**VCE, "multipath_correlation_factor": 1.0}
RUNS.update({f"{name}-{tag}": {**cfg, **extra} for name, cfg in list(RUNS.items())
             for tag, extra in (("vce", VCE), ("vce1", VCE1))})


def chi2_row(d: Path, inputs, cfg: dict) -> dict:
    """Figures of one run (module doc)."""
    from gnssatt.attitude.process import process
    from gnssatt.attitude.settings import ALL_PHASES, AttitudeSettings
    from gnssatt.attitude.truth import attitude_errors_deg, score_fixes

    t = time.process_time()
    sol = process(inputs, AttitudeSettings.preset("seed000", **{**ALL_PHASES, "mode": "dynamic", **cfg}))
    cpu = time.process_time() - t
    _, de = attitude_errors_deg(d, sol)
    fi = np.flatnonzero(sol.att_fixed)
    s = sol.sigma_euler_deg[fi, 1:3]
    e = de[fi, 1:3]
    chi = ((e / s) ** 2).sum(1).mean() / 2
    chi_c = (((e - e.mean(0)) / s) ** 2).sum(1).mean() / 2
    sc0 = sol.sigma_consider_euler_deg
    s0 = np.sqrt(s ** 2 - (sc0[fi, 1:3] ** 2 if sc0 is not None else 0.0))
    chi0 = ((e / s0) ** 2).sum(1).mean() / 2
    sc = score_fixes(sol, d / "truth")
    cons = np.asarray((sol.summary.get("antenna_consider") or {}).get("attitude_sigma_deg_median", [np.nan] * 3),
                      float)
    return {"bias_chi": float(((e.mean(0) / cons[1:]) ** 2).sum() / 2) if np.all(cons[1:] > 0) else float("nan"),
            "consider": np.round(cons, 3).tolist(),
            "wrong": f"{sc['wrong_constraints']} of {sc['constraints']}", "std": de[sol.att_fixed].std(0),
            "chi": chi, "chi_c": chi_c, "chi0": chi0, "mean": e.mean(0), "sigma_med": np.median(s, 0),
            "cpu": cpu, "em": ((sol.summary.get("smoother") or {}).get("process_noise") or {}).get("noise_em")}


def main() -> None:
    from bench.bench_attitude_lengths import PASSES, simulated_pass
    from gnssatt.attitude.process import load_inputs

    ap = argparse.ArgumentParser()
    ap.add_argument("--passes", default=",".join(PASSES))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--runs", default="adaptive,acceleration")
    ap.add_argument("--minutes", type=float, default=106.0)
    ap.add_argument("--sets", default=None, help="folder to keep (and reuse) the simulated sets")
    args = ap.parse_args()
    print(f"Machine: {machine_line()}. Seed {args.seed}, {args.minutes:.0f} min.")
    print("| pass | run | wrong integers | std yaw / pitch / roll deg | chi2/dof | without the consider term | "
          "chi2/dof, mean removed | mean pitch / roll deg | median sigma pitch / roll deg | "
          "antenna consider yaw / pitch / roll deg | (mean / consider)^2 per dof | CPU s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(args.sets) if args.sets else Path(tmp)
        for label in args.passes.split(","):
            d = simulated_pass(base, label, args.seed, args.minutes)
            inputs = load_inputs(files_of(d))
            for name in args.runs.split(","):
                r = chi2_row(d, inputs, RUNS[name])
                sd, m, sg = r["std"], r["mean"], r["sigma_med"]
                print(f"| {label} | {name} | {r['wrong']} | {sd[0]:.4f} / {sd[1]:.4f} / {sd[2]:.4f} | {r['chi']:.2f} | "
                      f"{r['chi0']:.2f} | {r['chi_c']:.2f} | {m[0]:+.3f} / {m[1]:+.3f} | {sg[0]:.3f} / {sg[1]:.3f} | "
                      f"{r['consider']} | {r['bias_chi']:.2f} | {r['cpu']:.0f} |", flush=True)
                if r["em"]:
                    its = r["em"]["iterations"]
                    print("    noise_em: " + "; ".join(f"s {h['floor_scale']:.3f} r {h['ratio']:.3f} "
                                                       f"n_eff {h['effective_links']:.0f}" for h in its)
                          + f" -> floor x {r['em']['floor_scale']:.3f}", flush=True)


if __name__ == "__main__":
    main()
