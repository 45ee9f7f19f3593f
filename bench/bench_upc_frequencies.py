"""UPC1-UPC2 (37.95 m, real, 1 h at 1 Hz): the fixed baseline per frequency, against the set README's reference.

The reference (the gAGE/UPC tutorial's coordinates, written as the files' APPROX POSITIONs) is a point-to-point
vector; the files' antennas are "Unknown" (no ANTEX type), so the phase-centre offsets and variations of the two
antennas cannot be applied. If those antennas differ, the L1 and L2 phase-centre baselines differ from each other
and from the reference: this bench measures by how much (docs/attitude.md, "Limits", UPC).

    python -m bench.bench_upc_frequencies [--epochs N]

Prints, per signal set (L1+L2, L1, L2), the fixed fraction and the median length, azimuth and elevation over the
fixed epochs, and each median's difference from the reference. Needs ../shared/data/real.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import tempfile
from pathlib import Path

import numpy as np

from bench.real_sets import REAL_DATA_DIR, UPC, UPC_ENU_M, UPC_PLATFORM, upc_files
from gnssatt.attitude.process import load_inputs, process
from gnssatt.attitude.settings import AttitudeSettings

REF_LENGTH_M = float(np.linalg.norm(UPC_ENU_M))
REF_AZIMUTH_DEG = float(np.degrees(np.arctan2(UPC_ENU_M[0], UPC_ENU_M[1])) % 360.0)
REF_ELEVATION_DEG = float(np.degrees(np.arctan2(UPC_ENU_M[2], np.hypot(UPC_ENU_M[0], UPC_ENU_M[1]))))
SIGNAL_SETS = (["L1", "L2"], ["L1"], ["L2"])


def _first_epochs(obs, n: int):
    return dataclasses.replace(obs, time=obs.time[:n], epoch_flag=obs.epoch_flag[:n],
                               clock_offset_s=obs.clock_offset_s[:n], values=obs.values[:n], lli=obs.lli[:n],
                               ssi=obs.ssi[:n], events=[])


def run(n_epochs: int) -> list[dict]:
    """One kinematic seed000 run per signal set over the first n_epochs epochs: medians over fixed epochs."""
    tmp = Path(tempfile.mkdtemp())
    plat = tmp / "platform.json"
    plat.write_text(json.dumps(UPC_PLATFORM))
    rows = []
    for sigs in SIGNAL_SETS:
        inputs = load_inputs(upc_files(REAL_DATA_DIR / UPC, plat))
        inputs.obs = {a: _first_epochs(o, n_epochs) for a, o in inputs.obs.items()}
        bt = process(inputs, AttitudeSettings.preset("seed000", mode="kinematic", signals=sigs)).baseline_table
        fixed = np.asarray(bt["fixed"], dtype=bool)
        rows.append({"signals": "+".join(sigs), "fixed": f"{fixed.sum()}/{fixed.size}",
                     "length_m": float(np.median(bt["length_m"][fixed])),
                     "azimuth_deg": float(np.median(bt["azimuth_deg"][fixed])),
                     "elevation_deg": float(np.median(bt["elevation_deg"][fixed]))})
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--epochs", type=int, default=3600, help="epochs from the start (1 Hz; default the hour)")
    args = ap.parse_args(argv)
    print(f"reference: length {REF_LENGTH_M:.4f} m, azimuth {REF_AZIMUTH_DEG:.3f} deg, "
          f"elevation {REF_ELEVATION_DEG:.3f} deg")
    print("| signals | fixed | length m (- ref, mm) | azimuth deg (- ref) | elevation deg (- ref) |")
    print("|---|---|---|---|---|")
    for r in run(args.epochs):
        print(f"| {r['signals']} | {r['fixed']} | {r['length_m']:.4f} ({(r['length_m'] - REF_LENGTH_M) * 1e3:+.1f}) "
              f"| {r['azimuth_deg']:.4f} ({r['azimuth_deg'] - REF_AZIMUTH_DEG:+.4f}) "
              f"| {r['elevation_deg']:.3f} ({r['elevation_deg'] - REF_ELEVATION_DEG:+.3f}) |")


if __name__ == "__main__":
    main()
