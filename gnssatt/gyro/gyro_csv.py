"""Gyro log CSV: `time_gps, wx_rad_s, wy_rad_s, wz_rad_s[, temperature_c]` (or `gps_week, gps_sow` for the time).

Implements: ../shared/CONVENTIONS.md "Inputs: sensor logs" (angular rate of the body relative to inertial space in
sensor axes, rad/s; GPS time ISO 8601 without zone) and docs/formats/gyro_csv.md (the sample is the mean rate over
the interval that ends at its time tag; rows in strictly increasing time). Every malformed line is a ParseError
naming the file, the line, the 1-based column where the bad cell starts and what was expected there.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.time import GpsTime

__all__ = ["GyroLog", "read_gyro_csv", "is_gyro_header", "gyro_csv_text", "RATE_COLUMNS"]

RATE_COLUMNS = ("wx_rad_s", "wy_rad_s", "wz_rad_s")
#: |rate| above this is not a body rate a gyro log holds (about 1150 deg/s; MEMS ranges end near 2000 deg/s)
MAX_RATE_RAD_S = 20.0
_LAYOUT = "time_gps,wx_rad_s,wy_rad_s,wz_rad_s[,temperature_c]  e.g.  2018-06-06T12:20:00.100,1.0e-3,-2.0e-5,3.1e-6"


@dataclass
class GyroLog:
    """One gyro log: time (n,) GpsTime, rate_rad_s (n, 3) in sensor axes, temperature_c (n,) or None, name."""

    time: GpsTime
    rate_rad_s: np.ndarray
    temperature_c: np.ndarray | None
    name: str = "gyro.csv"

    @property
    def interval_s(self) -> float:
        """Median sample interval, s."""
        if len(self.time) < 2:
            return float("nan")
        return float(np.median((self.time[1:] - self.time[:-1])))


def is_gyro_header(first_line: str) -> bool:
    """True when a CSV header line names the gyro columns (used to pick the gyro log out of a set)."""
    cols = {c.strip() for c in first_line.split(",")}
    return set(RATE_COLUMNS) <= cols and ("time_gps" in cols or {"gps_week", "gps_sow"} <= cols)


def _cell_columns(line: str) -> list[int]:
    """1-based character column where each comma-separated cell starts."""
    starts, col = [1], 1
    for ch in line:
        col += 1
        if ch == ",":
            starts.append(col)
    return starts


def _header(name: str, line: str) -> tuple[dict, bool]:
    cols = [c.strip() for c in line.split(",")]
    index = {c: i for i, c in enumerate(cols)}
    if len(index) != len(cols):
        raise ParseError(name, 1, "a header line without repeated column names: " + _LAYOUT, line)
    if not is_gyro_header(line):
        missing = [c for c in ("time_gps",) + RATE_COLUMNS if c not in index]
        raise ParseError(name, 1, f"a header line with columns {_LAYOUT} (missing: {', '.join(missing)})", line)
    return index, "time_gps" in index


def _parse_iso(text: str) -> tuple:
    date, sep, clock = text.partition("T")
    if not sep:
        raise ValueError(text)
    yy, mm, dd = (int(v) for v in date.split("-"))
    h, m, s = clock.split(":")
    t = (yy, mm, dd, int(h), int(m), float(s))
    if not (1 <= mm <= 12 and 1 <= dd <= 31 and 0 <= t[3] < 24 and 0 <= t[4] < 60 and 0 <= t[5] < 61):
        raise ValueError(text)
    return t


def _float_cell(name, line_no, starts, cells, i, what, limit=None) -> float:
    try:
        v = float(cells[i])
    except ValueError:
        v = float("nan")
    if not math.isfinite(v) or (limit is not None and abs(v) > limit):
        bound = f" with |value| <= {limit:g}" if limit is not None else ""
        raise ParseError(name, line_no, f"{what}: a finite number{bound}", cells[i] or "(empty)", column=starts[i])
    return v


def read_gyro_csv(text: str | bytes, name: str = "gyro.csv") -> GyroLog:
    """Parse a gyro log; ParseError(file, line, column, expected) on the first malformed line.

    Checks: a header with the CONVENTIONS columns; per row the number of cells, the time (ISO 8601 GPS time, or
    gps_week integer and gps_sow in [0, 604800)), finite rates of at most MAX_RATE_RAD_S, a finite temperature
    when the column exists (empty allowed: NaN), strictly increasing time.
    """
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise ParseError(name, None, "UTF-8 text", "binary data") from exc
    lines = text.splitlines()
    if not lines or not lines[0].strip():
        raise ParseError(name, 1, "a header line " + _LAYOUT, "empty file")
    index, iso = _header(name, lines[0])
    n_cols = len(lines[0].split(","))
    has_temp = "temperature_c" in index
    rate_idx = [index[c] for c in RATE_COLUMNS]
    keys, rates, temps = [], [], []
    prev = None
    for line_no, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        cells = [c.strip() for c in line.split(",")]
        starts = _cell_columns(line)
        if len(cells) != n_cols:
            col = len(line) + 1 if len(cells) < n_cols else starts[n_cols]     # where a value is missing / extra
            raise ParseError(name, line_no, f"{n_cols} comma-separated values as in the header ({_LAYOUT})",
                             line, column=col)
        if iso:
            i = index["time_gps"]
            try:
                key = _parse_iso(cells[i])
            except (ValueError, IndexError):
                raise ParseError(name, line_no, "time_gps as YYYY-MM-DDTHH:MM:SS.sss (GPS time, no zone)",
                                 cells[i] or "(empty)", column=starts[i]) from None
        else:
            iw, isow = index["gps_week"], index["gps_sow"]
            try:
                week = int(cells[iw])
                if week < 0:
                    raise ValueError
            except ValueError:
                raise ParseError(name, line_no, "gps_week: a non-negative integer", cells[iw] or "(empty)",
                                 column=starts[iw]) from None
            sow = _float_cell(name, line_no, starts, cells, isow, "gps_sow")
            if not 0.0 <= sow < 604800.0:
                raise ParseError(name, line_no, "gps_sow in [0, 604800)", cells[isow], column=starts[isow])
            key = (week, sow)
        w = [_float_cell(name, line_no, starts, cells, i, c, MAX_RATE_RAD_S)
             for i, c in zip(rate_idx, RATE_COLUMNS)]
        temp = float("nan")
        if has_temp and cells[index["temperature_c"]]:
            temp = _float_cell(name, line_no, starts, cells, index["temperature_c"], "temperature_c", 500.0)
        if prev is not None and key <= prev:
            i = index["time_gps"] if iso else index["gps_sow"]
            raise ParseError(name, line_no, "rows in strictly increasing time order", cells[i], column=starts[i])
        prev = key
        keys.append(key)
        rates.append(w)
        temps.append(temp)
    if not keys:
        raise ParseError(name, 2, "at least one data row", "header only")
    if iso:
        cal = list(zip(*keys))
        t = GpsTime.from_calendar(*(np.asarray(c) for c in cal))
    else:
        wk, sw = zip(*keys)
        t = GpsTime.from_week_sow(np.asarray(wk), np.asarray(sw))
    return GyroLog(t, np.asarray(rates, float), np.asarray(temps, float) if has_temp else None, name)


def gyro_csv_text(time: GpsTime, rate_rad_s: np.ndarray, temperature_c: np.ndarray | None = None) -> str:
    """The CSV text of a gyro log (header + one row per sample; rates to 1e-12 rad/s, time to 1 ms)."""
    iso = time.iso(3)
    iso = iso if isinstance(iso, list) else [iso]
    w = np.asarray(rate_rad_s, float)
    head = "time_gps," + ",".join(RATE_COLUMNS) + (",temperature_c" if temperature_c is not None else "")
    if temperature_c is None:
        rows = ["%s,%.12e,%.12e,%.12e" % (t, a, b, c) for t, (a, b, c) in zip(iso, w.tolist())]
    else:
        rows = ["%s,%.12e,%.12e,%.12e,%.2f" % (t, a, b, c, d)
                for t, (a, b, c), d in zip(iso, w.tolist(), np.asarray(temperature_c).tolist())]
    return "\n".join([head] + rows) + "\n"
