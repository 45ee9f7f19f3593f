"""Time scales: leap seconds, UTC, TT / TAI / UT1 Julian dates, BDT and GST, checked against ERFA."""
from __future__ import annotations

import datetime as dt

import erfa
import numpy as np
import pytest

from hypothesis import given, settings, strategies as st

from gnssatt.gnss import leap_seconds as L
from gnssatt.gnss.time import GpsTime

US_IN_DAYS = 1e-6 / 86400.0


@pytest.mark.parametrize("cal, expected", [
    ((1980, 1, 6), 0.0),          # GPS epoch: GPS = UTC
    ((1981, 6, 30, 23, 59, 59), 0.0),
    ((1981, 7, 1), 1.0),
    ((2005, 4, 2, 12), 13.0),     # the geonet 2005 data set
    ((2007, 3, 21), 14.0),        # GRACE-A 2007
    ((2008, 12, 31, 23, 59, 59), 14.0),
    ((2009, 1, 1), 15.0),
    ((2016, 12, 31, 23, 59, 59), 17.0),
    ((2017, 1, 1), 18.0),
    ((2024, 6, 24), 18.0),
])
def test_gps_minus_utc_known_values(cal, expected):
    t = L.utc_to_gps(*cal)
    assert L.gps_minus_utc_s(t) == expected


def test_table_agrees_with_erfa_dat_at_every_step_and_between():
    """Our table (whatever its source) gives the same TAI-UTC as erfa.dat around every step since 1972."""
    tab = L.TABLE
    for mjd in tab.mjd_utc:
        for dmjd in (-1.5, -0.5, 0.0, 0.5, 100.0):
            m = int(mjd + dmjd) if dmjd >= 0 else int(mjd) - 1
            if m < 41317:  # before 1972 UTC had rubber seconds; out of scope (module docstring)
                continue
            y, mo, d, _ = erfa.jd2cal(2400000.5, m + 0.5)
            t = L.utc_to_gps(int(y), int(mo), int(d), 12)
            assert L.tai_minus_utc_s(t) == erfa.dat(int(y), int(mo), int(d), 0.5), (y, mo, d)


def test_all_sources_agree_and_freshest_chosen():
    # astropy-iers-data is a dependency of the package (pyproject), so its file must load here
    tables = [L._fallback(), L._from_erfa(), L._from_astropy_iers_data()]
    n = min(len(t.mjd_utc) for t in tables)
    for t in tables[1:]:
        np.testing.assert_array_equal(t.mjd_utc[:n], tables[0].mjd_utc[:n])
        np.testing.assert_array_equal(t.tai_minus_utc_s[:n], tables[0].tai_minus_utc_s[:n])
    assert L.TABLE.expires == max(t.expires for t in tables)
    assert L.EXPIRES == L.TABLE.expires
    assert "expires" in L.TABLE.describe()


def test_leap_second_is_labelled_60_and_round_trips():
    # 2016-12-31T23:59:60 UTC is GPS 2017-01-01T00:00:17
    t0 = GpsTime.from_calendar(2017, 1, 1, 0, 0, 15.0)
    t = t0 + np.arange(0.0, 4.0, 0.25)
    y, mo, d, hh, mi, ss = L.gps_to_utc(t)
    labels = [f"{a:04d}-{b:02d}-{c:02d}T{e:02d}:{f:02d}:{g:06.3f}" for a, b, c, e, f, g in zip(y, mo, d, hh, mi, ss)]
    assert labels[0] == "2016-12-31T23:59:58.000"
    assert labels[8] == "2016-12-31T23:59:60.000"
    assert labels[11] == "2016-12-31T23:59:60.750"
    assert labels[12] == "2017-01-01T00:00:00.000"
    back = L.utc_to_gps(y, mo, d, hh, mi, ss)
    np.testing.assert_array_equal(back.s, t.s)
    np.testing.assert_allclose(back.frac, t.frac, atol=1e-12)
    # and ERFA agrees on the UTC quasi-JD inside the leap second
    jd1, jd2 = L.jd_utc(t)
    e1, e2 = erfa.taiutc(*t.to_jd_tai())
    np.testing.assert_allclose((jd1 - e1) + (jd2 - e2), 0.0, atol=1e-3 * US_IN_DAYS)


@settings(max_examples=200, deadline=None)
@given(s=st.integers(min_value=0, max_value=1_500_000_000), frac=st.floats(0.0, 0.999999))
def test_utc_round_trip_and_erfa_utc(s, frac):
    t = GpsTime(s, frac)
    back = L.utc_to_gps(*L.gps_to_utc(t))
    assert int(back.s) == s and abs(float(back.frac) - frac) < 1e-9
    jd1, jd2 = L.jd_utc(t)
    e1, e2 = erfa.taiutc(*t.to_jd_tai())
    assert abs((jd1 - e1) + (jd2 - e2)) < 1e-3 * US_IN_DAYS


def test_tt_tai_jd_match_erfa_chain_from_utc():
    """UTC calendar -> erfa dtf2d/utctai/taitt vs. our utc_to_gps -> to_jd_tt: same instant to 1 ns."""
    cals = [(2005, 4, 2, 0, 0, 0.0), (2007, 3, 21, 13, 47, 12.25), (2021, 9, 22, 23, 59, 59.9),
            (2016, 12, 31, 23, 59, 60.5), (1990, 1, 1, 0, 0, 0.0)]
    for cal in cals:
        t = L.utc_to_gps(*cal)
        tai = erfa.utctai(*erfa.dtf2d("UTC", *cal))
        tt = erfa.taitt(*tai)
        j1, j2 = t.to_jd_tt()
        assert abs((j1 - tt[0]) + (j2 - tt[1])) < 1e-3 * US_IN_DAYS, cal
        j1, j2 = t.to_jd_tai()
        assert abs((j1 - tai[0]) + (j2 - tai[1])) < 1e-3 * US_IN_DAYS, cal
        assert j1 % 1.0 == 0.5  # jd1 is 0h of a day: exact two-part split


def test_jd_tt_of_gps_epoch_and_vectorised_shape():
    t = GpsTime(np.array([[0, 86400], [43200, 604800]]))
    j1, j2 = t.to_jd_tt()
    assert j1.shape == (2, 2)
    assert j1[0, 0] == 2444244.5 and j2[0, 0] == pytest.approx(51.184 / 86400, abs=1e-16)
    assert j1[0, 1] == 2444245.5


def test_ut1_jd_uses_ut1_minus_utc():
    t = GpsTime.from_calendar(2021, 9, 22, 6)
    u1, u2 = L.jd_ut1(t, -0.1)
    e = erfa.utcut1(*L.jd_utc(t), -0.1)
    assert abs((u1 - e[0]) + (u2 - e[1])) < 1e-3 * US_IN_DAYS


def test_bdt_and_gst_epochs():
    # BDT epoch: 2006-01-01T00:00:00 UTC, when GPS - UTC = 14 s
    t = GpsTime.from_bdt_week_sow(0, 0.0)
    assert t == L.utc_to_gps(2006, 1, 1)
    week, sow = t.bdt_week_sow()
    assert week == 0 and sow == 0.0
    t = GpsTime.from_bdt_week_sow(1000, 345600.5)
    w, s = t.week_sow()
    assert w == 2356 and s == pytest.approx(345614.5)
    # GST epoch: 1999-08-22T00:00:00 GPST = GPS week 1024
    g = GpsTime.from_gst_week_sow(0, 0.0)
    assert g.iso(0) == "1999-08-22T00:00:00"
    assert g.gst_week_sow()[0] == 0


def test_expiry():
    exp = L.TABLE.expires
    before = L.utc_to_gps(exp.year, exp.month, exp.day) + (-86400.0)
    after = L.utc_to_gps(exp.year, exp.month, exp.day) + 86400.0
    assert not L.is_expired(before)
    assert L.is_expired(after)
    both = GpsTime.concatenate([before, after])
    msg = L.expiry_warning(both)
    assert msg is not None and msg.startswith("1 epoch") and exp.isoformat() in msg
    assert L.expiry_warning(before) is None


def test_parse_leap_second_dat_refuses_bad_rows_and_missing_expiry():
    good = "#  File expires on 28 June 2027\n    41317.0    1  1 1972       10\n    41499.0    1  7 1972       11\n"
    tab = L.parse_iers_leap_second_dat(good, "x")
    assert tab.expires == dt.date(2027, 6, 28) and list(tab.tai_minus_utc_s) == [10, 11]
    with pytest.raises(ValueError, match="expires"):
        L.parse_iers_leap_second_dat(good.splitlines()[1] + "\n", "x")
    with pytest.raises(ValueError, match="MJD day month year"):
        L.parse_iers_leap_second_dat(good + "41700.0 1 1\n", "x")
    # a custom table changes the answer (the table argument is honoured)
    t = L.utc_to_gps(1973, 1, 1, table=tab)
    assert L.gps_minus_utc_s(t, table=tab) == 11 - 19


def test_iso_datetime64_path_gives_the_loops_text(monkeypatch):
    """GpsTime.iso with 0, 3 or 6 decimals formats through datetime64; the text is the per-epoch loop's: rounding
    into the next second, minute and day (0.9995 s at 3 decimals), midnight, years up to ~2900, scalars as str."""
    import numpy as np

    import gnssatt.gnss.time as T

    rng = np.random.default_rng(7)
    s = np.concatenate([rng.integers(0, T._ISO_FAST_MAX_S, 5000), [0, 59, 86399, T._ISO_FAST_MAX_S - 1]])
    frac = np.concatenate([rng.random(5000), [0.9995, 0.9999996, 0.0005, 0.0]])
    t = T.GpsTime(s, frac)
    fast = {d: t.iso(d) for d in (0, 3, 6)}
    scalar = T.GpsTime(np.int64(86399), 0.9995).iso(3)
    monkeypatch.setattr(T, "_DATETIME64_UNITS", {})          # the loop only
    for d in (0, 3, 6):
        assert fast[d] == t.iso(d), d
    assert scalar == T.GpsTime(np.int64(86399), 0.9995).iso(3) == "1980-01-07T00:00:00.000"
    assert isinstance(scalar, str)
