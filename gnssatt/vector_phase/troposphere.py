"""Slant tropospheric delay of the vector-phase data: the Saastamoinen model the code solution corrects for
(gnssatt.gnss.positioning.saastamoinen_delay_m), removed from the phases by the reader and added to code and
phase by the simulated set, so that both sides use one model."""
from __future__ import annotations

import numpy as np

__all__ = ["slant_delay_m"]


def slant_delay_m(r_ecef_m, r_sat_ecef_m) -> np.ndarray:
    """Saastamoinen slant delay (m) of each satellite position r_sat_ecef_m (..., 3) seen from r_ecef_m (3,)."""
    from gnssatt.gnss.frames import ecef_to_geodetic
    from gnssatt.gnss.positioning import saastamoinen_delay_m

    r = np.asarray(r_ecef_m, float)
    lat, _, h = ecef_to_geodetic(r)
    los = np.asarray(r_sat_ecef_m, float) - r
    el = np.arcsin(np.clip(los @ (r / np.linalg.norm(r)) / np.linalg.norm(los, axis=-1), -1.0, 1.0))
    return np.nan_to_num(saastamoinen_delay_m(lat, h, el))
