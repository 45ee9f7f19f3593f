"""Readers of the sensor logs of CONVENTIONS.md "Inputs: sensor logs": accelerometer.csv, magnetometer.csv,
gyro.csv, velocity.csv (see docs/formats/inertial_csv.md), each refused line by line with a ParseError that
names the file, the line, the column and what was expected.

Checks: the header has the kind's columns (time_gps, or gps_week and gps_sow, then the three value
columns; optional columns after them); every row has as many fields as the header; every value is a finite
number; times strictly increase (unsorted or duplicate rows are refused); every sample's magnitude lies in
the kind's physical range, so values in the wrong unit by orders of magnitude (mg or cm/s^2 for m/s^2, uT,
gauss or pT for nT, deg/s for rad/s, cm/s or km/s for m/s) are refused with the likely unit named.
Implements: CONVENTIONS.md "Inputs: sensor logs" and "Time"; ParseError of gnssatt.gnss.io.errors.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.time import GpsTime


@dataclass(frozen=True)
class SensorSpec:
    """Columns of one kind and the range of a sample's magnitude in its unit (min_norm, max_norm), with the
    units a value outside it most likely was written in."""

    kind: str
    columns: tuple
    optional: tuple
    unit: str
    min_norm: float
    max_norm: float
    hint_low: str
    hint_high: str


SPECS = {
    # specific force: 0 (free fall) to 50 g (beyond any vehicle; a launcher stays below 10 g); 9.81 m/s^2 is
    # 1000 mg or 981 cm/s^2, both above 500
    "accelerometer": SensorSpec("accelerometer", ("ax_m_s2", "ay_m_s2", "az_m_s2"), ("temperature_c",), "m/s^2",
                                0.0, 500.0, "", "mg or cm/s^2"),
    # the Earth's main field is 20-70 uT at the surface and > 5 uT out to GEO; 1000 nT would be 1 uT
    "magnetometer": SensorSpec("magnetometer", ("bx_nT", "by_nT", "bz_nT"), ("temperature_c",), "nT",
                               1000.0, 200000.0, "uT, gauss or tesla", "pT"),
    # 20 rad/s = 1146 deg/s, beyond a tumbling cubesat's and a vehicle's rates
    "gyro": SensorSpec("gyro", ("wx_rad_s", "wy_rad_s", "wz_rad_s"), ("temperature_c",), "rad/s", 0.0, 20.0,
                       "", "deg/s"),
    # up to escape velocity at LEO (11.2 km/s) plus the Earth's rotation
    "velocity": SensorSpec("velocity", ("vx_ecef_m_s", "vy_ecef_m_s", "vz_ecef_m_s"),
                           ("sigma_m_s", "x_ecef_m", "y_ecef_m", "z_ecef_m"), "m/s", 0.0, 12000.0, "",
                           "cm/s or mm/s"),
}

_ISO = re.compile(r"^(\d{4})-(\d{2})-(\d{2})[T ](\d{2}):(\d{2}):(\d{2}(?:\.\d*)?)$")


@dataclass
class SensorLog:
    """One CSV: time (n,) GpsTime, t_s (n,) seconds since time[0], values (n, 3) in the kind's unit, extra
    {column: (n,)} of the optional columns present, name (as the user knows the file), line_no (n,) of each row."""

    name: str
    kind: str
    time: GpsTime
    t_s: np.ndarray
    values: np.ndarray
    extra: dict = field(default_factory=dict)
    line_no: np.ndarray = field(default_factory=lambda: np.zeros(0, int))


def _layout(spec: SensorSpec) -> str:
    return "time_gps," + ",".join(spec.columns) + " (or gps_week,gps_sow instead of time_gps; optional " + \
        ",".join(spec.optional) + " after them)"


def _char_col(line: str, index: int) -> int:
    """1-based character column where field `index` (0-based) of a comma-separated line starts."""
    pos = 0
    for _ in range(index):
        nxt = line.find(",", pos)
        if nxt < 0:
            return len(line) + 1
        pos = nxt + 1
    return pos + 1


def _header(spec: SensorSpec, line: str, name: str) -> tuple[list[str], list[int], list[int]]:
    """(header, time column indices, value column indices) or ParseError on line 1."""
    head = [h.strip() for h in line.split(",")]
    time_cols = ["time_gps"] if head[:1] == ["time_gps"] else (["gps_week", "gps_sow"]
                                                              if head[:2] == ["gps_week", "gps_sow"] else None)
    if time_cols is None:
        raise ParseError(name, 1, "a header line " + _layout(spec), line, column=1)
    k = len(time_cols)
    for j, col in enumerate(spec.columns):
        if len(head) <= k + j or head[k + j] != col:
            raise ParseError(name, 1, f"column {k + j + 1} named {col!r} ({spec.kind}, {spec.unit}): header "
                             + _layout(spec), line, column=_char_col(line, k + j))
    for j, col in enumerate(head[k + 3:], start=k + 3):
        if col not in spec.optional:
            raise ParseError(name, 1, f"optional columns {', '.join(spec.optional)} only: header " + _layout(spec),
                             line, column=_char_col(line, j))
    return head, list(range(k)), list(range(k, k + 3))


def _time_fields(fields: list[str], n_time: int, name: str, ln: int, line: str) -> tuple:
    """(year, month, day, hour, minute, second) of an ISO time, or (week, sow) of gps_week,gps_sow."""
    if n_time == 1:
        m = _ISO.match(fields[0].strip())
        t = (*(int(m.group(i)) for i in range(1, 6)), float(m.group(6))) if m else None
        if t is None or not (1 <= t[1] <= 12 and 1 <= t[2] <= 31 and t[3] < 24 and t[4] < 60 and t[5] < 61):
            raise ParseError(name, ln, "time_gps as ISO 8601 GPS time, e.g. 2018-06-06T12:20:00.000 (month 1-12, "
                             "day 1-31, hour 0-23, minute 0-59, second below 61)", line, column=1)
        return t
    try:
        week, sow = int(fields[0]), float(fields[1])
        if week < 0:
            raise ValueError(fields[0])
    except ValueError as exc:
        raise ParseError(name, ln, "gps_week (non-negative integer) and gps_sow (seconds) numbers", line,
                         column=1) from exc
    if not (0 <= sow < 604800.0 and np.isfinite(sow)):
        raise ParseError(name, ln, "gps_sow in [0, 604800)", line, column=_char_col(line, 1))
    return week, sow


def _times(parts: list[tuple], n_time: int) -> GpsTime:
    a = list(zip(*parts))
    if n_time == 1:
        return GpsTime.from_calendar(*(np.array(x) for x in a))
    return GpsTime.from_week_sow(np.array(a[0]), np.array(a[1]))


def read_sensor_csv(source: str | Path | bytes, kind: str, name: str | None = None) -> SensorLog:
    """The sensor log of `kind` ('accelerometer', 'magnetometer', 'gyro', 'velocity') in a CSV file or bytes.

    Raises ParseError(name, line, column, expected, found) on the first malformed line (module docstring).
    """
    spec = SPECS[kind]
    name = name or (Path(source).name if not isinstance(source, bytes) else f"{kind}.csv")
    raw = source if isinstance(source, bytes) else Path(source).read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ParseError(name, None, "UTF-8 text", "binary data") from exc
    lines = text.splitlines()
    if not lines or not lines[0].strip():
        raise ParseError(name, 1, "a header line " + _layout(spec), "an empty file", column=1)
    head, tcols, vcols = _header(spec, lines[0], name)
    n_cols = len(head)
    parts, values, extra, line_nos, texts = [], [], {c: [] for c in head[len(tcols) + 3:]}, [], []
    for ln, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        fields = line.split(",")
        if len(fields) != n_cols:
            raise ParseError(name, ln, f"{n_cols} comma-separated fields as in the header ({','.join(head)})",
                             line, column=_char_col(line, min(len(fields), n_cols)))
        parts.append(_time_fields(fields, len(tcols), name, ln, line))
        row = []
        for j in vcols + list(range(len(tcols) + 3, n_cols)):
            try:
                x = float(fields[j])
            except ValueError:
                x = np.nan
            if not np.isfinite(x):
                raise ParseError(name, ln, f"a finite number in column {head[j]!r}", line, column=_char_col(line, j))
            row.append(x)
        vec = np.array(row[:3])
        norm = float(np.sqrt(vec @ vec))
        if not spec.min_norm <= norm <= spec.max_norm:
            j = vcols[int(np.argmax(np.abs(vec)))]
            hint = spec.hint_low if norm < spec.min_norm else spec.hint_high
            raise ParseError(name, ln, f"{spec.kind} values in {spec.unit} (magnitude {spec.min_norm:g} to "
                             f"{spec.max_norm:g}); this row's magnitude is {norm:.6g}"
                             + (f": written in {hint}?" if hint else ""), line, column=_char_col(line, j))
        values.append(vec)
        for c, x in zip(extra, row[3:]):
            extra[c].append(x)
        line_nos.append(ln)
        texts.append(line)
    if not values:
        raise ParseError(name, 2, "at least one data row after the header", "no data rows", column=1)
    time = _times(parts, len(tcols))
    dt = np.diff(np.asarray(time - time[0], dtype=np.float64))
    bad = np.flatnonzero(dt <= 0.0)
    if len(bad):
        i = int(bad[0]) + 1
        what = "a time later than the previous row's (duplicate time)" if dt[i - 1] == 0.0 else \
            "times in increasing order (this row is earlier than the previous)"
        raise ParseError(name, line_nos[i], what, texts[i], column=1)
    return SensorLog(name, kind, time, np.asarray(time - time[0], dtype=np.float64), np.array(values),
                     {c: np.array(v) for c, v in extra.items()}, np.array(line_nos))
