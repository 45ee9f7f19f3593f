"""GPS fault injection into simulated RINEX 3 observation files (text level, so any reader sees the fault).

Two fault modes of seed 002 sec. 4: a phase fault on one satellite of one antenna (a jump of `size_cyc` L1
cycles held over the window, or a ramp reaching it at the window's end: "temporary abnormal interference on a
single GPS satellite"), and an outage of all satellites on all antennas ("complete out track from the whole
GPS constellation": the epochs are left out of every file, as a receiver that lost lock on everything writes
nothing). Table 1: a fault of 35 % of the L1 wavelength every 60 s on average.
Implements: RINEX 3.04 sec. 5.1 / Table A3 (epoch records "> yyyy mm dd hh mm ss.sssssss  flag n", observation
fields F14.3 + LLI + SSI, 16 columns each, after the 3-character satellite id).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gnssatt.gnss.time import GpsTime

__all__ = ["PhaseFault", "inject_phase_faults", "inject_outage", "fault_schedule"]


@dataclass(frozen=True)
class PhaseFault:
    """One phase fault: antenna id, satellite (e.g. G07), window [start, end] GPS seconds, size (L1 cycles)."""

    antenna: str
    sat: str
    start_gps_s: float
    end_gps_s: float
    size_cyc: float
    kind: str = "jump"                       # jump | ramp

    def offset_cyc(self, t_gps_s: float) -> float:
        """The phase added at time t (0 outside the window)."""
        if not self.start_gps_s <= t_gps_s <= self.end_gps_s:
            return 0.0
        if self.kind == "ramp" and self.end_gps_s > self.start_gps_s:
            return self.size_cyc * (t_gps_s - self.start_gps_s) / (self.end_gps_s - self.start_gps_s)
        return self.size_cyc


def _epoch_seconds(line: str) -> float:
    y, mo, d, h, mi = (int(line[k:k + w]) for k, w in ((2, 4), (7, 2), (10, 2), (13, 2), (16, 2)))
    sec = float(line[18:29])
    t = GpsTime.from_calendar(y, mo, d, h, mi, sec)
    return float(t.s) + float(t.frac)


def _l1_index(lines: list[str], code: str = "L1C") -> tuple[int, int]:
    """(index of the first data line, position of `code` among the GPS observation types)."""
    types: list[str] = []
    collecting = False
    for i, ln in enumerate(lines):
        label = ln[60:80].strip()
        if label == "SYS / # / OBS TYPES":
            if ln[0] == "G":
                types = ln[7:58].split()
                collecting = True
            elif ln[0] == " " and collecting:
                types += ln[7:58].split()
            else:
                collecting = False
        if label == "END OF HEADER":
            if code not in types:
                raise ValueError(f"no {code} among the GPS observation types {types}")
            return i + 1, types.index(code)
    raise ValueError("no END OF HEADER")


def inject_phase_faults(obs_path: str | Path, faults: list[PhaseFault], code: str = "L1C") -> int:
    """Add each fault's phase offset to `code` of its satellite in the file (in place); number of values changed."""
    path = Path(obs_path)
    lines = path.read_text().split("\n")
    start, k = _l1_index(lines, code)
    col = 3 + 16 * k
    by_sat: dict[str, list[PhaseFault]] = {}
    for f in faults:
        by_sat.setdefault(f.sat, []).append(f)
    changed = 0
    t = None
    for i in range(start, len(lines)):
        ln = lines[i]
        if ln.startswith(">"):
            t = _epoch_seconds(ln)
            continue
        sat = ln[:3]
        if t is None or sat not in by_sat:
            continue
        off = sum(f.offset_cyc(t) for f in by_sat[sat])
        field_txt = ln[col:col + 14]
        if off == 0.0 or not field_txt.strip():
            continue
        value = float(field_txt) + off
        lines[i] = ln[:col] + f"{value:14.3f}" + ln[col + 14:]
        changed += 1
    path.write_text("\n".join(lines))
    return changed


def inject_outage(obs_paths: list[str | Path], start_gps_s: float, end_gps_s: float) -> int:
    """Leave the epochs in [start, end] out of every file (in place); number of epochs removed per file."""
    removed = 0
    for p in obs_paths:
        path = Path(p)
        lines = path.read_text().split("\n")
        start, _ = _l1_index(lines)
        out = lines[:start]
        keep = True
        n = 0
        for ln in lines[start:]:
            if ln.startswith(">"):
                keep = not (start_gps_s <= _epoch_seconds(ln) <= end_gps_s)
                n += 0 if keep else 1
            if keep:
                out.append(ln)
        path.write_text("\n".join(out))
        removed = n
    return removed


def fault_schedule(rng: np.random.Generator, epochs_gps_s: np.ndarray, visible: dict, antennas: list[str],
                   mean_interval_s: float = 60.0, size_cyc: float = 0.35, first_s: float = 120.0,
                   skip: list[tuple[float, float]] | None = None) -> list[PhaseFault]:
    """Single-epoch phase jumps at intervals of mean_interval_s (+- 20 %), each on a random (antenna, satellite)
    visible at that epoch. visible: epoch GPS second -> list of satellites seen on every antenna. Windows in
    `skip` (GPS seconds) get no fault."""
    faults = []
    t = epochs_gps_s[0] + first_s
    while t <= epochs_gps_s[-1]:
        k = int(np.argmin(np.abs(epochs_gps_s - t)))
        te = float(epochs_gps_s[k])
        sats = visible.get(te, [])
        if sats and not any(a <= te <= b for a, b in (skip or [])):
            faults.append(PhaseFault(antennas[int(rng.integers(len(antennas)))], sats[int(rng.integers(len(sats)))],
                                     te, te, size_cyc))
        t += mean_interval_s * rng.uniform(0.8, 1.2)
    return faults
