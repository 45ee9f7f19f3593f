"""worker.gnss.positioning: SPP on real data against independent truths.

- GRACE-A 2007-03-21 (RINEX 2.10 P1/P2/C1, 10 s) against the JPL reduced-dynamic orbit (centre of mass; the
  decimetre CoM-antenna offset is ignored), first hour (360 epochs). Measured here (see docs/design/positioning.md):
  broadcast 3.3 m RMS 3-D code-only (2.1 m carrier-smoothed), CODE SP3/CLK 2.9 m code-only, 2.0 m smoothed.
- Nagoya 2024 static mosaic-X5 pair against the README's RTK positions: IF solutions 1.0 / 1.7 m from truth.
"""
from __future__ import annotations

import copy

import numpy as np
import pytest

from tests.conftest import real_set
from worker.gnss.ephemeris import BroadcastEphemeris, PreciseEphemeris
from worker.gnss.frames import enu, geodetic_to_ecef
from worker.gnss.positioning import (FLAG_NO_VELOCITY, FLAG_TOO_FEW, hatch_smooth, klobuchar_l1_delay_s,
                                     saastamoinen_delay_m, spp)
from worker.gnss.time import GpsTime

GRACE = "leo_grace_a_2007080"
NAGOYA = "static_1m_mosaicx5_nagoya_2024"
GRACE_EPOCHS = slice(0, 360)  # the first hour: 2 revolutions' worth of geometry changes in 360 fixes

# Tolerances (reasons):
BROADCAST_RMS_M = 5.0     # issue 4 Done-when: broadcast SPP of GRACE-A within 5 m RMS 3-D
PRECISE_RMS_M = 2.5       # issue target 2 m; measured 2.0 m smoothed on this hour (satellite antenna offsets with
                          # CoM orbits and no ANTEX leave ~1 m per-block range biases, see the design note)
PRECISE_MEDIAN_M = 2.0
LEO_VELOCITY_M_S = 0.5    # phase-rate central difference at 10 s errs by range jerk x dt^2/6: measured 0.27 m/s
STATIC_MEAN_3D_M = 3.0    # "within a few metres": IF code SPP with broadcast orbits, 5 min average
STATIC_VEL_M_S = 0.05     # Doppler velocity of a static receiver (measured 0.013 m/s per axis RMS)


@pytest.fixture(scope="module")
def grace():
    from worker.gnss.io.rinex_clock import read_rinex_clock
    from worker.gnss.io.rinex_nav import read_rinex_nav
    from worker.gnss.io.rinex_obs import read_rinex_obs
    from worker.gnss.io.sp3 import read_sp3

    d = real_set(GRACE)
    return dict(nav=read_rinex_nav(d / "brdc0800.07n.gz"), sp3=read_sp3(d / "cod14193.sp3.gz"),
                clk=read_rinex_clock(d / "cod14193.clk.gz"), ref=read_sp3(d / "GRAA_07_080.sp3.gz"),
                obs=read_rinex_obs(d / "graa0800.07o.gz"))


def _grace_errors(sol, ref):
    from worker.gnss.orbits.sp3_interp import interpolate_sp3, interpolate_sp3_velocity

    pos, _ = interpolate_sp3(ref, ["L09"], sol.time)  # the reference at the reception time in GPS time
    vel = interpolate_sp3_velocity(ref, ["L09"], sol.time)
    return (np.linalg.norm(sol.position_ecef_m - pos[:, 0], axis=1),
            np.linalg.norm(sol.velocity_ecef_m_s - vel[:, 0], axis=1))


def test_grace_broadcast_spp_within_5_m(grace):
    sol = spp(grace["obs"], BroadcastEphemeris(grace["nav"]), epochs=GRACE_EPOCHS)
    e3, ev = _grace_errors(sol, grace["ref"])
    assert sol.valid.all()
    rms = float(np.sqrt(np.mean(e3 ** 2)))
    assert rms < BROADCAST_RMS_M, rms
    assert np.all(sol.iono_free[sol.used])  # P1/P2 everywhere on this receiver
    assert sol.velocity_source == "phase-rate"  # the file has no Doppler
    assert np.sqrt(np.nanmean(ev ** 2)) < LEO_VELOCITY_M_S
    # spaceborne: no elevation mask, satellites below the local horizon are used
    assert np.nanmin(np.where(sol.used, sol.elevation_deg, np.nan)) < 0.0
    # the receiver clock is steered (BlackJack): tens of ns at most
    assert np.nanmax(np.abs(sol.clock_s)) < 1e-6


def test_grace_precise_spp_smoothed(grace):
    eph = PreciseEphemeris(grace["sp3"], grace["clk"])
    raw = spp(grace["obs"], eph, epochs=GRACE_EPOCHS)
    sm = spp(grace["obs"], eph, epochs=GRACE_EPOCHS, smoothing_window_s=600.0)
    e_raw, _ = _grace_errors(raw, grace["ref"])
    e_sm, _ = _grace_errors(sm, grace["ref"])
    assert sm.valid.mean() > 0.99  # one epoch of the hour has 4 satellites with CODE clocks: no fix
    e_raw, e_sm = e_raw[sm.valid & raw.valid], e_sm[sm.valid & raw.valid]
    rms_raw, rms_sm = (float(np.sqrt(np.mean(e ** 2))) for e in (e_raw, e_sm))
    assert rms_sm < PRECISE_RMS_M, (rms_raw, rms_sm)
    assert np.median(e_sm) < PRECISE_MEDIAN_M
    assert rms_sm < rms_raw  # smoothing the code with the phase must help
    # post-fit residuals of the smoothed code are sub-metre
    assert np.sqrt(np.nanmean(sm.residuals_m ** 2)) < 1.0


@pytest.fixture(scope="module")
def nagoya():
    from worker.gnss.io.rinex_nav import read_rinex_nav
    from worker.gnss.io.rinex_obs import read_rinex_obs

    d = real_set(NAGOYA)
    out = {"eph": BroadcastEphemeris(read_rinex_nav(d / "base.nav"))}
    for name in ("base", "rover"):
        lat, lon, h = np.loadtxt(d / f"{name}_position.txt").ravel()[:3]
        out[name] = (read_rinex_obs(d / f"{name}.obs"), geodetic_to_ecef(np.radians(lat), np.radians(lon), h))
    return out


@pytest.mark.parametrize("name", ["base", "rover"])
def test_nagoya_static_within_a_few_metres(nagoya, name):
    obs, truth = nagoya[name]
    sol = spp(obs, nagoya["eph"])
    d_enu = enu(truth, sol.position_ecef_m)
    assert sol.valid.all() and (sol.flags == 0).all()
    assert np.linalg.norm(d_enu.mean(axis=0)) < STATIC_MEAN_3D_M
    assert np.percentile(np.linalg.norm(d_enu, axis=1), 95) < 2 * STATIC_MEAN_3D_M
    assert sol.velocity_source == "doppler"
    assert np.sqrt(np.mean(sol.velocity_ecef_m_s ** 2)) < STATIC_VEL_M_S
    # These receivers run their clocks a quarter millisecond off GPS time (base -0.245 ms, rover +0.266 ms):
    # the reason alignment exists. The drift is a fraction of a ppm.
    assert 1e-4 < np.abs(sol.clock_s).min() and np.abs(sol.clock_s).max() < 1e-3
    assert np.abs(sol.clock_drift_s_s).max() < 1e-6
    # single frequency with Klobuchar still within ~5 m (measured 4.0 m)
    sf = spp(obs, nagoya["eph"], iono_free=False)
    assert not sf.iono_free.any()
    assert np.linalg.norm(enu(truth, sf.position_ecef_m).mean(axis=0)) < 2 * STATIC_MEAN_3D_M


def test_raim_excludes_an_injected_fault(nagoya):
    obs, truth = nagoya["base"]
    bad = copy.copy(obs)
    bad.values = obs.values.copy()
    j = obs.sats.index("G13")
    for code in ("C1C", "C2W", "C2L"):
        bad.values[:, j, obs.codes.index(code)] += 80.0  # an 80 m code fault on both bands
    sol = spp(bad, nagoya["eph"])
    col = sol.sats.index("G13")
    assert sol.excluded[:, col].mean() > 0.95
    assert np.linalg.norm(enu(truth, sol.position_ecef_m).mean(axis=0)) < STATIC_MEAN_3D_M
    no_raim = spp(bad, nagoya["eph"], raim_max_exclusions=0)
    assert np.linalg.norm(enu(truth, no_raim.position_ecef_m).mean(axis=0)) > 2 * STATIC_MEAN_3D_M


def test_too_few_satellites_flagged(nagoya):
    obs, _ = nagoya["base"]
    few = copy.copy(obs)
    few.values = obs.values.copy()
    keep = [obs.sats.index(s) for s in ("G05", "G07", "G13")]
    drop = np.setdiff1d(np.arange(len(obs.sats)), keep)
    few.values[:, drop] = np.nan
    sol = spp(few, nagoya["eph"], epochs=slice(0, 5))
    assert np.all(sol.flags & FLAG_TOO_FEW) and np.all(sol.flags & FLAG_NO_VELOCITY)
    assert np.isnan(sol.position_ecef_m).all() and not sol.valid.any()


def test_atmosphere_models_known_values():
    # Saastamoinen, standard atmosphere, sea level, zenith: 2.3 m hydrostatic + ~0.1 m wet (RTKLIB tropmodel).
    z = saastamoinen_delay_m(np.radians(35.0), 0.0, np.radians(90.0))
    assert 2.3 < z < 2.6
    assert saastamoinen_delay_m(np.radians(35.0), 0.0, np.radians(10.0)) == pytest.approx(z / np.sin(np.radians(10)))
    assert saastamoinen_delay_m(0.0, 450e3, np.radians(45.0)) == 0.0  # spacecraft
    # Klobuchar at night is the 5 ns floor times the obliquity factor F = 1 + 16 (0.53 - E)^3 (IS-GPS-200 20-4)
    alpha, beta = [1.118e-08, 7.451e-09, -5.960e-08, -5.960e-08], [9.011e04, 1.638e04, -1.966e05, -6.554e04]
    night = klobuchar_l1_delay_s(alpha, beta, 0.0, 0.0, 0.0, np.pi / 2, 0.0)  # local midnight at lon 0
    assert night == pytest.approx(5e-9 * (1 + 16 * (0.53 - 0.5) ** 3))
    noon = klobuchar_l1_delay_s(alpha, beta, 0.0, 0.0, 0.0, np.pi / 2, 50400.0)  # 14 h local: the maximum
    assert 10e-9 < noon < 100e-9
    low = klobuchar_l1_delay_s(alpha, beta, 0.0, 0.0, 0.0, np.radians(5.0), 50400.0)
    assert 2.5 < low / noon < 3.5  # obliquity near the horizon


def test_hatch_filter_restarts_and_averages():
    rng = np.random.default_rng(1)
    n = 200
    t = GpsTime(np.arange(n) + 1_000_000_000, np.zeros(n))
    rng_true = 2.0e7 + 500.0 * np.arange(n)
    code = (rng_true + rng.normal(0, 1.0, n))[:, None]
    phase = (rng_true + 12345.6)[:, None]
    phase[120:] += 0.19 * 7  # an undetected slip: the code-prediction test cannot see 1.3 m
    slip = np.zeros((n, 1), bool)
    slip[150] = True  # a flagged slip restarts the filter
    sm, count = hatch_smooth(code, phase, slip, t, 100.0, max_gap_s=1.5, reset_threshold_m=20.0)
    assert count[99, 0] == 100 and count[150, 0] == 1 and count[199, 0] == 50
    assert np.std(sm[60:100, 0] - rng_true[60:100]) < 0.3  # ~1/sqrt(100) of the code noise, plus memory
    assert sm[150, 0] == code[150, 0]
    big = code.copy()
    big[170] += 300.0  # a code-only 1 ms clock jump would be 300 km; 300 m is enough to restart
    _, count2 = hatch_smooth(big, phase, slip, t, 100.0, max_gap_s=1.5, reset_threshold_m=20.0)
    assert count2[170, 0] == 1
