"""Receive-antenna vector effective length h(theta, phi) (seed 003 eq. 12) and its Cartesian components (eq. 22-24).

Directions are in the antenna frame (CONVENTIONS.md "platform.json": z along the boresight, x along the body x
projected): theta from the boresight, phi the azimuth from antenna x towards antenna y; the unit vector towards
the satellite is s = (sin t cos p, sin t sin p, cos t), the propagation direction n = -s (eq. 11). The spherical
basis is a_theta = (cos t cos p, cos t sin p, -sin t), a_phi = (-sin p, cos p, 0). Lengths in metres, complex
(phasors of e^{j omega t}, as eq. 13-16).

Models:
- `ShortDipole`: a short dipole along antenna x, h = L (x - s (s . x)) (the transverse part of its axis; real).
  Rotations about its axis leave h unchanged: only two angles are observable (Krall and Bahder, seed 003 sec. I).
- `RhcpPatch`: ideal right-hand circular, h = L g(t) e^{-j p} (a_theta - j a_phi), g = (1 + cos t) / 2: the
  crossed-dipole receive antenna of Wu et al. 1993 (its phase is the textbook wind-up). A rotation about the
  boresight adds the same phase to every satellite: indistinguishable from the receiver clock.
- `AsymmetricPatch`: the RHCP patch times (1 + a sin^m t e^{j m (p - p0)}): an azimuth-dependent phase pattern
  (an offset feed), which breaks the cylindrical symmetry so all three angles are observable (seed 003 sec. V.B).
- `TableAntenna`: h_theta, h_phi tabulated on a (theta, phi) grid, bilinear in complex values, periodic in phi.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ShortDipole", "RhcpPatch", "AsymmetricPatch", "TableAntenna", "spherical_basis", "angles_of",
           "h_cartesian_antenna", "table_of"]


def angles_of(s_ant: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(theta_rad, phi_rad) of unit directions s_ant (..., 3) towards the satellite, antenna frame."""
    s = np.asarray(s_ant, dtype=np.float64)
    theta = np.arccos(np.clip(s[..., 2], -1.0, 1.0))
    phi = np.arctan2(s[..., 1], s[..., 0])
    return theta, phi


def spherical_basis(theta_rad, phi_rad) -> tuple[np.ndarray, np.ndarray]:
    """(a_theta, a_phi), each (..., 3), of the antenna frame's spherical coordinates (seed 003 eq. 12)."""
    ct, st, cp, sp = np.cos(theta_rad), np.sin(theta_rad), np.cos(phi_rad), np.sin(phi_rad)
    a_theta = np.stack([ct * cp, ct * sp, -st], axis=-1)
    a_phi = np.stack([-sp, cp, np.zeros_like(sp)], axis=-1)
    return a_theta, a_phi


def h_cartesian_antenna(antenna, s_ant: np.ndarray) -> np.ndarray:
    """Complex h (..., 3) in antenna-frame Cartesian components for directions s_ant (..., 3) to the satellite.

    Implements: seed 003 eq. 22-24 (h_1 = h_t cos t cos p - h_p sin p, h_2 = h_t cos t sin p + h_p cos p,
    h_3 = -h_t sin t).
    """
    theta, phi = angles_of(s_ant)
    h_theta, h_phi = antenna.h_spherical(theta, phi)
    a_theta, a_phi = spherical_basis(theta, phi)
    return h_theta[..., None] * a_theta + h_phi[..., None] * a_phi


@dataclass(frozen=True)
class ShortDipole:
    """Short dipole along antenna x, effective length length_m (seed 003 sec. I, Krall and Bahder)."""

    length_m: float = 0.1
    name: str = "short-dipole"

    def h_spherical(self, theta_rad, phi_rad) -> tuple[np.ndarray, np.ndarray]:
        """(h_theta, h_phi) complex: the projections of L x on a_theta and a_phi."""
        ct, cp, sp = np.cos(theta_rad), np.cos(phi_rad), np.sin(phi_rad)
        return (self.length_m * ct * cp).astype(complex), (-self.length_m * sp).astype(complex)


@dataclass(frozen=True)
class RhcpPatch:
    """Ideal right-hand circularly polarised antenna: h = L (1 + cos t)/2 e^{-j p} (a_theta - j a_phi).

    Its transverse part is |D|/2 (D^ + j k x D^) with D = x - k (k . x) + k x y the receiver's effective dipole of
    Wu et al. 1993 (k = -s), so its phase against an RHCP field is the Wu wind-up angle
    (tests/vector_phase/test_phase_model.py).
    """

    length_m: float = 0.1
    name: str = "rhcp-patch"

    def h_spherical(self, theta_rad, phi_rad) -> tuple[np.ndarray, np.ndarray]:
        g = self.length_m * 0.5 * (1.0 + np.cos(theta_rad)) * np.exp(-1j * np.asarray(phi_rad))
        return g, -1j * g


@dataclass(frozen=True)
class AsymmetricPatch:
    """RHCP patch with an azimuth-dependent phase pattern: h_rhcp (1 + a sin^m t e^{j m (p - p0)}).

    asymmetry (a, 0 <= a < 1): the relative size of the non-symmetric term; harmonic (m >= 1): its azimuthal
    order (sin^m t keeps h single-valued at the boresight); phase_deg (p0): its orientation in the antenna frame.
    """

    length_m: float = 0.1
    asymmetry: float = 0.5
    harmonic: int = 2
    phase_deg: float = 0.0
    name: str = "asymmetric-patch"

    def h_spherical(self, theta_rad, phi_rad) -> tuple[np.ndarray, np.ndarray]:
        h_theta, h_phi = RhcpPatch(self.length_m).h_spherical(theta_rad, phi_rad)
        m = int(self.harmonic)
        factor = 1.0 + self.asymmetry * np.sin(theta_rad) ** m * np.exp(
            1j * m * (np.asarray(phi_rad) - np.radians(self.phase_deg)))
        return h_theta * factor, h_phi * factor


@dataclass(frozen=True)
class TableAntenna:
    """h_theta, h_phi (complex, m) on a grid: theta_deg (n_t,) increasing in [0, 180], phi_deg (n_p,) increasing,
    covering [0, 360) with a uniform step (periodic); h_theta_m, h_phi_m (n_t, n_p). Bilinear in complex values.
    Directions beyond the last theta get the last row (the table's own edge, e.g. the horizon)."""

    theta_deg: np.ndarray
    phi_deg: np.ndarray
    h_theta_m: np.ndarray
    h_phi_m: np.ndarray
    name: str = "table"

    def h_spherical(self, theta_rad, phi_rad) -> tuple[np.ndarray, np.ndarray]:
        t = np.degrees(np.asarray(theta_rad, dtype=np.float64))
        p = np.mod(np.degrees(np.asarray(phi_rad, dtype=np.float64)) - self.phi_deg[0], 360.0)
        n_t, n_p = self.h_theta_m.shape
        step = 360.0 / n_p
        j0 = np.floor(p / step).astype(int) % n_p
        fp = p / step - np.floor(p / step)
        j1 = (j0 + 1) % n_p
        tc = np.clip(t, self.theta_deg[0], self.theta_deg[-1])
        i0 = np.clip(np.searchsorted(self.theta_deg, tc, side="right") - 1, 0, n_t - 2)
        ft = (tc - self.theta_deg[i0]) / (self.theta_deg[i0 + 1] - self.theta_deg[i0])

        def interp(table):
            return ((1 - ft) * ((1 - fp) * table[i0, j0] + fp * table[i0, j1])
                    + ft * ((1 - fp) * table[i0 + 1, j0] + fp * table[i0 + 1, j1]))

        return interp(self.h_theta_m), interp(self.h_phi_m)


def table_of(antenna, theta_step_deg: float = 2.0, phi_step_deg: float = 2.0, theta_max_deg: float = 180.0) -> TableAntenna:
    """A TableAntenna sampled from any model on a regular grid (theta 0..theta_max, phi 0..360-step)."""
    theta_deg = np.arange(0.0, theta_max_deg + 1e-9, theta_step_deg)
    phi_deg = np.arange(0.0, 360.0 - 1e-9, phi_step_deg)
    tt, pp = np.meshgrid(np.radians(theta_deg), np.radians(phi_deg), indexing="ij")
    h_theta, h_phi = antenna.h_spherical(tt, pp)
    return TableAntenna(theta_deg, phi_deg, np.asarray(h_theta, complex), np.asarray(h_phi, complex))
