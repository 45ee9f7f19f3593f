"""SP3 reader: golden tests of each RINEX-QUIRKS "SP3" item, errors with lines, and georinex value for value."""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from tests.conftest import real_set, require_module
from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.sp3 import read_sp3, summarize_sp3


def sp3_text(sats, epochs, *, version="d", velocity=False, seconds=None, drop=(), extra_body_sat=None,
             eof=True, bad=()):
    """A small synthetic SP3-c/d text. epochs: number of 15-min epochs from 2024-06-24 00:00; drop: (epoch, sat)
    pairs without records; bad: (epoch, sat, 'pos'|'clk') flagged with SP3 bad values."""
    n = len(sats)
    lines = [f"#{version}{'V' if velocity else 'P'}2024  6 24  0  0  0.00000000{epochs:8d} ORBIT IGS20 FIT  TST",
             "## 2320  86400.00000000   900.00000000 60485 0.0000000000000"]
    ids = [f"{s:>3s}" for s in sats]
    n_lines = max(5, math.ceil(n / 17))
    for k in range(n_lines):
        chunk = ids[17 * k:17 * k + 17]
        chunk += ["  0"] * (17 - len(chunk))
        lines.append(("+  " + f"{n:3d}" + "   " if k == 0 else "+        ") + "".join(chunk))
    for k in range(n_lines):
        lines.append("++       " + "  5" * 17)
    lines += ["%c M  cc GPS ccc cccc cccc cccc cccc ccccc ccccc ccccc ccccc",
              "%c cc cc ccc ccc cccc cccc cccc cccc ccccc ccccc ccccc ccccc",
              "%f  1.2500000  1.025000000  0.00000000000  0.000000000000000",
              "%f  0.0000000  0.000000000  0.00000000000  0.000000000000000",
              "%i    0    0    0    0      0      0      0      0         0",
              "%i    0    0    0    0      0      0      0      0         0",
              "/* synthetic test file"]
    for e in range(epochs):
        mins = 15 * e
        sec = seconds[e] if seconds and e in seconds else 0.0
        hh, mm = divmod(mins, 60)
        if seconds and e in seconds and sec >= 60.0:
            mm -= 1
        lines.append(f"*  2024  6 24 {hh:2d} {mm:2d} {sec:11.8f}")
        body_sats = list(sats) + ([extra_body_sat] if extra_body_sat and e == 1 else [])
        for j, s in enumerate(body_sats):
            if (e, s) in drop:
                continue
            x, y, z = 20000.0 + 10 * j + e, -15000.0 + j, 5000.0 - e
            clk = 100.0 + j + 0.001 * e
            if (e, s, "pos") in bad:
                x = y = z = 0.0
            if (e, s, "clk") in bad:
                clk = 999999.999999
            lines.append(f"P{s:>3s}{x:14.6f}{y:14.6f}{z:14.6f}{clk:14.6f}")
            if velocity and (e, s, "vel") not in drop:
                lines.append(f"V{s:>3s}{10000.0 + j:14.6f}{-20000.0:14.6f}{30000.0:14.6f}{1.5:14.6f}")
    if eof:
        lines.append("EOF")
    return ("\n".join(lines) + "\n").encode()


SATS = ["G01", "G02", "E11", "R05"]


def test_basic_values_units_and_header():
    sp3 = read_sp3(sp3_text(SATS, 3, velocity=True), name="t.sp3")
    assert sp3.version == "d" and sp3.pos_vel_flag == "V" and sp3.sats == SATS
    assert sp3.coordinate_system == "IGS20" and sp3.agency == "TST" and sp3.time_system == "GPS"
    assert sp3.time.iso(0) == ["2024-06-24T00:00:00", "2024-06-24T00:15:00", "2024-06-24T00:30:00"]
    assert sp3.position_ecef_m.shape == (3, 4, 3)
    np.testing.assert_array_equal(sp3.position_ecef_m[1, 2], [20021.0e3, -14998.0e3, 4999.0e3])
    assert sp3.clock_s[1, 2] == pytest.approx(102.001e-6, rel=1e-15)
    np.testing.assert_allclose(sp3.velocity_ecef_m_s[0, 1], [1000.1, -2000.0, 3000.0], rtol=1e-15)  # dm/s -> m/s
    assert sp3.clock_rate_s_s[0, 0] == pytest.approx(1.5e-10, rel=1e-15)
    assert sp3.warnings == []


def test_quirk_epoch_seconds_60_rolls_over():
    """RINEX-QUIRKS SP3: 'An epoch line with seconds 60.000'."""
    sp3 = read_sp3(sp3_text(SATS, 3, seconds={1: 60.0}), name="t.sp3")
    text = sp3_text(SATS, 3, seconds={1: 60.0}).decode()
    assert "*  2024  6 24  0 14 60.00000000" in text
    assert sp3.time.iso(0)[1] == "2024-06-24T00:15:00"
    assert any(w.code == "epoch-seconds-60" for w in sp3.warnings)


def test_quirk_sp3d_more_than_85_satellites():
    """RINEX-QUIRKS SP3: 'SP3-d headers with more than 85 satellites (more + lines)'."""
    sats = [f"{s}{p:02d}" for s in "GREC" for p in range(1, 28)]  # 108 satellites, 7 '+' lines
    raw = sp3_text(sats, 2)
    assert sum(1 for ln in raw.decode().split("\n") if ln.startswith("+ ")) == 7
    sp3 = read_sp3(raw, name="big.sp3")
    assert sp3.sats == sats and sp3.position_ecef_m.shape == (2, 108, 3)
    assert np.isfinite(sp3.position_ecef_m).all()
    assert sp3.position_ecef_m[1, 107, 0] == (20000.0 + 1070 + 1) * 1e3


def test_quirk_body_satellite_not_in_header_is_read_under_its_own_id():
    """A satellite in the body the '+' lines do not list (gnsstk's SP3c_mgex3 has C07): records carry their ids,
    so it is added under that id with a warning; nothing is swapped (docs/reader_policy.md)."""
    base = read_sp3(sp3_text(SATS, 3), name="t.sp3")
    sp3 = read_sp3(sp3_text(SATS, 3, extra_body_sat="G09"), name="t.sp3")
    assert sp3.sats == base.sats + ["G09"]
    (w,) = [w for w in sp3.warnings if w.code == "unlisted-satellite"]
    assert "G09" in w.message and w.line_no is not None
    np.testing.assert_array_equal(sp3.position_ecef_m[:, :len(SATS)], base.position_ecef_m)
    assert np.isfinite(sp3.position_ecef_m[:, -1]).any()


def test_quirk_header_satellite_absent_from_body_is_dropped():
    """A listed satellite without any record (SP3-d of georust/rinex lists 30 of them): dropped with a warning."""
    drop = {(e, "E11") for e in range(3)}
    base = read_sp3(sp3_text(SATS, 3), name="t.sp3")
    sp3 = read_sp3(sp3_text(SATS, 3, drop=drop), name="t.sp3")
    assert sp3.sats == [s for s in base.sats if s != "E11"]
    (w,) = [w for w in sp3.warnings if w.code == "listed-without-records"]
    assert "E11" in w.message and w.line_no == 3
    keep = [base.sats.index(s) for s in sp3.sats]
    np.testing.assert_array_equal(sp3.position_ecef_m, base.position_ecef_m[:, keep])
    # Absent at one epoch only: tolerated as NaN, counted.
    sp3 = read_sp3(sp3_text(SATS, 3, drop={(1, "E11")}), name="t.sp3")
    assert np.isnan(sp3.position_ecef_m[1, 2]).all() and np.isfinite(sp3.position_ecef_m[0, 2]).all()
    assert any(w.code == "missing-records" for w in sp3.warnings)


def test_header_count_disagreeing_with_listed_ids_is_refused():
    raw = sp3_text(SATS, 2).decode().replace("+    4   ", "+    5   ", 1)
    with pytest.raises(ParseError, match="exactly 5 satellite ids"):
        read_sp3(raw.encode(), name="t.sp3")


def test_quirk_missing_velocity_records_and_bad_values():
    """RINEX-QUIRKS SP3: 'Missing velocity records, and the bad or absent value 999999.999999'."""
    raw = sp3_text(SATS, 3, velocity=True, drop={(2, "G02", "vel")}, bad={(1, "G01", "clk"), (0, "R05", "pos")})
    sp3 = read_sp3(raw, name="t.sp3")
    assert np.isnan(sp3.velocity_ecef_m_s[2, 1]).all() and np.isfinite(sp3.velocity_ecef_m_s[1, 1]).all()
    assert np.isfinite(sp3.position_ecef_m[2, 1]).all()
    assert any(w.code == "missing-velocity" for w in sp3.warnings)
    assert np.isnan(sp3.clock_s[1, 0]) and np.isfinite(sp3.position_ecef_m[1, 0]).all()
    assert np.isnan(sp3.position_ecef_m[0, 3]).all() and np.isfinite(sp3.clock_s[0, 3])


def test_eof_line_and_missing_eof():
    sp3 = read_sp3(sp3_text(SATS, 2, eof=True) + b"\n", name="t.sp3")
    assert not any(w.code == "missing-eof" for w in sp3.warnings)
    sp3 = read_sp3(sp3_text(SATS, 2, eof=False), name="t.sp3")
    assert any(w.code == "missing-eof" for w in sp3.warnings)
    with pytest.raises(ParseError, match="after the 'EOF'"):
        read_sp3(sp3_text(SATS, 2) + b"PG01  1.0  2.0\n", name="t.sp3")


@pytest.mark.parametrize("old, new, line", [
    ("PG01  20000.000000", "PG01  20000.0000x0", 21),   # header is 19 lines, first epoch line 20
    ("*  2024  6 24  0 15", "*  2024  6 24  0 1x", 25),
    ("*  2024  6 24  0 15", "*  2024  6 24  0  0", 25),  # not increasing
    ("PR05  20030.000000", "PG01  20030.000000", 24),    # G01 twice in one epoch
])
def test_broken_sp3_raise_parse_error_with_line(old, new, line):
    raw = sp3_text(SATS, 3).decode()
    assert old in raw
    with pytest.raises(ParseError) as info:
        read_sp3(raw.replace(old, new, 1).encode(), name="t.sp3")
    assert info.value.line_no == line and info.value.path == "t.sp3"


# --- real files ------------------------------------------------------------------------------------------

def test_real_cod_sp3c_against_georinex():
    georinex = require_module("georinex")
    path = real_set("leo_grace_a_2007080") / "cod14193.sp3.gz"
    sp3 = read_sp3(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = georinex.load_sp3(path, None)
    assert sp3.sats == [str(s) for s in ds.sv.values] and len(sp3.sats) == 43
    t_ms = ds.time.values.astype("datetime64[ms]").astype(np.int64)
    ours_ms = (sp3.time.s + 315964800) * 1000 + np.round(sp3.time.frac * 1000).astype(np.int64)
    np.testing.assert_array_equal(ours_ms, t_ms)
    theirs_pos = ds.position.values * 1000.0  # km -> m
    ok = np.isfinite(sp3.position_ecef_m)
    np.testing.assert_array_equal(sp3.position_ecef_m[ok], theirs_pos[ok])
    theirs_clk = ds.clock.values
    okc = np.isfinite(sp3.clock_s)
    np.testing.assert_array_equal(sp3.clock_s[okc], theirs_clk[okc] * 1e-6)
    assert np.all(theirs_clk[~okc] >= 999999.0)  # georinex keeps the bad-value sentinel; we give NaN
    assert okc.sum() == 96 * 43 - 1248 and sp3.velocity_ecef_m_s is None


def test_real_grace_sp3b_leo():
    sp3 = read_sp3(real_set("leo_grace_a_2007080") / "GRAA_07_080.sp3.gz")
    assert sp3.version == "b" and sp3.sats == ["L09"] and len(sp3.time) == 1443
    assert sp3.coordinate_system == "IGS00" and sp3.agency == "JPL"
    assert sp3.time[0].iso(0) == "2007-03-20T23:59:00" and sp3.time[1442].iso(0) == "2007-03-22T00:01:00"
    r_m = np.linalg.norm(sp3.position_ecef_m[:, 0], axis=-1)
    assert np.all((r_m > 6.7e6) & (r_m < 6.9e6))  # GRACE at ~450-500 km altitude
    assert np.isnan(sp3.clock_s).all()  # 999999.999999 throughout
    s = summarize_sp3(real_set("leo_grace_a_2007080") / "GRAA_07_080.sp3.gz")
    assert s["format"] == "SP3-b" and s["valid_positions"] == 1443 and s["valid_clocks"] == 0
    assert [w["code"] for w in s["warnings"]] == ["missing-eof"]
