"""The geomagnetic reference field in ECEF from IGRF-14 (the ppigrf package), refusing dates outside the model.

B_ecef = B_r e_r + B_theta e_theta + B_phi e_phi with, at geocentric colatitude theta and longitude phi,
e_r = (sin t cos p, sin t sin p, cos t), e_theta = (cos t cos p, cos t sin p, -sin t), e_phi = (-sin p, cos p, 0).

Implements: IGRF-14 (Alken et al. 2025, IAGA V-MOD; definitive to 2020, secular variation to 2030) as
evaluated by ppigrf.igrf_gc (degree 13 spherical harmonic synthesis in geocentric coordinates).
Neglects: the crustal field (IGRF stops at degree 13: errors of order 100-200 nT at the surface, seed 001's
140 nT horizontal / 200 nT down for WMM) and external (magnetospheric, ionospheric) fields; the secular
variation within one call (one date for all points: ~100 nT/yr, 0.01 nT per hour).
"""
from __future__ import annotations

import datetime as _dt

import numpy as np

MODEL_NAME = "IGRF-14"
#: the span of the IGRF-14 coefficients (ppigrf's IGRF14.shc): 1900.0 to 2030.0
VALID_FROM = _dt.datetime(1900, 1, 1)
VALID_UNTIL = _dt.datetime(2030, 1, 1)


def model_date(t) -> _dt.datetime:
    """The UTC-ish calendar datetime of GPS time t (scalar GpsTime); leap seconds do not matter here."""
    y, mo, d, hh, mi, ss = (np.asarray(x).ravel()[0] for x in t.calendar())
    return _dt.datetime(int(y), int(mo), int(d), int(hh), int(mi)) + _dt.timedelta(seconds=float(ss))


def field_ecef_nT(r_ecef_m, date: _dt.datetime) -> np.ndarray:
    """IGRF-14 main field (..., 3) in nT, ECEF axes, at ECEF positions (..., 3) m on `date`.

    Raises ValueError for a date outside the model's span (an expired model is never extrapolated silently).
    """
    import ppigrf

    if not VALID_FROM <= date <= VALID_UNTIL:
        raise ValueError(f"{MODEL_NAME} covers {VALID_FROM.date()} to {VALID_UNTIL.date()}; the data are of "
                         f"{date.date()}: no geomagnetic model for that date")
    r = np.asarray(r_ecef_m, dtype=np.float64)
    shape = r.shape
    r = r.reshape(-1, 3)
    rn = np.linalg.norm(r, axis=-1)
    theta = np.arccos(np.clip(r[:, 2] / rn, -1, 1))
    phi = np.arctan2(r[:, 1], r[:, 0])
    br, bt, bp = ppigrf.igrf_gc(rn / 1e3, np.degrees(theta), np.degrees(phi), date)
    br, bt, bp = br[0], bt[0], bp[0]
    st, ct, sp, cp = np.sin(theta), np.cos(theta), np.sin(phi), np.cos(phi)
    e_r = np.stack([st * cp, st * sp, ct], -1)
    e_t = np.stack([ct * cp, ct * sp, -st], -1)
    e_p = np.stack([-sp, cp, np.zeros_like(sp)], -1)
    return (br[:, None] * e_r + bt[:, None] * e_t + bp[:, None] * e_p).reshape(shape)
