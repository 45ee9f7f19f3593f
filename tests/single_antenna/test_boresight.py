"""C/N0 boresight on simulated C/N0 from a known gain pattern: weighted mean vs pattern fit, against the 3-15 deg
of the literature seed 001 cites, and the fit's sigma against its actual error."""
from __future__ import annotations

import numpy as np

from gnssatt.gnss.time import GpsTime
from gnssatt.planning.series import reference_from_ecef
from gnssatt.planning.trajectory import Keplerian, track_from_keplerian
from gnssatt.sim.cn0_pattern import Cn0Params, simulate_cn0
from gnssatt.sim.constellation import synthetic_gps
from gnssatt.single_antenna.boresight import PATCH, pattern_fit, weighted_mean

T0 = GpsTime.from_calendar(2025, 4, 1, 10, 0, 0)


def _angle_deg(a, b):
    return float(np.degrees(np.arccos(np.clip(a @ b, -1, 1))))


def test_exact_pattern_without_noise_is_recovered():
    rng = np.random.default_rng(2)
    e = rng.normal(size=(12, 3))
    e /= np.linalg.norm(e, axis=-1, keepdims=True)
    b = np.array([0.3, -0.2, 0.93])
    b /= np.linalg.norm(b)
    cn0 = 40.0 + PATCH.gain(np.degrees(np.arccos(e @ b)))
    fit = pattern_fit(e, cn0, start=np.array([0.0, 0.0, 1.0]))
    # noise-free C/N0 from the same piecewise-linear pattern: the fit lands on the truth (to 0.01 deg)
    assert fit.ok and _angle_deg(fit.boresight, b) < 0.01 and abs(fit.c0_dbhz - 40.0) < 1e-3


def test_leo_pass_error_distribution_against_the_literature():
    const = synthetic_gps(T0)
    t = T0 + np.arange(0, 3000, 20.0)
    track = track_from_keplerian(Keplerian(T0, 7014.3e3, 0.0, 98.0, 0.0, 0.0, 0.0), t)
    bore = -reference_from_ecef(track, "orbital")[:, 2, :]            # Earth pointing, boresight to zenith
    r_sat, _ = const.position_clock(np.asarray(t - const.t_ref, float)[:, None] + np.zeros(const.n))
    cn0, e = simulate_cn0(track.r_ecef_m, r_sat, bore, PATCH, Cn0Params(), np.random.default_rng(0))
    err_mean, err_fit, sig_fit = [], [], []
    for k in range(len(t)):
        m, f = weighted_mean(e[k], cn0[k]), pattern_fit(e[k], cn0[k])
        err_mean.append(_angle_deg(m.boresight, bore[k]))
        err_fit.append(_angle_deg(f.boresight, bore[k]))
        sig_fit.append(f.sigma_deg)
    rms_mean = np.sqrt(np.mean(np.square(err_mean)))
    rms_fit = np.sqrt(np.mean(np.square(err_fit)))
    # seed 001: ~15 deg for the weighted mean (JPL), 3.2-11.9 deg rms for the pattern model (Axelrad), with
    # 1.5 dB satellite offsets and 1 dB noise here: the mean within 5-20 deg, the fit within 2-12 deg and better
    assert 5.0 < rms_mean < 20.0
    assert 2.0 < rms_fit < 12.0 and rms_fit < rms_mean
    # the fit's formal sigma (2-d direction) within a factor 1.5 of its actual rms
    assert 1 / 1.5 < np.median(sig_fit) / rms_fit < 1.5
