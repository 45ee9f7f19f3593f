"""GPS - UTC leap seconds from a maintained table that knows when it expires.

The table is read once, at import, from the first of these that loads (all offline, never fetched):
1. the IERS `Leap_Second.dat` bundled with the installed `astropy-iers-data` package (maintained, carries
   "File expires on ..."), or
2. pyerfa's own table (`erfa.leap_seconds`, with `expires`), when that expires later (someone updated it),
3. the fallback copied below from IERS Bulletin C 72 (Leap_Second.dat of July 2026, expires 2027-06-28).
The chosen table names its `source`; `is_expired(t)` tells a product to warn: after `EXPIRES` a leap second
may have been announced that this table does not know, so UTC (and UT1 via UTC) may be off by whole seconds.
`expiry_warning(t)` is the sentence a product carries then (the attitude summary's warnings, the RINEX nav
reader's LEAP_TABLE_EXPIRED for GLONASS epochs, the simulator's truth file).

This is the project's one leap-second table: RINEX navigation/clock/SP3 readers (UTC epochs), the simulator
and the UTC/UT1 Julian dates for ERFA all read `TABLE`. Layering: gnssatt.gnss.time (GPS time, no leap
seconds) <- this module; time never imports it.

Implements: IERS Bulletin C (TAI - UTC); GPS time = TAI - 19 s (IS-GPS-200 sec. 3.3.4); UTC calendar with
the leap second written 23:59:60 (ITU-R TF.460-6).
Neglects: UTC before 1972 (rubber seconds; GPS time began in 1980). Times before 1972 get the 1972 offset.
"""
from __future__ import annotations

import datetime as _dt
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gnssatt.gnss.constants import MJD_GPS_EPOCH, TAI_MINUS_GPS_S
from gnssatt.gnss.time import GpsTime, days_from_civil, civil_from_days

_GPS_EPOCH_MJD = int(MJD_GPS_EPOCH)
_TAI_MINUS_GPS_S = int(TAI_MINUS_GPS_S)
_MJD_UNIX_EPOCH = 40587  # MJD of 1970-01-01

# Fallback: (MJD of the UTC day from which the value holds, TAI - UTC s). IERS Bulletin C 72, Leap_Second.dat.
_FALLBACK_ROWS = (
    (41317, 10), (41499, 11), (41683, 12), (42048, 13), (42413, 14), (42778, 15), (43144, 16), (43509, 17),
    (43874, 18), (44239, 19), (44786, 20), (45151, 21), (45516, 22), (46247, 23), (47161, 24), (47892, 25),
    (48257, 26), (48804, 27), (49169, 28), (49534, 29), (50083, 30), (50630, 31), (51179, 32), (53736, 33),
    (54832, 34), (56109, 35), (57204, 36), (57754, 37),
)
_FALLBACK_EXPIRES = _dt.date(2027, 6, 28)


@dataclass(frozen=True)
class LeapSecondTable:
    """TAI - UTC steps: from UTC day `mjd_utc[i]` (00:00 UTC) on, TAI - UTC = `tai_minus_utc_s[i]`."""

    mjd_utc: np.ndarray  # int64, increasing
    tai_minus_utc_s: np.ndarray  # int64
    expires: _dt.date
    source: str

    @property
    def step_gps_s(self) -> np.ndarray:
        """GPS seconds since 1980-01-06 of each step instant (00:00:00 UTC of `mjd_utc[i]`)."""
        return (self.mjd_utc - _GPS_EPOCH_MJD) * 86400 + (self.tai_minus_utc_s - _TAI_MINUS_GPS_S)

    def describe(self) -> str:
        """One line naming the table's origin, last step and expiry, for products."""
        last = _mjd_to_date(int(self.mjd_utc[-1]))
        return (f"leap seconds: {self.source}; last step {last.isoformat()} (TAI-UTC = "
                f"{int(self.tai_minus_utc_s[-1])} s); expires {self.expires.isoformat()}")


def _mjd_to_date(mjd: int) -> _dt.date:
    y, m, d = civil_from_days(mjd - _MJD_UNIX_EPOCH)
    return _dt.date(int(y), int(m), int(d))


def _date_to_mjd(year, month, day) -> np.ndarray:
    return days_from_civil(year, month, day) + _MJD_UNIX_EPOCH


_MONTHS = {m: i + 1 for i, m in enumerate(
    ["january", "february", "march", "april", "may", "june", "july", "august", "september", "october",
     "november", "december"])}


def parse_iers_leap_second_dat(text: str, source: str) -> LeapSecondTable:
    """LeapSecondTable of the text of an IERS `Leap_Second.dat` (Bulletin C) file.

    Args:
        text: the file's content: '#' comment lines (one says "File expires on 28 June 2027"), then rows
            `MJD day month year TAI-UTC`.
        source: name of the file for `describe()`.
    Implements: layout of https://hpiers.obspm.fr/iers/bul/bulc/Leap_Second.dat.
    """
    expires = None
    rows = []
    for line in text.splitlines():
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            m = re.search(r"expires\s+on\s+(\d{1,2})\s+([A-Za-z]+)\s+(\d{4})", s)
            if m:
                expires = _dt.date(int(m.group(3)), _MONTHS[m.group(2).lower()], int(m.group(1)))
            continue
        parts = s.split()
        if len(parts) != 5:
            raise ValueError(f"{source}: expected 'MJD day month year TAI-UTC', found {line!r}")
        rows.append((int(float(parts[0])), int(parts[4])))
    if expires is None or not rows:
        raise ValueError(f"{source}: no 'File expires on' line or no rows")
    mjd, dat = (np.array(c, dtype=np.int64) for c in zip(*rows))
    if np.any(np.diff(mjd) <= 0):
        raise ValueError(f"{source}: MJD column not increasing")
    return LeapSecondTable(mjd, dat, expires, source)


def _from_astropy_iers_data() -> LeapSecondTable:
    import astropy_iers_data  # bundled data package; never downloads

    path = Path(astropy_iers_data.IERS_LEAP_SECOND_FILE)
    version = getattr(astropy_iers_data, "__version__", "?")
    return parse_iers_leap_second_dat(path.read_text(), f"IERS Leap_Second.dat (astropy-iers-data {version})")


def _from_erfa() -> LeapSecondTable:
    import erfa

    rows = [(int(r["year"]), int(r["month"]), float(r["tai_utc"])) for r in erfa.leap_seconds.get()]
    rows = [r for r in rows if r[0] >= 1972]  # integer steps only
    mjd = _date_to_mjd([r[0] for r in rows], [r[1] for r in rows], 1)
    dat = np.array([round(r[2]) for r in rows], dtype=np.int64)
    expires = erfa.leap_seconds.expires
    expires = expires.date() if isinstance(expires, _dt.datetime) else expires
    return LeapSecondTable(np.asarray(mjd, dtype=np.int64), dat, expires,
                           f"pyerfa built-in table (erfa {erfa.__version__})")


def _fallback() -> LeapSecondTable:
    mjd, dat = (np.array(c, dtype=np.int64) for c in zip(*_FALLBACK_ROWS))
    return LeapSecondTable(mjd, dat, _FALLBACK_EXPIRES, "gnssatt fallback copy of IERS Bulletin C 72")


def load_table() -> LeapSecondTable:
    """The freshest available leap-second table (latest `expires`): astropy-iers-data, pyerfa or fallback."""
    candidates = []
    for loader in (_from_astropy_iers_data, _from_erfa):
        try:
            candidates.append(loader())
        except Exception:  # noqa: BLE001 - a missing/odd optional source falls through to the next one
            continue
    candidates.append(_fallback())
    best = candidates[0]
    for cand in candidates[1:]:
        if cand.expires > best.expires:
            best = cand
    return best


TABLE: LeapSecondTable = load_table()
EXPIRES: _dt.date = TABLE.expires
SOURCE: str = TABLE.source


def _index_gps(t: GpsTime, table: LeapSecondTable) -> np.ndarray:
    idx = np.searchsorted(table.step_gps_s, np.asarray(t.s), side="right") - 1
    return np.clip(idx, 0, len(table.mjd_utc) - 1)


def gps_minus_utc_s(t: GpsTime, table: LeapSecondTable | None = None) -> np.ndarray:
    """GPS - UTC in seconds (integer-valued float64) at GPS times `t` (shape of t).

    Implements: GPS - UTC = (TAI - UTC) - 19 s, TAI - UTC from IERS Bulletin C. During an inserted leap
    second (23:59:60 UTC) the old value holds, so UTC = GPS - (GPS - UTC) reads 23:59:60.
    """
    table = table or TABLE
    return (table.tai_minus_utc_s[_index_gps(t, table)] - _TAI_MINUS_GPS_S).astype(np.float64)


def tai_minus_utc_s(t: GpsTime, table: LeapSecondTable | None = None) -> np.ndarray:
    """TAI - UTC in seconds (integer-valued float64) at GPS times `t`."""
    return gps_minus_utc_s(t, table) + _TAI_MINUS_GPS_S


def utc_to_gps(year, month, day, hour=0, minute=0, second=0.0,
               table: LeapSecondTable | None = None) -> GpsTime:
    """GpsTime of a UTC calendar date and time (vectorised); a leap second is written with second in [60, 61).

    Implements: GPS = UTC + (TAI - UTC) - 19 s with the offset of the UTC second being labelled.
    """
    second = np.asarray(second, dtype=np.float64)
    whole = np.floor(second)
    naive_day_s = (days_from_civil(year, month, day) - (_GPS_EPOCH_MJD - _MJD_UNIX_EPOCH)) * 86400 \
        + np.asarray(hour, dtype=np.int64) * 3600 + np.asarray(minute, dtype=np.int64) * 60
    # Look the offset up with 23:59:60 clipped to 23:59:59, so the leap second keeps the old offset.
    offset = gps_minus_utc_at_utc_s(naive_day_s + np.minimum(whole, 59).astype(np.int64), table)
    return GpsTime(naive_day_s + whole.astype(np.int64) + offset, second - whole)


def gps_minus_utc_at_utc_s(utc_calendar_s, table: LeapSecondTable | None = None) -> np.ndarray:
    """GPS - UTC (int64 s) at UTC instants given as whole seconds of the UTC calendar since 1980-01-06 00:00.

    Args:
        utc_calendar_s: int64 array, `GpsTime.from_calendar(<UTC calendar date and time>).s` (RINEX writes
            GLONASS and some clock/SP3 epochs in UTC).
    Implements: IERS Bulletin C; the value of the UTC day the instant lies in (a 23:59:60 label must be given
    as 23:59:59, see `utc_to_gps`).
    """
    table = table or TABLE
    steps_naive = (table.mjd_utc - _GPS_EPOCH_MJD) * 86400
    idx = np.searchsorted(steps_naive, np.asarray(utc_calendar_s, dtype=np.int64), side="right") - 1
    idx = np.clip(idx, 0, len(steps_naive) - 1)
    return table.tai_minus_utc_s[idx] - _TAI_MINUS_GPS_S


def gps_to_utc(t: GpsTime, table: LeapSecondTable | None = None):
    """UTC calendar (year, month, day, hour, minute, second float64) of GPS times; 23:59:60.x in a leap second.

    Implements: UTC = GPS - (GPS - UTC) (IS-GPS-200 sec. 20.3.3.5.2.4), ITU-R TF.460-6 leap-second labelling.
    """
    table = table or TABLE
    idx = _index_gps(t, table)
    s = np.asarray(t.s)
    offset = table.tai_minus_utc_s[idx] - _TAI_MINUS_GPS_S
    steps = table.step_gps_s
    nxt = np.minimum(idx + 1, len(steps) - 1)
    # Inside an inserted leap second: the last second before the next step, when that step is +1 s.
    in_leap = (idx + 1 < len(steps)) & (table.tai_minus_utc_s[nxt] - table.tai_minus_utc_s[idx] == 1) \
        & (s >= steps[nxt] - 1) & (s < steps[nxt])
    naive = GpsTime(s - offset - in_leap.astype(np.int64), t.frac)
    y, mo, d, hh, mi, ss = naive.calendar()
    ss = np.where(in_leap, ss + 1.0, ss)  # 23:59:59.x of the day before -> 23:59:60.x
    return y, mo, d, hh, mi, ss


def is_expired(t: GpsTime, table: LeapSecondTable | None = None) -> np.ndarray:
    """True where GPS time `t` is on or after the table's expiry date (then GPS - UTC may be stale).

    A product computed at such a time should carry a warning naming `TABLE.describe()`.
    """
    table = table or TABLE
    exp_mjd = int(_date_to_mjd(table.expires.year, table.expires.month, table.expires.day))
    exp_gps_s = (exp_mjd - _GPS_EPOCH_MJD) * 86400
    return np.asarray(t.s) >= exp_gps_s


def expiry_warning(t: GpsTime, table: LeapSecondTable | None = None) -> str | None:
    """A warning sentence for a product when any of `t` is past the table's expiry, else None."""
    table = table or TABLE
    n = int(np.count_nonzero(is_expired(t, table)))
    if n == 0:
        return None
    return (f"{n} epoch(s) lie after the leap-second table's expiry ({table.expires.isoformat()}, "
            f"{table.source}); UTC and UT1 there may be off by whole seconds if a leap second was announced")


def jd_utc(t: GpsTime) -> tuple[np.ndarray, np.ndarray]:
    """(jd1, jd2): ERFA quasi Julian date in UTC of GPS times `t` (a leap-second day has 86401 s), via erfa.dtf2d.

    Implements: UTC = GPS - (GPS - UTC) with this table (IERS Bulletin C), then the SOFA/ERFA UTC quasi-JD
    convention of iauDtf2d.
    """
    import erfa

    y, mo, d, hh, mi, ss = gps_to_utc(t)
    return erfa.dtf2d("UTC", y.astype(np.int32), mo.astype(np.int32), d.astype(np.int32),
                      hh.astype(np.int32), mi.astype(np.int32), ss)


def jd_ut1(t: GpsTime, ut1_minus_utc_s=0.0) -> tuple[np.ndarray, np.ndarray]:
    """(jd1, jd2): two-part Julian date in UT1 = UTC + (UT1 - UTC) [s] of GPS times `t`, UTC from this table.

    Computed as UT1 = GPS - (GPS - UTC) + (UT1 - UTC), a continuous scale (no quasi-JD).
    """
    return t.jd_with_offset(np.asarray(ut1_minus_utc_s, dtype=np.float64) - gps_minus_utc_s(t))
