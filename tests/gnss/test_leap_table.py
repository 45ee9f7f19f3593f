"""The one leap-second table: agrees with ERFA's `dat` on every day since 1980 and with the IERS Leap_Second.dat of
astropy-iers-data (rows and expiry); the RINEX nav reader and the simulator answer from it; an expired table
reaches a product as a warning; gnssatt.gnss.time does not import it (no import cycle)."""
from __future__ import annotations

import ast
import datetime as dt
import re
import warnings
from pathlib import Path

import astropy_iers_data
import erfa
import numpy as np

from gnssatt.gnss import leap_seconds as L
from gnssatt.gnss.io import rinex_nav
from gnssatt.gnss.time import GpsTime
from gnssatt.sim import _constants as sim_constants
from tests.gnss.test_rinex_nav_builders import GLO_VALUES, d19, header_line


def _utc_days_since_1980():
    """(year, month, day) int arrays of every UTC day from 1980-01-01 to the day before the table's expiry."""
    first = dt.date(1980, 1, 1).toordinal()
    days = [dt.date.fromordinal(o) for o in range(first, L.TABLE.expires.toordinal())]
    return (np.array([d.year for d in days]), np.array([d.month for d in days]), np.array([d.day for d in days]))


def test_every_day_since_1980_agrees_with_erfa_dat():
    """TAI - UTC at noon of each UTC day 1980-01-01 .. expiry equals erfa.dat (exact integers).

    erfa.dat knows leap seconds up to its own table's date; past pyerfa's `expires` it warns ("dubious year")
    but still answers with its last value, which is right as long as no leap second was announced since
    2017 (IERS Bulletin C 72 of July 2026: none before 2027-06-28)."""
    y, mo, d = _utc_days_since_1980()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", erfa.ErfaWarning)
        expected = erfa.dat(y.astype(np.int32), mo.astype(np.int32), d.astype(np.int32), 0.5)
    t = L.utc_to_gps(y, mo, d, 12)
    got = L.tai_minus_utc_s(t)
    bad = np.flatnonzero(got != expected)
    assert bad.size == 0, [(int(y[i]), int(mo[i]), int(d[i]), got[i], expected[i]) for i in bad[:5]]
    assert len(y) > 17000  # 1980 .. at least 2026


def test_table_is_the_iers_file_of_astropy_iers_data():
    """Rows and "File expires on" of the installed Leap_Second.dat, read independently of the module's parser."""
    text = Path(astropy_iers_data.IERS_LEAP_SECOND_FILE).read_text()
    rows = [ln.split() for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    mjd = np.array([int(float(r[0])) for r in rows])
    dat = np.array([int(r[4]) for r in rows])
    m = re.search(r"File expires on\s+(\d+)\s+(\w+)\s+(\d{4})", text)
    expires = dt.datetime.strptime(" ".join(m.groups()), "%d %B %Y").date()
    np.testing.assert_array_equal(L.TABLE.mjd_utc, mjd)
    np.testing.assert_array_equal(L.TABLE.tai_minus_utc_s, dat)
    assert L.TABLE.expires >= expires  # the freshest source wins; the bundled file is one candidate
    # IERS: the last leap second was inserted at the end of 2016-12-31 (TAI - UTC = 37 s, GPS - UTC = 18 s)
    assert int(L.TABLE.mjd_utc[-1]) == 57754 and int(L.TABLE.tai_minus_utc_s[-1]) == 37
    # the fallback copy in the module is that file's Bulletin (72) and expiry, so an offline install agrees
    fb = L._fallback()
    np.testing.assert_array_equal(fb.mjd_utc, mjd[:len(fb.mjd_utc)])
    np.testing.assert_array_equal(fb.tai_minus_utc_s, dat[:len(fb.mjd_utc)])
    assert fb.expires <= expires


def test_rinex_nav_and_simulator_read_the_one_table():
    y, mo, d = _utc_days_since_1980()
    keep = y >= 1981
    y, mo, d = y[keep], mo[keep], d[keep]
    table_gps_minus_utc = L.gps_minus_utc_s(L.utc_to_gps(y, mo, d, 12))
    # RINEX nav: UTC calendar seconds (GLONASS epochs); one second before midnight and at midnight of each day
    noon_utc_s = GpsTime.from_calendar(y, mo, d, 12).s
    np.testing.assert_array_equal(rinex_nav.gps_minus_utc_s(noon_utc_s), table_gps_minus_utc)
    assert rinex_nav.LEAP_TABLE_EXPIRES == L.EXPIRES
    # simulator: GPS seconds (float)
    gps_noon = L.utc_to_gps(y[::97], mo[::97], d[::97], 12)
    sim = [sim_constants.gps_minus_utc_s(float(s)) for s in gps_noon.s]
    assert sim == table_gps_minus_utc[::97].astype(int).tolist()
    assert sim_constants.LEAP_TABLE_EXPIRES == L.EXPIRES.isoformat()


def _glonass_nav_v2(year: int, leap_header: str | None) -> bytes:
    lines = [header_line("     2.01           G: GLONASS NAV DATA", "RINEX VERSION / TYPE"),
             header_line("gnssatt-test", "PGM / RUN BY / DATE")]
    if leap_header is not None:
        lines.append(header_line(leap_header, "LEAP SECONDS"))
    lines.append(header_line("", "END OF HEADER"))
    v = [d19(x, "D") for x in GLO_VALUES]
    rec = [f" 3 {year % 100:02d}  1 10  0 15  0.0" + "".join(v[0:3])] + ["   " + "".join(v[k:k + 4]) for k in (3, 7, 11)]
    return ("\n".join(lines + rec) + "\n").encode()


def test_expired_table_warns_in_rinex_nav_and_products():
    year = L.TABLE.expires.year + 1  # 10 January of the year after the expiry: past it
    nav = rinex_nav.read_rinex_nav(_glonass_nav_v2(year, None), name="late.g")
    codes = [w.code for w in nav.warnings]
    assert "leap-table-expired" in codes and nav.glonass.leap_s.tolist() == [18]
    nav_h = rinex_nav.read_rinex_nav(_glonass_nav_v2(year, "    19"), name="late.g")  # a new leap second
    assert nav_h.glonass.leap_s.tolist() == [19] and "leap-table-expired" in [w.code for w in nav_h.warnings]
    before = rinex_nav.read_rinex_nav(_glonass_nav_v2(L.TABLE.expires.year - 1, None), name="ok.g")
    assert "leap-table-expired" not in [w.code for w in before.warnings]
    # the sentence a product carries (attitude summary warnings, simulator truth file)
    late = L.utc_to_gps(year, 1, 10)
    assert sim_constants.leap_expiry_warning(float(late.s)) == L.expiry_warning(late)
    assert L.TABLE.expires.isoformat() in L.expiry_warning(late)
    assert sim_constants.leap_expiry_warning(float(L.utc_to_gps(2018, 6, 6).s)) is None


def _gnssatt_imports(module: str) -> set[str]:
    """gnssatt modules named by any import statement (top level or inside functions) of `module`."""
    src = Path(__import__(module, fromlist=["x"]).__file__).read_text()
    imported = set()
    for node in ast.walk(ast.parse(src)):
        if isinstance(node, ast.ImportFrom) and node.module:
            imported.add(node.module)
        elif isinstance(node, ast.Import):
            imported.update(a.name for a in node.names)
    return {m for m in imported if m.startswith("gnssatt")}


def test_time_module_does_not_import_the_leap_table():
    """gnssatt.gnss.time is below the table (the table builds UTC on GPS time), so there is no import cycle:
    time reads only the constants, which import nothing of the project."""
    assert _gnssatt_imports("gnssatt.gnss.time") <= {"gnssatt.gnss.constants"}
    assert _gnssatt_imports("gnssatt.gnss.constants") == set()
    assert "gnssatt.gnss.time" in _gnssatt_imports("gnssatt.gnss.leap_seconds")
