"""GPS time as a two-part number, and calendar / week-seconds conversions.

Float64 seconds since 1980 resolve only about 0.24 us, which a LEO range rate of ~8 km/s turns into
2 mm, so a time is kept as whole seconds since the GPS epoch (int64) plus a fraction (float64 in [0, 1)).

Implements: GPS time scale and week numbering of IS-GPS-200 sec. 20.3.3.5.2.4 (continuous week count,
no 1024 roll-over here); proleptic Gregorian calendar via the days-from-civil algorithm (H. Hinnant).
Neglects: leap seconds (GPS time has none). UTC and UT1 live with the leap-second table, which builds on this
module and never the reverse (gnssatt.gnss.leap_seconds: `utc_to_gps`, `gps_to_utc`, `jd_utc`, `jd_ut1`).
TT / TAI / BDT / GST are fixed offsets.
"""
from __future__ import annotations

import numpy as np

# The fixed offsets of TAI / TT / BDT / GST from GPS time and the JD of the GPS epoch are definitions of
# gnssatt.gnss.constants (IS-GPS-200 sec. 3.3.4, IAU 2000 B1.9, BDS ICD B1I 4.1.2, Galileo OS SIS ICD 5.1.2),
# re-exported here under the names this module always had.
from gnssatt.gnss.constants import (  # noqa: F401
    BDT_MINUS_GPST_S, BDT_WEEK_OFFSET, GST_MINUS_GPST_S, GST_WEEK_OFFSET, JD_GPS_EPOCH, TAI_MINUS_GPS_S,
    TT_MINUS_GPS_S,
)

SECONDS_PER_DAY = 86400  # int: whole-second arithmetic (gnssatt.gnss.constants.SECONDS_PER_DAY is the float)
SECONDS_PER_WEEK = 604800
# Days from 1970-01-01 to the GPS epoch 1980-01-06.
_GPS_EPOCH_UNIX_DAYS = 3657
#: GpsTime.iso: decimals -> the datetime64 unit that prints them; times below this bound (GPS seconds: ~year 2900)
#: have four-digit years there too
_DATETIME64_UNITS = {0: "s", 3: "ms", 6: "us"}       # (ns: int64 overflows after 2262)
_ISO_FAST_MAX_S = 29_000_000_000


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
        if decimals in _DATETIME64_UNITS and np.all((s >= 0) & (s < _ISO_FAST_MAX_S)):
            # the same text from numpy's datetime64 formatting (no leap seconds there either: GPS calendar
            # arithmetic), ~10x faster than the loop below for the 6358 epochs of a 106-minute pass
            unit = _DATETIME64_UNITS[decimals]
            stamps = ((s + _GPS_EPOCH_UNIX_DAYS * SECONDS_PER_DAY) * scale + ticks).astype(f"datetime64[{unit}]")
            text = np.datetime_as_string(stamps, unit=unit)
            return str(text) if self.s.ndim == 0 else text.tolist()
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

    # --- other time scales (two-part Julian dates for ERFA) ---------------------------------------
    def jd_with_offset(self, offset_s) -> tuple[np.ndarray, np.ndarray]:
        """(jd1, jd2): two-part Julian date of these times shifted by `offset_s` seconds (scalar or shape of t).

        jd1 is the JD of 0h of the GPS day, jd2 the day fraction of (seconds of day + frac + offset), so a scale
        that is GPS time plus an offset (TAI, TT, or UT1 = GPS - (GPS - UTC) + (UT1 - UTC)) keeps ~1 us.
        """
        days = np.floor_divide(self.s, SECONDS_PER_DAY)
        sod = (self.s - days * SECONDS_PER_DAY).astype(np.float64)
        jd1 = JD_GPS_EPOCH + days.astype(np.float64)
        jd2 = (sod + (self.frac + np.asarray(offset_s, dtype=np.float64))) / SECONDS_PER_DAY
        return jd1, jd2

    def to_jd_gps(self) -> tuple[np.ndarray, np.ndarray]:
        """(jd1, jd2): two-part Julian date in the GPS time scale; jd1 = JD of 0h of the GPS day."""
        return self.jd_with_offset(0.0)

    def to_jd_tai(self) -> tuple[np.ndarray, np.ndarray]:
        """(jd1, jd2): two-part Julian date in TAI (TAI = GPS + 19 s, IS-GPS-200 sec. 3.3.4)."""
        return self.jd_with_offset(TAI_MINUS_GPS_S)

    def to_jd_tt(self) -> tuple[np.ndarray, np.ndarray]:
        """(jd1, jd2): two-part Julian date in TT for ERFA (TT = TAI + 32.184 s = GPS + 51.184 s).

        jd1 is the JD of 0h of the GPS day (an integer + 0.5), jd2 the TT fraction (may exceed 1 a little),
        so the sum keeps ~1e-11 day (1 us) and each part is exact to the ERFA two-part convention.
        """
        return self.jd_with_offset(TT_MINUS_GPS_S)

    # --- BeiDou and Galileo system times ----------------------------------------------------------
    @classmethod
    def from_bdt_week_sow(cls, week, sow) -> "GpsTime":
        """GPS time of a BeiDou Time week and seconds of week (BDT = GPST - 14 s; BDT week 0 = GPS week 1356).

        Implements: BDS ICD B1I v3.0 sec. 4.1.2 (BDT epoch 2006-01-01T00:00:00 UTC).
        """
        return cls.from_week_sow(np.asarray(week, dtype=np.int64) + BDT_WEEK_OFFSET, sow) + (-BDT_MINUS_GPST_S)

    def bdt_week_sow(self) -> tuple[np.ndarray, np.ndarray]:
        """(BDT week, BDT seconds of week) of these GPS times."""
        week, sow = (self + BDT_MINUS_GPST_S).week_sow()
        return week - BDT_WEEK_OFFSET, sow

    @classmethod
    def from_gst_week_sow(cls, week, sow) -> "GpsTime":
        """GPS time of a Galileo System Time week (GST week 0 = GPS week 1024) and seconds of week.

        Implements: Galileo OS SIS ICD 2.1 sec. 5.1.2. Neglects: GGTO (GST - GPST, a few ns, broadcast).
        Note: RINEX 3/4 navigation files write the Galileo week already aligned to GPS weeks; use
        `from_week_sow` for those.
        """
        return cls.from_week_sow(np.asarray(week, dtype=np.int64) + GST_WEEK_OFFSET, sow)

    def gst_week_sow(self) -> tuple[np.ndarray, np.ndarray]:
        """(GST week, GST seconds of week) of these GPS times (GGTO neglected)."""
        week, sow = self.week_sow()
        return week - GST_WEEK_OFFSET, sow
