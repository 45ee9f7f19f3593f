"""EOP sources: zero, bundled IERS finals2000A, user files (finals / C04), interpolation, coverage warnings."""
from __future__ import annotations

import warnings

import astropy_iers_data
import numpy as np
import pytest

from gnssatt.gnss import frames as F
from gnssatt.gnss.eop import ARCSEC_RAD, EopSource, EopWarning
from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.leap_seconds import utc_to_gps
from gnssatt.gnss.time import GpsTime

FINALS = astropy_iers_data.IERS_A_FILE
C04 = astropy_iers_data.IERS_B_FILE


def _finals_lines(mjd0, n):
    out = []
    for line in open(FINALS):
        if line[7:15].strip() and mjd0 <= float(line[7:15]) < mjd0 + n:
            out.append(line.rstrip("\n"))
    return out


def test_zero_eop():
    e = EopSource.zero()
    t = GpsTime.from_calendar(2021, 9, 22) + np.arange(3.0)
    v = e.at(t)
    assert np.all(v.xp_rad == 0) and np.all(v.ut1_minus_utc_s == 0) and np.all(v.covered)
    np.testing.assert_array_equal(v.ut1_minus_tai_s, -37.0)
    assert "zero EOP" in e.describe() and e.coverage_warning(t) is None


def test_bundled_values_at_nodes_and_between():
    e = EopSource.bundled()
    assert "finals2000A" in e.describe() and "astropy-iers-data" in e.describe()
    rows = _finals_lines(54180, 2)  # 2007-03-21, 22
    xp0, xp1 = float(rows[0][18:27]), float(rows[1][18:27])
    u0, u1 = float(rows[0][58:68]), float(rows[1][58:68])
    t = utc_to_gps(2007, 3, 21, [0, 12, 24])
    v = e.at(t)
    np.testing.assert_allclose(v.xp_rad[[0, 2]] / ARCSEC_RAD, [xp0, xp1], atol=1e-9)
    np.testing.assert_allclose(v.ut1_minus_utc_s[[0, 2]], [u0, u1], atol=1e-9)
    # midday: cubic interpolation is near the chord (polar motion curves < 0.1 mas over a day)
    assert abs(v.xp_rad[1] / ARCSEC_RAD - (xp0 + xp1) / 2) < 1e-4
    assert abs(v.ut1_minus_utc_s[1] - (u0 + u1) / 2) < 5e-5
    assert not v.predicted.any()


def test_ut1_continuous_across_leap_second():
    e = EopSource.bundled()
    t = GpsTime.from_calendar(2017, 1, 1, 0, 0, np.arange(16.0, 20.0, 0.5))  # UTC leap at GPS 00:00:18
    v = e.at(t)
    assert np.max(np.abs(np.diff(v.ut1_minus_tai_s))) < 1e-6
    jump = np.diff(v.ut1_minus_utc_s)
    assert np.count_nonzero(np.abs(jump) > 0.5) == 1 and jump.max() == pytest.approx(1.0, abs=1e-6)


def test_outside_table_is_nan_with_counted_warning_and_frames_propagate_nan():
    e = EopSource.bundled()
    t = GpsTime.concatenate([GpsTime.from_calendar(2021, 1, 1), GpsTime.from_calendar(2040, 1, 1)])
    with pytest.warns(EopWarning, match="1 epoch"):
        v = e.at(t)
    assert v.covered.tolist() == [True, False] and np.isnan(v.xp_rad[1]) and np.isfinite(v.xp_rad[0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EopWarning)
        R = F.R_gcrf_from_ecef(t, e)
    assert np.isfinite(R[0]).all() and np.isnan(R[1]).all()
    assert "outside" in e.coverage_warning(t)


def test_predicted_values_flagged():
    e = EopSource.bundled()
    last_obs = np.datetime64(e.file_date)
    pred_day = (last_obs + np.timedelta64(30, "D")).astype(object)
    t = utc_to_gps(pred_day.year, pred_day.month, pred_day.day)
    v = e.at(t)
    assert v.covered and v.predicted
    assert "predicted" in e.coverage_warning(t)
    assert not e.at(GpsTime.from_calendar(2010, 1, 1)).predicted


def test_from_file_finals_subset(tmp_path):
    p = tmp_path / "finals2000A.daily"
    p.write_text("\n".join(_finals_lines(59470, 10)) + "\n")  # 2021-09-13 .. 22
    e = EopSource.from_file(p)
    assert "finals2000A.daily" in e.describe() and e.span() == ("2021-09-13", "2021-09-22")
    t = utc_to_gps(2021, 9, 17, 7)
    a, b = e.at(t), EopSource.bundled().at(t)
    assert abs(a.xp_rad - b.xp_rad) < 1e-15 and abs(a.ut1_minus_utc_s - b.ut1_minus_utc_s) < 1e-12
    np.testing.assert_allclose(a.dx_rad, b.dx_rad, atol=1e-18)


def test_from_file_c04_agrees_with_finals(tmp_path):
    lines = open(C04).read().splitlines()
    header = [ln for ln in lines[:10] if ln.startswith("#")]
    body = [ln for ln in lines if not ln.startswith("#") and ln.split()[4] in {f"{m}.00" for m in range(54175, 54190)}]
    p = tmp_path / "eopc04.txt"
    p.write_text("\n".join(header + body) + "\n")
    e = EopSource.from_file(p)
    t = utc_to_gps(2007, 3, 21, 6)
    a, b = e.at(t), EopSource.bundled().at(t)
    assert abs(a.xp_rad - b.xp_rad) / ARCSEC_RAD < 1e-3  # C04 vs Bulletin A: < 1 mas
    assert abs(a.ut1_minus_utc_s - b.ut1_minus_utc_s) < 1e-4
    assert not a.predicted


def test_from_file_refuses_garbage(tmp_path):
    p = tmp_path / "bad.txt"
    p.write_text("this is not an EOP file\nat all\n")
    with pytest.raises(ParseError):
        EopSource.from_file(p)
    p.write_text("")
    with pytest.raises(ParseError):
        EopSource.from_file(p)
    p.write_text("# C04\n2007 3 21 0 54180.00 0.1 0.2\n")
    with pytest.raises(ParseError) as exc:
        EopSource.from_file(p)
    assert exc.value.line_no == 2
