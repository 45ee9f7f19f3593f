"""The satellite's field polarisation, E ~ (u - j v) (seed 003 eq. 15), from the satellite antenna's attitude.

A GPS satellite's L-band array is modelled as crossed dipoles along its body x and y axes fed in quadrature
(right-hand circular on its +z boresight towards the Earth). Seen along the propagation direction k (unit,
satellite -> receiver) its field's polarisation vectors are
    u = unit(x_s - k (k . x_s) - k x y_s),   v = k x u,
so u, v are real, orthonormal and u x v = k: a right-hand circular field (the effective dipole of Wu et al.
1993). R1k, R2k of eq. 27-28 are the ECEF components of u and v. The field amplitude E(Theta, Phi) cancels in
the phase and is not modelled.
Neglects: the satellite's cross-polar (LHCP) leakage off boresight and first-order v/c aberration (seed 003).
"""
from __future__ import annotations

import numpy as np

__all__ = ["polarisation_ecef"]


def polarisation_ecef(k_ecef: np.ndarray, x_sat_ecef: np.ndarray, y_sat_ecef: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) (..., 3): ECEF polarisation vectors of the field of eq. 15, E ~ u - j v.

    Args: k_ecef (..., 3) unit propagation direction (satellite -> receiver); x_sat_ecef, y_sat_ecef (..., 3)
    the satellite body x and y axes in ECEF (broadcastable). Implements: seed 003 eq. 15, 27-28 with the
    crossed-dipole effective dipole of Wu et al. 1993.
    """
    k = np.asarray(k_ecef, dtype=np.float64)
    x_s = np.broadcast_to(x_sat_ecef, k.shape)
    y_s = np.broadcast_to(y_sat_ecef, k.shape)
    d = x_s - k * np.einsum("...i,...i->...", k, x_s)[..., None] - np.cross(k, y_s)
    u = d / np.linalg.norm(d, axis=-1, keepdims=True)
    return u, np.cross(k, u)
