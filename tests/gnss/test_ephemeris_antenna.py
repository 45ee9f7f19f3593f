"""gnssatt.gnss.satellite_antenna and PreciseEphemeris(antenna_offsets=...): satellite antenna offsets for CoM orbits.

Authorities:
- the Sun: the Astronomical Almanac's low-precision formula (written out below, independently of ERFA; ~0.01 deg
  over 1950-2050) with GMST (IAU 1982, Aoki et al.) for the Earth-fixed direction;
- the offsets: igs05.atx as transcribed in IGS05_GPS_PCO, cross-checked through the ANTEX reader on a written file;
- the real effect: GRACE-A 2007-03-21 code residuals against the JPL orbit, whose per-satellite means split by
  GPS block with the CoM orbit (IIA about -0.6 m, IIR +0.2 to +1 m) and lose that split with the offsets.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from tests.conftest import real_set
from gnssatt.gnss.satellite_antenna import (IGS05_GPS_PCO, SatelliteAntennaOffsets, default_offsets_for_sp3,
                                           satellite_body_axes_ecef, sun_position_ecef_m)
from gnssatt.gnss.time import GpsTime

GRACE = "leo_grace_a_2007080"
DAY = GpsTime.from_calendar(2007, 3, 21)

# Tolerances (reasons):
SUN_DIRECTION_DEG = 0.05   # AA low-precision formula 0.01 deg; GMST vs the IAU 2006 chain and UT1 = UTC ~0.005 deg
BLOCK_SPLIT_COM_M = 0.8    # measured 1.2 m between the IIA and IIR mean residuals with the CoM orbit
BLOCK_SPLIT_APC_M = 0.25   # measured < 0.1 m with the igs05 offsets
EACH_SAT_APC_M = 0.4       # every satellite's 6-hour mean residual with the offsets (measured |.| < 0.28 m;
                           # 0.7-1.2 m for a third of them with the CoM orbit)


def _sun_almanac_ecef_unit(year, month, day, hour_utc):
    """Unit vector to the Sun in ECEF by the Astronomical Almanac formula (sec. C5) and GMST, UT1 = UTC."""
    jd = 367 * year - (7 * (year + (month + 9) // 12)) // 4 + (275 * month) // 9 + day + 1721013.5 + hour_utc / 24
    n = jd - 2451545.0
    L = np.radians((280.460 + 0.9856474 * n) % 360)
    g = np.radians((357.528 + 0.9856003 * n) % 360)
    lam = L + np.radians(1.915) * np.sin(g) + np.radians(0.020) * np.sin(2 * g)
    eps = np.radians(23.439 - 4e-7 * n)
    u_eci = np.array([np.cos(lam), np.cos(eps) * np.sin(lam), np.sin(eps) * np.sin(lam)])
    gmst = np.radians((280.46061837 + 360.98564736629 * n) % 360)
    c, s = np.cos(gmst), np.sin(gmst)
    return np.array([c * u_eci[0] + s * u_eci[1], -s * u_eci[0] + c * u_eci[1], u_eci[2]])


@pytest.mark.parametrize("when", [(2007, 3, 21, 12.0), (2024, 6, 21, 3.5), (2010, 12, 1, 18.25)])
def test_sun_direction_matches_the_almanac(when):
    y, m, d, h = when
    leap = 14 if y == 2007 else (15 if y == 2010 else 18)  # GPS - UTC, s
    t = GpsTime.from_calendar(y, m, d) + (h * 3600.0 + leap)
    sun = sun_position_ecef_m(t)[0]
    ref = _sun_almanac_ecef_unit(y, m, d, h)
    ang = np.degrees(np.arccos(np.clip(sun @ ref / np.linalg.norm(sun), -1, 1)))
    assert ang < SUN_DIRECTION_DEG, ang
    assert 0.98 < np.linalg.norm(sun) / 1.495978707e11 < 1.02  # one astronomical unit, +- eccentricity


def test_body_axes_yaw_steering():
    rng = np.random.default_rng(3)
    r = rng.normal(size=(50, 3)) * 26.56e6 / np.sqrt(3)
    sun = np.array([1.496e11, 2e9, -5e9]) + rng.normal(size=(50, 3)) * 1e9
    ax = satellite_body_axes_ecef(r, sun)
    ex, ey, ez = ax[:, 0], ax[:, 1], ax[:, 2]
    assert np.allclose(np.einsum("nij,nkj->nik", ax, ax), np.eye(3), atol=1e-12)  # orthonormal rows
    assert np.allclose(np.cross(ex, ey), ez, atol=1e-12)  # right-handed
    assert np.allclose(ez, -r / np.linalg.norm(r, axis=1, keepdims=True))  # z to the Earth's centre
    es = sun - r
    assert np.allclose(np.einsum("ni,ni->n", ey, es), 0.0, atol=1e-3 * 1.5e11 * 1e-9)  # y normal to the Sun
    assert np.all(np.einsum("ni,ni->n", ex, es) > 0)  # +x on the Sun's side (IGS convention)


def test_igs05_table_lookup_and_validity():
    o = SatelliteAntennaOffsets.igs05()
    t = DAY + 43200.0
    pco, cov = o.pco_body_m(["G05", "G02", "G15", "G33", "E11"], t)
    assert cov.tolist() == [True, True, False, False, False]  # SVN 15 left PRN 15 on 2007-03-15
    assert np.allclose(pco[0], [0.279, 0.0, 2.463]) and np.allclose(pco[1], [0.0, 0.0, 0.614])
    assert np.all(pco[2:] == 0.0)
    # PRN 1 changes satellite (SVN 32 -> 37 -> 49): the entry follows the date
    for date, z in (((2008, 1, 1), 2.201), ((2008, 12, 1), 2.220), ((2010, 1, 1), 0.700)):
        p, c = o.pco_body_m(["G01"], GpsTime.from_calendar(*date))
        assert c[0] and p[0, 2] == pytest.approx(z)
    p, c = o.pco_body_m(["G01"], GpsTime.from_calendar(2008, 10, 20))  # between SVN 32 and SVN 37: none
    assert not c[0]
    blocks = {row[2] for row in IGS05_GPS_PCO}
    assert blocks == {"II", "IIA", "IIR-A", "IIR-B", "IIR-M", "IIF"}


def test_from_antex_agrees_with_the_table(tmp_path):
    from gnssatt.gnss.io.antex import AntennaPattern, FrequencyPattern, read_antex, write_antex

    def sat(prn, svn, block, z_mm, frm, until=None):
        zen = np.zeros(15)
        return AntennaPattern(antenna_type=f"BLOCK {block}", serial=prn, svn_code=svn, dazi_deg=0.0,
                              zen1_deg=0.0, zen2_deg=14.0, dzen_deg=1.0, valid_from=frm, valid_until=until,
                              frequencies=[FrequencyPattern("G01", np.array([279.0, 0.0, z_mm]), zen),
                                           FrequencyPattern("G02", np.array([279.0, 0.0, z_mm]), zen)])

    path = tmp_path / "sat.atx"
    path.write_text(write_antex([sat("G05", "G035", "IIA", 2463.0, GpsTime.from_calendar(1993, 8, 30),
                                     GpsTime.from_calendar(2009, 6, 9))]))
    o = SatelliteAntennaOffsets.from_antex(read_antex(path))
    t = DAY + 1000.0
    r = np.array([[15e6, 10e6, 18e6]])
    a, ca = o.offset_ecef_m(["G05"], t, r)
    b, cb = SatelliteAntennaOffsets.igs05().offset_ecef_m(["G05"], t, r)
    assert ca[0] and cb[0] and np.allclose(a, b, atol=1e-9)
    assert np.linalg.norm(a) == pytest.approx(np.hypot(0.279, 2.463))
    # the z offset points to the Earth: the APC is 2.46 m closer to the geocentre
    assert np.linalg.norm(r + a) - np.linalg.norm(r) == pytest.approx(-2.463, abs=0.02)


@pytest.fixture(scope="module")
def grace():
    from gnssatt.gnss.io.rinex_clock import read_rinex_clock
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs
    from gnssatt.gnss.io.sp3 import read_sp3

    d = real_set(GRACE)
    return dict(sp3=read_sp3(d / "cod14193.sp3.gz"), clk=read_rinex_clock(d / "cod14193.clk.gz"),
                ref=read_sp3(d / "GRAA_07_080.sp3.gz"), obs=read_rinex_obs(d / "graa0800.07o.gz"))


def _mean_residual_per_satellite(grace, eph, n_epochs=2160):
    """Per-satellite mean of the ionosphere-free code minus the range from the JPL orbit (6 h, clock removed)."""
    from gnssatt.gnss.constants import C_M_S
    from gnssatt.gnss.signals import FREQ_GPS_L1_HZ, FREQ_GPS_L2_HZ
    from gnssatt.gnss.geometry import sagnac_rotate
    from gnssatt.gnss.orbits.sp3_interp import interpolate_sp3

    obs = grace["obs"]
    P1 = obs.get("C1W", "G")[:n_epochs]
    P2 = obs.get("C2W", "G")[:n_epochs]
    g = FREQ_GPS_L1_HZ ** 2 / (FREQ_GPS_L1_HZ ** 2 - FREQ_GPS_L2_HZ ** 2)
    pif = g * P1 - (g - 1.0) * P2
    t = obs.time[:n_epochs]
    r_rx = interpolate_sp3(grace["ref"], ["L09"], t)[0][:, 0]  # CoM; the receiver clock is < 1 us: < 1 cm
    ii, jj = np.nonzero(np.isfinite(pif))
    sats = np.array(obs.sats)[jj]
    t_tx = GpsTime(t.s[ii], t.frac[ii]) - P1[ii, jj] / C_M_S
    st = eph.state(sats, t_tx)
    st = eph.state(sats, t_tx - np.nan_to_num(st.clock_s))
    rs = sagnac_rotate(st.r_ecef_m, np.linalg.norm(st.r_ecef_m - r_rx[ii], axis=1) / C_M_S)
    res = np.full(pif.shape, np.nan)
    res[ii, jj] = pif[ii, jj] + C_M_S * st.clock_s - np.linalg.norm(rs - r_rx[ii], axis=1)
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # epochs without a satellite
        res -= np.nanmedian(res, axis=1, keepdims=True)  # receiver clock
    res[np.abs(res) > 5.0] = np.nan  # the receiver's gross code errors (arcs tens of metres off)
    return {s: float(np.nanmean(res[:, j])) for j, s in enumerate(obs.sats)
            if np.isfinite(res[:, j]).sum() > 30}


def test_grace_code_residuals_lose_their_block_split(grace):
    from gnssatt.gnss.ephemeris import PreciseEphemeris

    block = {prn: b for prn, _, b, frm, until, _ in IGS05_GPS_PCO
             if frm <= "2007-03-21" and (until is None or until > "2007-03-21")}
    assert default_offsets_for_sp3(grace["sp3"]) is not None  # cod14193.sp3 declares IGS05
    split = {}
    for name, offsets in (("com", None), ("apc", "auto")):
        eph = PreciseEphemeris(grace["sp3"], grace["clk"], antenna_offsets=offsets)
        mean = _mean_residual_per_satellite(grace, eph)
        iia = [v for s, v in mean.items() if block[s] == "IIA"]
        iir = [v for s, v in mean.items() if block[s].startswith("IIR")]
        assert len(iia) >= 4 and len(iir) >= 4
        split[name] = float(np.mean(iir) - np.mean(iia))
        if name == "apc":
            assert max(abs(v) for v in mean.values()) < EACH_SAT_APC_M, mean
    assert split["com"] > BLOCK_SPLIT_COM_M and abs(split["apc"]) < BLOCK_SPLIT_APC_M, split
