"""`baseline_update` "rigid" against "additive" (gnssatt/attitude/rigid_update.py) on seed 000 Fig. 6's two slews
(bench_attitude.SLEWS, clean, simulator seeds 0-7) and optionally the 106-minute clean / slew passes of
bench_attitude_lengths.py: attitude fix rate from the first fixed epoch, fix_lost events, max error over the fixed
epochs from the first one, max after its first 30 s, 95th percentile; dynamic mode, four settings: Table 1 forward
and adaptive_omega_noise forward ("all phases"), the preset seed000 with the adaptive noise (the tests' setting), and
smoother_adaptive_noise ("all phases"). Print only (tab-separated, one line per pass, seed and setting).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_attitude_rigid_slews.py [--seeds 0,1,2,3,4,5,6,7] [--passes]
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

from bench.bench_attitude import CLEAN, SLEWS, files_of  # noqa: E402

CFGS = {"Table 1 forward": ("all-phases", {}), "adaptive forward": ("all-phases", {"adaptive_omega_noise": True}),
        "seed000 adaptive": ("seed000", {"adaptive": {"enabled": True}}),
        "smoother_adaptive_noise": ("all-phases", {"smoother": True, "smoother_adaptive_noise": True})}


def figures(d: Path, inputs, preset: str, cfg: dict, update: str) -> str:
    """Fix rate from the first fixed epoch, fix_lost count, max / max after 30 s / p95 error (deg), CPU s."""
    from gnssatt.attitude.process import process
    from gnssatt.attitude.settings import AttitudeSettings
    from gnssatt.attitude.truth import attitude_errors_deg

    c0 = time.process_time()
    sol = process(inputs, AttitudeSettings.preset(preset, mode="dynamic", baseline_update=update, **cfg))
    ang, _ = attitude_errors_deg(d, sol)
    fi = np.flatnonzero(sol.att_fixed)
    t = np.asarray(sol.pobs.time - sol.pobs.time[0], float)[sol.att_epochs]
    late = fi[t[fi] > t[fi[0]] + 30.0]
    return (f"{update}: fix rate {sol.att_fixed[fi[0]:].mean():.4f} lost {sol.summary['events'].get('fix_lost', 0)} "
            f"max {ang[fi].max():.3f} late {ang[late].max():.3f} p95 {np.percentile(ang[fi], 95):.3f} "
            f"cpu {time.process_time() - c0:.1f}")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", default="0,1,2,3,4,5,6,7")
    ap.add_argument("--passes", action="store_true", help="also the 106-minute clean and slew passes")
    args = ap.parse_args()
    from gnssatt.attitude.process import load_inputs
    from gnssatt.sim import simulate_scenario

    with tempfile.TemporaryDirectory() as tmp:
        runs = [(label, seed, "slew", {**over, **CLEAN}) for label, over in SLEWS.items()
                for seed in map(int, args.seeds.split(","))]
        if args.passes:
            from bench.bench_attitude_lengths import PASSES, SEED
            runs += [(f"106-min {p}", SEED, PASSES[p][0], {"duration_s": 106 * 60.0, **PASSES[p][1]})
                     for p in ("clean", "slew")]
        for i, (label, seed, scenario, over) in enumerate(runs):
            d = Path(tmp) / f"run{i}"
            simulate_scenario(scenario, d, seed=seed, overrides=over)
            inputs = load_inputs(files_of(d))
            for name, (preset, cfg) in CFGS.items():
                print("\t".join([label, str(seed), name] + [figures(d, inputs, preset, cfg, u)
                                                            for u in ("additive", "rigid")]), flush=True)


if __name__ == "__main__":
    main()
