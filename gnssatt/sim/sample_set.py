"""Small, valid RINEX 3.04 observation files and a platform.json made without the simulator (no real data needed),
for the service tests, the UI tests and the service-load benchmark.

Values are plausible (pseudoranges ~2e7 m, phases in cycles, C/N0 35-50 dB-Hz) but carry no geometry:
these files exercise the service (upload, validation, jobs), not the science (gnssatt.sim.simulate_scenario makes
sets with geometry and truth).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

CODES_GPS = ["C1C", "L1C", "D1C", "S1C", "C2W", "L2W", "D2W", "S2W"]


def obs_v3_text(marker: str, *, n_epochs: int = 30, interval_s: float = 1.0, sats=("G01", "G05", "G12", "G19"),
                start=(2024, 6, 24, 8, 20, 0.0), seed: int = 0, lli_every: int = 0) -> str:
    rng = np.random.default_rng(seed)
    y, mo, d, h, mi, s = start
    head = [
        f"{'3.04':>9}{'':11}{'OBSERVATION DATA':<20}{'G (GPS)':<20}RINEX VERSION / TYPE",
        f"{'gnssatt-tests':<20}{'gnssatt':<20}{'20260101 000000 UTC':<20}PGM / RUN BY / DATE",
        f"{marker:<60}MARKER NAME",
        f"{'':<20}{'TEST RECEIVER':<20}{'1.0':<20}REC # / TYPE / VERS",
        f"{'':<20}{'TEST ANTENNA':<20}{'':<20}ANT # / TYPE",
        f"{-3976219.5082:14.4f}{3382372.5671:14.4f}{3652512.9849:14.4f}{'':18}APPROX POSITION XYZ",
        f"{0.0:14.4f}{0.0:14.4f}{0.0:14.4f}{'':18}ANTENNA: DELTA H/E/N",
        (f"G{len(CODES_GPS):5d} " + " ".join(CODES_GPS)).ljust(60) + "SYS / # / OBS TYPES",
        f"{interval_s:10.3f}{'':50}INTERVAL",
        f"{y:6d}{mo:6d}{d:6d}{h:6d}{mi:6d}{s:13.7f}{'':5}{'GPS':<3}{'':9}TIME OF FIRST OBS",
        f"{'':60}END OF HEADER",
    ]
    lines = list(head)
    base = {sat: rng.uniform(2.0e7, 2.5e7) for sat in sats}
    for k in range(n_epochs):
        sec = s + k * interval_s
        mm, ss = mi + int(sec // 60), sec % 60
        hh, mm = h + mm // 60, mm % 60
        lines.append(f"> {y:4d} {mo:02d} {d:02d} {hh:02d} {mm:02d}{ss:11.7f}  0{len(sats):3d}")
        for sat in sats:
            rho = base[sat] + 500.0 * k + rng.normal(0, 0.3)
            vals = [rho, rho / 0.19029367, -2600.0, 45.0 + rng.normal(0, 2),
                    rho + 3.0, rho / 0.24421021, -2000.0, 38.0 + rng.normal(0, 2)]
            rec = sat
            for i, v in enumerate(vals):
                lli = "1" if (lli_every and i == 1 and k % lli_every == 0 and k) else " "
                rec += f"{v:14.3f}{lli} "
            lines.append(rec.rstrip())
    return "\n".join(lines) + "\n"


def platform_doc(antennas=("GPS-2", "GPS-0", "GPS-1"), files: dict | None = None) -> dict:
    positions = {"GPS-2": [0.0, 0.0, 0.0], "GPS-0": [1.04653, -0.07191, 0.0], "GPS-1": [0.0, 1.13969, 0.0]}
    doc = {"name": "CASSIOPE-like", "kind": "spacecraft",
           "antennas": {a: {"position_m": positions.get(a, [0.5, 0.5, 0.0]), "boresight": [0, 0, -1]}
                        for a in antennas},
           "master": antennas[0]}
    if files is not None:
        doc["observation_files"] = files
    return doc


def write_sample_set(out: Path, *, n_epochs: int = 30, antennas=("GPS-2", "GPS-0", "GPS-1")) -> list[Path]:
    """Three small RINEX 3.04 files (MARKER NAME = antenna id) and platform.json; returns the paths."""
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for i, ant in enumerate(antennas):
        p = out / f"{ant}.rnx"
        p.write_text(obs_v3_text(ant, n_epochs=n_epochs, seed=i, lli_every=10))
        paths.append(p)
    plat = out / "platform.json"
    plat.write_text(json.dumps(platform_doc(antennas), indent=2))
    paths.append(plat)
    return paths
