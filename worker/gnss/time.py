"""GPS time as a two-part number, and calendar / week-seconds conversions.

Float64 seconds since 1980 resolve only about 0.24 us, which a LEO range rate of ~8 km/s turns into
2 mm, so a time is kept as whole seconds since the GPS epoch (int64) plus a fraction (float64 in [0, 1)).

Implements: GPS time scale and week numbering of IS-GPS-200 sec. 20.3.3.5.2.4 (continuous week count,
no 1024 roll-over here); proleptic Gregorian calendar via the days-from-civil algorithm (H. Hinnant).
Neglects: leap seconds (GPS time has none); UTC conversion lives with the leap-second table.
"""
from __future__ import annotations

import numpy as np

SECONDS_PER_DAY = 86400
SECONDS_PER_WEEK = 604800
# Days from 1970-01-01 to the GPS epoch 1980-01-06.
_GPS_EPOCH_UNIX_DAYS = 3657


def days_from_civil(year, month, day) -> np.ndarray:
    """Days since 1970-01-01 of a proleptic Gregorian date (vectorised, int64).

    Implements: H. Hinnant, "chrono-Compatible Low-Level Date Algorithms", days_from_civil.
    """
    y = np.asarray(year, dtype=np.int64) - (np.asarray(month) <= 2)
    m = np.asarray(month, dtype=np.int64)
    d = np.asarray(day, dtype=np.int64)
    era = np.floor_divide(y, 400)
    yoe = y - era * 400
    mp = (m + 9) % 12
    doy = (153 * mp + 2) // 5 + d - 1
    doe = yoe * 365 + yoe // 4 - yoe // 100 + doy
    return era * 146097 + doe - 719468


def civil_from_days(days) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(year, month, day) of days since 1970-01-01 (vectorised).

    Implements: H. Hinnant, civil_from_days.
    """
    z = np.asarray(days, dtype=np.int64) + 719468
    era = np.floor_divide(z, 146097)
    doe = z - era * 146097
    yoe = (doe - doe // 1460 + doe // 36524 - doe // 146096) // 365
    y = yoe + era * 400
    doy = doe - (365 * yoe + yoe // 4 - yoe // 100)
    mp = (5 * doy + 2) // 153
    d = doy - (153 * mp + 2) // 5 + 1
    m = np.where(mp < 10, mp + 3, mp - 9)
    return y + (m <= 2), m, d


class GpsTime:
    """An array of GPS times: `s` whole seconds since 1980-01-06T00:00:00 GPST (int64) + `frac` (float64, [0, 1)).

    Scalars are 0-d arrays. Differences between two GpsTime are float64 seconds computed part by part,
    so they keep sub-nanosecond resolution over decades.
    """

    __slots__ = ("s", "frac")

    def __init__(self, s, frac=0.0):
        s_arr = np.asarray(s)
        frac_arr = np.asarray(frac, dtype=np.float64)
        if s_arr.dtype.kind == "f":
            whole = np.floor(s_arr)
            frac_arr = frac_arr + (s_arr - whole)
            s_arr = whole
        s_arr = s_arr.astype(np.int64)
        carry = np.floor(frac_arr)
        self.s = s_arr + carry.astype(np.int64)
        self.frac = frac_arr - carry

    # --- construction -------------------------------------------------------------------------
    @classmethod
    def from_calendar(cls, year, month, day, hour=0, minute=0, second=0.0) -> "GpsTime":
        """GPS time of a calendar date and time of day already in the GPS time scale (RINEX epochs)."""
        second = np.asarray(second, dtype=np.float64)
        whole_sec = np.floor(second)
        days = days_from_civil(year, month, day) - _GPS_EPOCH_UNIX_DAYS
        s = (days * SECONDS_PER_DAY + np.asarray(hour, dtype=np.int64) * 3600
             + np.asarray(minute, dtype=np.int64) * 60 + whole_sec.astype(np.int64))
        return cls(s, second - whole_sec)

    @classmethod
    def from_week_sow(cls, week, sow) -> "GpsTime":
        """GPS time of a (continuous) week number and seconds of week."""
        sow = np.asarray(sow, dtype=np.float64)
        whole = np.floor(sow)
        return cls(np.asarray(week, dtype=np.int64) * SECONDS_PER_WEEK + whole.astype(np.int64), sow - whole)

    @classmethod
    def from_iso(cls, text: str) -> "GpsTime":
        """GPS time of an ISO 8601 text without zone, e.g. '2018-06-06T12:20:00.000' (CONVENTIONS.md)."""
        date, _, clock = text.strip().replace(" ", "T").partition("T")
        y, mo, d = (int(v) for v in date.split("-"))
        hh, mm, ss = (clock or "00:00:00").split(":")
        return cls.from_calendar(y, mo, d, int(hh), int(mm), float(ss))

    @classmethod
    def concatenate(cls, times: list["GpsTime"]) -> "GpsTime":
        return cls(np.concatenate([np.atleast_1d(t.s) for t in times]),
                   np.concatenate([np.atleast_1d(t.frac) for t in times]))

    # --- views ----------------------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, ...]:
        return self.s.shape

    def __len__(self) -> int:
        return len(self.s)

    def __getitem__(self, index) -> "GpsTime":
        return GpsTime(self.s[index], self.frac[index])

    def week_sow(self) -> tuple[np.ndarray, np.ndarray]:
        """(continuous GPS week, seconds of week as float64)."""
        week = np.floor_divide(self.s, SECONDS_PER_WEEK)
        return week, (self.s - week * SECONDS_PER_WEEK) + self.frac

    def seconds(self) -> np.ndarray:
        """Float64 seconds since the GPS epoch (lossy at ~0.1 us; use differences for precision)."""
        return self.s.astype(np.float64) + self.frac

    def calendar(self):
        """(year, month, day, hour, minute, second as float64) in the GPS time scale."""
        days = np.floor_divide(self.s, SECONDS_PER_DAY)
        sod = self.s - days * SECONDS_PER_DAY
        y, m, d = civil_from_days(days + _GPS_EPOCH_UNIX_DAYS)
        return y, m, d, sod // 3600, (sod % 3600) // 60, (sod % 60) + self.frac

    def iso(self, decimals: int = 3) -> list[str] | str:
        """ISO 8601 text without zone, GPS time (CONVENTIONS.md), rounded to `decimals` (no 60.000 s)."""
        scale = 10 ** decimals
        ticks = np.round(self.frac * scale).astype(np.int64)
        s = self.s + ticks // scale
        ticks = ticks % scale
        t = GpsTime(s)
        y, mo, d, hh, mi, ss = t.calendar()
        out = []
        for row in zip(*(np.atleast_1d(a) for a in (y, mo, d, hh, mi, ss, ticks))):
            yy, mm, dd, h, mn, sec, tk = (int(v) for v in row)
            txt = f"{yy:04d}-{mm:02d}-{dd:02d}T{h:02d}:{mn:02d}:{sec:02d}"
            if decimals:
                txt += f".{tk:0{decimals}d}"
            out.append(txt)
        return out[0] if self.s.ndim == 0 else out

    # --- arithmetic -----------------------------------------------------------------------------
    def __sub__(self, other):
        """Seconds between two GpsTime (float64), or a GpsTime shifted back by float seconds."""
        if isinstance(other, GpsTime):
            return (self.s - other.s).astype(np.float64) + (self.frac - other.frac)
        return self + (-np.asarray(other, dtype=np.float64))

    def __add__(self, seconds) -> "GpsTime":
        seconds = np.asarray(seconds, dtype=np.float64)
        whole = np.floor(seconds)
        return GpsTime(self.s + whole.astype(np.int64), self.frac + (seconds - whole))

    def __eq__(self, other):  # type: ignore[override]
        return (self.s == other.s) & (self.frac == other.frac)

    def __repr__(self) -> str:
        return f"GpsTime({self.iso(6)!r})"
