"""gnssatt.gnss.positioning: SPP on real data against independent truths.

- GRACE-A 2007-03-21 (RINEX 2.10 P1/P2/C1, 10 s) against the JPL reduced-dynamic orbit (centre of mass; the
  antenna sits ~0.5 m above it: the solutions' mean radial offset, +0.5 m, is left in the error). Broadcast on the
  first hour; CODE SP3/CLK on the first 3 hours (1080 epochs), with the default model: igs05 satellite antenna
  offsets (PreciseEphemeris), C/N0 weighting from the signal-strength digits, batch variance calibration, RAIM
  and arc screening. Measured here (docs/design/positioning.md): CODE 1.37 m RMS 3-D code-only, 0.66 m
  carrier-smoothed (600 s); without the satellite antenna offsets 2.55 m; with the previous model (elevation
  weights, no calibration, no arc screening) 2.35 m. Whole day (bench): 1.47 m and 0.67 m.
- Nagoya 2024 static mosaic-X5 pair against the README's RTK positions: IF solutions 1.4 / 1.1 m from truth (base /
  rover, C/N0 weights; 1.7 / 1.0 m with elevation weights).
"""
from __future__ import annotations

import copy

import numpy as np
import pytest

from tests.conftest import real_set
from gnssatt.gnss.ephemeris import BroadcastEphemeris, PreciseEphemeris
from gnssatt.gnss.frames import enu, geodetic_to_ecef
from gnssatt.gnss.positioning import (FLAG_NO_VELOCITY, FLAG_NOT_CONVERGED, FLAG_TOO_FEW, SppOptions,
                                     hatch_smooth, klobuchar_l1_delay_s, saastamoinen_delay_m, spp)
from gnssatt.gnss.time import GpsTime

GRACE = "leo_grace_a_2007080"
NAGOYA = "static_1m_mosaicx5_nagoya_2024"
GRACE_EPOCHS = slice(0, 360)  # the first hour: 2 revolutions' worth of geometry changes in 360 fixes
GRACE_PRECISE_EPOCHS = slice(0, 1080)  # the first 3 hours
GRACE_BIASED_PASS = slice(4140, 4400)  # 11:30-12:13: G25 tracked 15 m off for 39 min (a whole pass)

# Tolerances (reasons):
BROADCAST_RMS_M = 5.0     # issue 4 Done-when: broadcast SPP of GRACE-A within 5 m RMS 3-D
PRECISE_RMS_M = 2.0       # issue 4 Done-when: CODE SP3/CLK within 2 m RMS 3-D (measured 1.37 m code-only)
PRECISE_SMOOTHED_RMS_M = 1.0   # carrier-smoothed, measured 0.66 m (0.5 m of it the CoM-antenna offset)
ANTENNA_OFFSET_GAIN_M = 0.5    # the CoM orbit without satellite antenna offsets: measured 2.55 m vs 1.37 m
OLD_MODEL_GAIN_M = 0.5         # elevation weights, no calibration/screening: measured 2.35 m vs 1.37 m
BIASED_PASS_RMS_M = 2.5        # with arc screening, measured 1.98 m (6.2 m without: 38 m at 5-satellite epochs)
LEO_VELOCITY_M_S = 0.5    # phase-rate central difference at 10 s errs by range jerk x dt^2/6: measured 0.27 m/s
STATIC_MEAN_3D_M = 3.0    # "within a few metres": IF code SPP with broadcast orbits, 5 min average
STATIC_VEL_M_S = 0.05     # Doppler velocity of a static receiver (measured 0.013 m/s per axis RMS)


@pytest.fixture(scope="module")
def grace():
    from gnssatt.gnss.io.rinex_clock import read_rinex_clock
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs
    from gnssatt.gnss.io.sp3 import read_sp3

    d = real_set(GRACE)
    return dict(nav=read_rinex_nav(d / "brdc0800.07n.gz"), sp3=read_sp3(d / "cod14193.sp3.gz"),
                clk=read_rinex_clock(d / "cod14193.clk.gz"), ref=read_sp3(d / "GRAA_07_080.sp3.gz"),
                obs=read_rinex_obs(d / "graa0800.07o.gz"))


def _grace_errors(sol, ref):
    from gnssatt.gnss.orbits.sp3_interp import interpolate_sp3, interpolate_sp3_velocity

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


def _rms(e):
    return float(np.sqrt(np.mean(e ** 2)))


def test_grace_precise_spp_within_2_m(grace):
    eph = PreciseEphemeris(grace["sp3"], grace["clk"])
    assert eph.antenna_offsets is not None  # IGS05 product -> the built-in igs05.atx satellite offsets
    raw = spp(grace["obs"], eph, epochs=GRACE_PRECISE_EPOCHS)
    sm = spp(grace["obs"], eph, SppOptions(smoothing_window_s=600.0), epochs=GRACE_PRECISE_EPOCHS)
    assert sm.valid.mean() > 0.99  # one epoch has 4 satellites with CODE clocks: no fix
    ok = sm.valid & raw.valid
    e_raw, e_sm = (_grace_errors(s, grace["ref"])[0][ok] for s in (raw, sm))
    assert _rms(e_raw) < PRECISE_RMS_M, _rms(e_raw)
    assert _rms(e_sm) < PRECISE_SMOOTHED_RMS_M, _rms(e_sm)
    assert _rms(e_sm) < _rms(e_raw)  # smoothing the code with the phase must help
    # the receiver's signal strength digits are there: C/N0 weights; the BlackJack's P-code noise is ~1/3 of the
    # a-priori 0.3 m at 51 dB-Hz, which the batch variance factor finds
    assert raw.weighting == "cn0" and 0.02 < raw.variance_factor < 0.5, raw.variance_factor
    # post-fit residuals of the smoothed code: decimetres for most rows (limb rows have little weight)
    assert np.median(np.abs(sm.residuals_m[sm.used])) < 0.2
    assert (sm.flags & (FLAG_TOO_FEW | FLAG_NOT_CONVERGED))[sm.valid].sum() == 0


def test_grace_precise_needs_the_satellite_antenna_offsets(grace):
    apc = spp(grace["obs"], PreciseEphemeris(grace["sp3"], grace["clk"]), epochs=GRACE_PRECISE_EPOCHS)
    com = spp(grace["obs"], PreciseEphemeris(grace["sp3"], grace["clk"], antenna_offsets=None),
              epochs=GRACE_PRECISE_EPOCHS)
    ok = apc.valid & com.valid
    e_apc, e_com = (_grace_errors(s, grace["ref"])[0][ok] for s in (apc, com))
    assert _rms(e_com) > _rms(e_apc) + ANTENNA_OFFSET_GAIN_M, (_rms(e_com), _rms(e_apc))


def test_grace_weighting_and_calibration_beat_the_flat_model(grace):
    eph = PreciseEphemeris(grace["sp3"], grace["clk"])
    new = spp(grace["obs"], eph, epochs=GRACE_PRECISE_EPOCHS)
    old = spp(grace["obs"], eph, SppOptions(weighting="elevation", calibrate_variance=False, arc_screening=False,
                                            smooth_variance=False), epochs=GRACE_PRECISE_EPOCHS)
    assert old.weighting == "elevation" and old.variance_factor == 1.0 and not old.arc_excluded.any()
    ok = new.valid & old.valid
    e_new, e_old = (_grace_errors(s, grace["ref"])[0][ok] for s in (new, old))
    assert _rms(e_old) > _rms(e_new) + OLD_MODEL_GAIN_M, (_rms(e_old), _rms(e_new))
    # calibrated: the a-priori noise scale hardly matters (the factor absorbs it)
    other = spp(grace["obs"], eph, SppOptions(sigma_code_m=0.1), epochs=GRACE_PRECISE_EPOCHS)
    assert other.variance_factor == pytest.approx(new.variance_factor * 9.0, rel=0.2)
    d = np.linalg.norm(other.position_ecef_m - new.position_ecef_m, axis=1)
    assert np.nanmedian(d) < 0.01 and np.sqrt(np.nanmean(d ** 2)) < 0.3


def test_grace_arc_screening_removes_a_biased_pass(grace):
    """G25 from 11:32 to 12:11 is 15 m off for the whole pass (code and phase agree: a channel bias); RAIM sees it
    at most epochs, not at the few with 5 satellites, where the fix took it (38 m errors)."""
    eph = PreciseEphemeris(grace["sp3"], grace["clk"])
    on = spp(grace["obs"], eph, epochs=GRACE_BIASED_PASS)
    off = spp(grace["obs"], eph, SppOptions(arc_screening=False), epochs=GRACE_BIASED_PASS)
    j = on.sats.index("G25")
    main = slice(4154 - GRACE_BIASED_PASS.start, 4388 - GRACE_BIASED_PASS.start)  # the pass, 11:32:20-12:11:20
    assert on.arc_excluded[main, j].all() and not on.used[main, j].any()
    assert not off.arc_excluded.any() and off.used[main, j].any()
    assert not np.delete(on.arc_excluded, j, axis=1).any()  # nothing else in this stretch
    e_on, e_off = (_grace_errors(s, grace["ref"])[0] for s in (on, off))
    assert _rms(e_on) < BIASED_PASS_RMS_M < 2 * BIASED_PASS_RMS_M < _rms(e_off), (_rms(e_on), _rms(e_off))


@pytest.fixture(scope="module")
def nagoya():
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs

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
    sf = spp(obs, nagoya["eph"], SppOptions(iono_free=False))
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
    no_raim = spp(bad, nagoya["eph"], SppOptions(raim_max_exclusions=0))
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


def test_arc_exclusions_rule():
    from gnssatt.gnss.positioning import _arc_exclusions

    n = 20
    t = GpsTime(np.arange(n) * 10 + 1_000_000_000, np.zeros(n))
    present = np.zeros((n, 3), bool)
    present[:, 0] = True                  # one arc, excluded 12 times of 20 -> whole arc
    present[:10, 1] = present[12:, 1] = True  # two arcs (gap at 10-11); the second excluded 2 of 8 -> kept
    present[:, 2] = True                  # excluded 2 of 20 -> kept
    excl = np.zeros((n, 3), bool)
    excl[:12, 0] = True
    excl[:10, 1] = True                   # first arc of satellite 1 always excluded -> that arc only
    excl[14:16, 1] = True
    excl[[3, 9], 2] = True
    fixed = np.ones(n, bool)
    out = _arc_exclusions(present, excl, fixed, t)
    assert out[:, 0].all()
    assert out[:10, 1].all() and not out[10:, 1].any()
    assert not out[:, 2].any()
    # unfixed epochs do not count: with only 2 fixed epochs in satellite 0's arc, 2 exclusions are too few
    fixed2 = np.zeros(n, bool)
    fixed2[:2] = True
    assert not _arc_exclusions(present, excl, fixed2, t)[:, 0].any()


def test_weighting_auto_falls_back_to_elevation_without_signal_strength(grace):
    obs = copy.copy(grace["obs"])
    obs.ssi = np.full_like(grace["obs"].ssi, -1)
    sol = spp(obs, BroadcastEphemeris(grace["nav"]), SppOptions(velocity=False), epochs=slice(0, 30))
    assert sol.weighting == "elevation"
    assert spp(grace["obs"], BroadcastEphemeris(grace["nav"]), SppOptions(velocity=False),
               epochs=slice(0, 30)).weighting == "cn0"
    with pytest.raises(ValueError):
        spp(grace["obs"], BroadcastEphemeris(grace["nav"]), SppOptions(weighting="snr"), epochs=slice(0, 3))
