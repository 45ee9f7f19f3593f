"""Transmitter attitude for the vector-phase model: nominal yaw steering and the orbit-frame axes.

The estimators and the phase model take the satellite body axes from any callable
`axes(t_gps_s, r_sat_ecef_m, v_sat_ecef_m_s) -> (x_sat_ecef, y_sat_ecef)` (arrays (..., 3)); the default is
`nominal_yaw_steering`, the project's model (satellite-yaw work: gnssatt.satyaw for the non-nominal ones).

- `nominal_yaw_steering`: IGS body frame, +z to the Earth's centre, +y = unit(z x e_sun), +x = y x z
  (Kouba 2009 eq. 1, gnssatt.gnss.satellite_antenna.satellite_body_axes_ecef) with the ERFA Sun of
  gnssatt.satyaw.states.sun_ecef_m; no yaw-rate limit and no noon/midnight turn manoeuvres.
- `orbit_frame_axes`: +z to the Earth's centre, +y = -(r x v_inertial) unit (the multi-antenna simulator's
  satellite axes, gnssatt/sim/observables.satellite_axes).
"""
from __future__ import annotations

import numpy as np

from gnssatt.gnss.satellite_antenna import satellite_body_axes_ecef
from gnssatt.gnss.time import GpsTime

__all__ = ["nominal_yaw_steering", "orbit_frame_axes", "OMEGA_EARTH_RAD_S"]

OMEGA_EARTH_RAD_S = 7.2921151467e-5


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def nominal_yaw_steering(t_gps_s, r_sat_ecef_m, v_sat_ecef_m_s=None) -> tuple[np.ndarray, np.ndarray]:
    """(x_sat_ecef, y_sat_ecef) (..., 3) of nominal yaw steering; t_gps_s (GPS seconds since 1980-01-06)
    broadcastable to r's leading shape (e.g. (n_ep, 1) for (n_ep, n_sv, 3)). v is not used (common signature)."""
    from gnssatt.satyaw.states import sun_ecef_m

    r = np.asarray(r_sat_ecef_m, dtype=np.float64)
    t = np.broadcast_to(np.asarray(t_gps_s, dtype=np.float64), r.shape[:-1]).reshape(-1)
    axes = satellite_body_axes_ecef(r.reshape(-1, 3), sun_ecef_m(GpsTime(t)))
    return axes[:, 0].reshape(r.shape), axes[:, 1].reshape(r.shape)


def orbit_frame_axes(t_gps_s, r_sat_ecef_m, v_sat_ecef_m_s) -> tuple[np.ndarray, np.ndarray]:
    """(x_sat_ecef, y_sat_ecef) of the orbit frame: z to the Earth's centre, y = -(r x v_inertial) unit."""
    r = np.asarray(r_sat_ecef_m, dtype=np.float64)
    v = np.asarray(v_sat_ecef_m_s, dtype=np.float64) + np.cross([0.0, 0.0, OMEGA_EARTH_RAD_S], r)
    z = -_unit(r)
    y = -_unit(np.cross(r, v))
    return np.cross(y, z), y
