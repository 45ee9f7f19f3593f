"""Gyro log CSV: `time_gps, wx_rad_s, wy_rad_s, wz_rad_s[, temperature_c]` (or `gps_week, gps_sow` for the time).

Implements: ../shared/CONVENTIONS.md "Inputs: sensor logs" and docs/formats/gyro_csv.md (the sample is the mean
rate over the interval that ends at its time tag). The rows are read by the one sensor-log reader,
gnssatt.gnss.io.sensor_csv (kind "gyro"), whose every refusal is a ParseError naming the file, the line, the
1-based column where the bad cell starts and what was expected there; this module gives the fusion its GyroLog,
recognises a gyro header in a set and writes the simulator's logs.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.gnss.io.sensor_csv import read_sensor_csv
from gnssatt.gnss.time import GpsTime

__all__ = ["GyroLog", "read_gyro_csv", "is_gyro_header", "gyro_csv_text", "RATE_COLUMNS"]

RATE_COLUMNS = ("wx_rad_s", "wy_rad_s", "wz_rad_s")


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


def read_gyro_csv(text: str | bytes, name: str = "gyro.csv") -> GyroLog:
    """Parse a gyro log with the one sensor-log reader (gnssatt.gnss.io.sensor_csv, kind "gyro");
    ParseError(file, line, column, expected, found) on the first malformed line (docs/formats/gyro_csv.md)."""
    raw = text.encode("utf-8") if isinstance(text, str) else text
    log = read_sensor_csv(raw, "gyro", name)
    return GyroLog(log.time, log.values, log.extra.get("temperature_c"), name)


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
