"""Yaw attitude models of a navigation satellite: nominal yaw steering, orbit-normal and the QZS-2/-4
pseudo-yaw steering with a yaw-rate limit (seed 004 sec. 1, Fig. 2, sec. 2.4-2.5).

Yaw (CONVENTIONS.md "yaw of GNSS satellites"): the rotation about body +z (nadir) from the orbital frame's
along-track axis x_o to body +x, degrees in (-180, 180]. The IGS body frame of nominal yaw steering is
e_z = -r/|r|, e_y = e_z x e_sun / |..|, e_x = e_y x e_z (+x on the Sun's side). Arrays carry xyz last.

The public functions here are the model other capabilities may reuse (e.g. vector-phase): `orbit_angles`,
`nominal_yaw_deg`, `nominal_yaw_rate_deg_s`, `pseudo_yaw_steering_deg`, `orbit_normal_yaw_deg`, `model_yaw_deg`,
`R_ecef_from_body`.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from gnssatt.gnss.constants import OMEGA_EARTH_RAD_S
from gnssatt.gnss.frames import R_orbital_from_ecef

__all__ = ["OrbitAngles", "orbit_angles", "nominal_yaw_deg", "nominal_yaw_rate_deg_s", "pseudo_yaw_steering_deg",
           "orbit_normal_yaw_deg", "model_yaw_deg", "R_ecef_from_body", "wrap_deg", "MODELS",
           "QZSS_YAW_RATE_LIMIT_DEG_S"]

#: QZS-2/-4 maximum yaw rate (seed 004 sec. 2.4, from SPI-QZS2-B): pseudo-yaw steering above it.
QZSS_YAW_RATE_LIMIT_DEG_S = 0.055
#: Attitude model names of satellites.json (CONVENTIONS.md).
#: "qzs1-yaw-steering" (QZS-1, seed 004 sec. 1): yaw steering, orbit normal while |beta| < 20 deg.
MODELS = ("yaw-steering", "orbit-normal", "qzss-pseudo-yaw-steering", "qzs1-yaw-steering")
#: |beta| below which QZS-1 flies orbit normal (seed 004 sec. 1; the real switch can lag by hours)
QZS1_ORBIT_NORMAL_BETA_DEG = 20.0


def wrap_deg(angle_deg) -> np.ndarray:
    """Angles wrapped into (-180, 180] degrees."""
    a = np.asarray(angle_deg, dtype=np.float64)
    w = np.mod(a + 180.0, 360.0) - 180.0
    return np.where(w == -180.0, 180.0, w)


class OrbitAngles(NamedTuple):
    """Sun-orbit geometry per epoch: beta_deg (Sun elevation above the orbit plane, + on the orbit-normal side),
    mu_deg (satellite's orbit angle from orbit midnight, along the motion), mu_rate_deg_s, and
    R_orbital_from_ecef (n, 3, 3) whose rows are x_o, y_o, z_o in ECEF."""

    beta_deg: np.ndarray
    mu_deg: np.ndarray
    mu_rate_deg_s: np.ndarray
    R_orbital_from_ecef: np.ndarray


def orbit_angles(r_sat_ecef_m, v_sat_ecef_m_s, r_sun_ecef_m) -> OrbitAngles:
    """Beta and mu angles and the orbital frame of satellites (n, 3) with the Sun (n, 3), all ECEF.

    v_sat_ecef_m_s is the Earth-fixed velocity; the inertial one (v + omega_E x r) defines the orbit plane.
    Implements: Kouba (2009) "A simplified yaw-attitude model for eclipsing GPS satellites", beta and mu (the
    angle from orbit midnight), with the Sun direction seen from the satellite.
    """
    r = np.asarray(r_sat_ecef_m, dtype=np.float64)
    R_o = R_orbital_from_ecef(r, v_sat_ecef_m_s)
    h_hat = -R_o[..., 1, :]                       # orbit normal r x v (inertial)
    s = np.asarray(r_sun_ecef_m, dtype=np.float64) - r
    s = s / np.linalg.norm(s, axis=-1, keepdims=True)
    sin_beta = np.einsum("...i,...i->...", s, h_hat)
    beta = np.arcsin(np.clip(sin_beta, -1.0, 1.0))
    p = s - sin_beta[..., None] * h_hat           # Sun projected on the orbit plane: orbit noon direction
    p = p / np.linalg.norm(p, axis=-1, keepdims=True)
    q = np.cross(h_hat, p)
    r_hat = r / np.linalg.norm(r, axis=-1, keepdims=True)
    u = np.arctan2(np.einsum("...i,...i->...", r_hat, q), np.einsum("...i,...i->...", r_hat, p))
    mu = u - np.pi                                # from orbit midnight
    v_in = np.asarray(v_sat_ecef_m_s) + np.cross([0.0, 0.0, OMEGA_EARTH_RAD_S], r)
    rate = np.linalg.norm(np.cross(r, v_in), axis=-1) / np.einsum("...i,...i->...", r, r)
    return OrbitAngles(np.degrees(beta), wrap_deg(np.degrees(mu)), np.degrees(rate), R_o)


def nominal_yaw_deg(r_sat_ecef_m, v_sat_ecef_m_s, r_sun_ecef_m) -> np.ndarray:
    """Nominal yaw-steering yaw angle (n,) in degrees of satellites (n, 3) with the Sun (n, 3), ECEF.

    Implements: the IGS body frame (Montenbruck et al. 2015, "Flight attitude models of GNSS satellites"):
    e_x = projection of the Sun direction on the plane normal to nadir; yaw = atan2(e_x . y_o, e_x . x_o), which
    equals Kouba (2009) atan2(-tan(beta), sin(mu)) for a circular orbit. NaN where the Sun is along nadir.
    """
    r = np.asarray(r_sat_ecef_m, dtype=np.float64)
    R_o = R_orbital_from_ecef(r, v_sat_ecef_m_s)
    s = np.asarray(r_sun_ecef_m, dtype=np.float64) - r
    s_o = np.einsum("...ij,...j->...i", R_o, s)   # Sun direction in the orbital frame
    with np.errstate(invalid="ignore"):
        yaw = np.degrees(np.arctan2(s_o[..., 1], s_o[..., 0]))
    bad = np.hypot(s_o[..., 0], s_o[..., 1]) < 1e-12 * np.linalg.norm(s_o, axis=-1)
    return np.where(bad, np.nan, wrap_deg(yaw))


def nominal_yaw_rate_deg_s(beta_deg, mu_deg, mu_rate_deg_s) -> np.ndarray:
    """Nominal yaw rate (deg/s): mu_dot tan(beta) cos(mu) / (sin^2(mu) + tan^2(beta)).

    Implements: the time derivative of Kouba (2009) eq. yaw = atan2(-tan(beta), sin(mu)) at constant beta
    (beta changes by < 1 deg/day); its extreme at orbit noon/midnight is mu_dot / tan(beta).
    """
    b = np.radians(np.asarray(beta_deg, dtype=np.float64))
    m = np.radians(np.asarray(mu_deg, dtype=np.float64))
    tb = np.tan(b)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray(mu_rate_deg_s) * tb * np.cos(m) / (np.sin(m) ** 2 + tb * tb)


def orbit_normal_yaw_deg(n: int, *, yaw_deg: float = 180.0) -> np.ndarray:
    """Orbit-normal mode yaw (n,): body axes fixed to the orbital frame; seed 004 sec. 2.5: yaw 180 deg (+x
    against the flight direction) for QZSS in the IGS convention."""
    return np.full(int(n), float(yaw_deg))


def _turn_limits(d_deg: np.ndarray, i_mid: int, s: float, lo: int, hi: int) -> tuple[int, int]:
    """First indices before/after i_mid where the nominal minus the rate-limited line changes side."""
    before = np.nonzero(d_deg[:i_mid] * s >= 0.0)[0]
    after = np.nonzero(d_deg[i_mid + 1:] * s <= 0.0)[0]
    a = int(before[-1]) if before.size else lo
    b = int(i_mid + 1 + after[0]) if after.size else hi
    return a, b


def pseudo_yaw_steering_deg(t_s, nominal_yaw_deg_, nominal_rate_deg_s=None, *,
                            rate_limit_deg_s: float = QZSS_YAW_RATE_LIMIT_DEG_S) -> np.ndarray:
    """Yaw (n,) of rate-limited pseudo-yaw steering: the nominal yaw except around orbit noon/midnight, where
    the nominal rate exceeds the limit and the satellite turns at the limit rate, leading then lagging the
    nominal (seed 004 Fig. 2) on a straight line through the turn's centre.

    Args:
        t_s: (n,) increasing times (s); nominal_yaw_deg_: (n,) nominal yaw there (deg);
        nominal_rate_deg_s: (n,) nominal yaw rate (deg/s; e.g. `nominal_yaw_rate_deg_s`), or None for the
            finite difference of the unwrapped nominal yaw (needs a sampling that resolves the turn).
    Implements: the symmetric rate-limited turn of QZS-2/-4 (seed 004 sec. 2.4, SPI-QZS2-B): the turn starts
    when the line of slope +-limit through the turn centre (maximum nominal rate) meets the nominal yaw.
    Neglects: the unpredictable turn direction for |beta| < 0.03 deg (sec. 2.4); the nominal direction is used.
    """
    t = np.asarray(t_s, dtype=np.float64)
    psi = np.unwrap(np.radians(np.asarray(nominal_yaw_deg_, dtype=np.float64)))
    psi = np.degrees(psi)
    rate = np.gradient(psi, t) if nominal_rate_deg_s is None else np.asarray(nominal_rate_deg_s, dtype=np.float64)
    out = psi.copy()
    fast = np.abs(rate) > rate_limit_deg_s
    if not fast.any():
        return wrap_deg(out)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], fast.astype(np.int8), [0]))))
    last_end = -1
    for start, stop in zip(edges[0::2], edges[1::2]):
        if start <= last_end:
            continue
        i_mid = int(start + np.argmax(np.abs(rate[start:stop])))
        s = float(np.sign(rate[i_mid]))
        line = psi[i_mid] + s * rate_limit_deg_s * (t - t[i_mid])
        a, b = _turn_limits(psi - line, i_mid, s, 0, len(t) - 1)
        out[a + 1:b] = line[a + 1:b]
        last_end = b
    return wrap_deg(out)


def model_yaw_deg(model: str, t_s, nominal_yaw_deg_, nominal_rate_deg_s=None, *,
                  rate_limit_deg_s: float = QZSS_YAW_RATE_LIMIT_DEG_S, beta_deg=None) -> np.ndarray:
    """The yaw (n,) of one of MODELS from the nominal yaw series (deg) at times t_s (s); beta_deg (n,) is
    needed by "qzs1-yaw-steering"."""
    if model == "qzs1-yaw-steering":
        if beta_deg is None:
            raise ValueError("qzs1-yaw-steering needs beta_deg")
        on = np.abs(np.asarray(beta_deg)) < QZS1_ORBIT_NORMAL_BETA_DEG
        return np.where(on, 180.0, wrap_deg(nominal_yaw_deg_))
    if model == "yaw-steering":
        return wrap_deg(nominal_yaw_deg_)
    if model == "orbit-normal":
        return orbit_normal_yaw_deg(len(np.atleast_1d(t_s)))
    if model == "qzss-pseudo-yaw-steering":
        return pseudo_yaw_steering_deg(t_s, nominal_yaw_deg_, nominal_rate_deg_s, rate_limit_deg_s=rate_limit_deg_s)
    raise ValueError(f"unknown attitude model {model!r}; expected one of {', '.join(MODELS)}")


def R_ecef_from_body(R_orbital_from_ecef_, yaw_deg) -> np.ndarray:
    """(n, 3, 3) rotation body -> ECEF: columns are the body axes in ECEF, e_x = cos(yaw) x_o + sin(yaw) y_o,
    e_y = -sin(yaw) x_o + cos(yaw) y_o, e_z = z_o (seed 004 eq. 9: O R(yaw))."""
    R_o = np.asarray(R_orbital_from_ecef_, dtype=np.float64)
    y = np.radians(np.asarray(yaw_deg, dtype=np.float64))[..., None]
    x_o, y_o, z_o = R_o[..., 0, :], R_o[..., 1, :], R_o[..., 2, :]
    ex = np.cos(y) * x_o + np.sin(y) * y_o
    ey = -np.sin(y) * x_o + np.cos(y) * y_o
    return np.stack([ex, ey, z_o], axis=-1)
