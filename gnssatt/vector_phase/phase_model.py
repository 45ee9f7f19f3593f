"""Carrier phase of one antenna with the orientation-dependent phase delta_s (seed 003 eq. 32-36, 44).

    delta_s = -Arg[ h_i(n_s) D_ik (R1k - j R2k) ]                                  (eq. 32)
    Psi_s = rho_s / lambda + b + delta_s / (2 pi) + N_s      [cycles]              (eq. 35 / 2 pi)
    Delta Psi_s(t) = (rho_s(t) - rho_s(t0)) / lambda + b(t) + (delta_s(t) - delta_s(t0)) / (2 pi)   (eq. 44)

h in ECEF components is R_ecef_from_ant h_ant(s_ant) (the antenna's own table turned with the platform: D of
eq. 26 is R_body_from_ecef, and the antenna is mounted by R_ant_from_body); (R1, R2) = (u, v) of
gnssatt.vector_phase.transmitter. b = omega Delta t* / (2 pi) is the receiver clock in cycles (eq. 41-42). The
phase is range-like (grows with the range), as eq. 35; RINEX L differs from it by the receiver's sign convention
only through b and N.
Neglects: v/c aberration, the change of the satellite's field between emission directions (E(Theta, Phi) is a
common amplitude), atmospheric delays and their changes (a single-antenna user would model them as usual).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.vector_phase.antenna import h_cartesian_antenna
from gnssatt.vector_phase.rotation import perturb_body
from gnssatt.vector_phase.transmitter import polarisation_ecef

__all__ = ["AntennaMount", "EpochGeometry", "ReceiverState", "delta_rad", "model_cycles", "jacobian",
           "unwrap_to", "N_STATE", "L1_WAVELENGTH_M", "nominal_scale"]

L1_WAVELENGTH_M = 299792458.0 / 1575.42e6
#: state order of the estimators: position_ecef_m (3), clock_cyc (1), attitude increment eps_body_rad (3)
N_STATE = 7
#: step of the numerical attitude derivative, rad
ATTITUDE_STEP_RAD = 1e-6


@dataclass(frozen=True)
class AntennaMount:
    """The receive antenna: a model of gnssatt.vector_phase.antenna, its mounting R_ant_from_body (3, 3), and
    the carrier wavelength (m)."""

    antenna: object
    R_ant_from_body: np.ndarray
    wavelength_m: float = L1_WAVELENGTH_M


@dataclass(frozen=True)
class EpochGeometry:
    """Known at one epoch (the 'enhanced ephemeris' of eq. 45): satellite positions at emission r_sat_ecef_m
    (n_sv, 3) in the ECEF frame of reception, and their body axes x_sat_ecef, y_sat_ecef (n_sv, 3)."""

    r_sat_ecef_m: np.ndarray
    x_sat_ecef: np.ndarray
    y_sat_ecef: np.ndarray


@dataclass(frozen=True)
class ReceiverState:
    """The seven unknowns of eq. 45: position_ecef_m (3,), clock_cyc (b), R_body_from_ecef (3, 3)."""

    position_ecef_m: np.ndarray
    clock_cyc: float
    R_body_from_ecef: np.ndarray


def nominal_scale(mount: AntennaMount) -> np.ndarray:
    """(7,) cycles per unit of each unknown at most (1/lambda per metre, 1 per clock cycle, 1/(2 pi) per rad): the
    fixed column scale of the observability analysis and the solvers, so a column that is zero (a dipole's
    axial rotation) stays zero instead of being normalised up from rounding noise."""
    return np.array([1.0 / mount.wavelength_m] * 3 + [1.0] + [1.0 / (2.0 * np.pi)] * 3)


def delta_rad(mount: AntennaMount, R_body_from_ecef: np.ndarray, e_ecef: np.ndarray, x_sat_ecef: np.ndarray,
              y_sat_ecef: np.ndarray) -> np.ndarray:
    """delta_s of eq. 32 in (-pi, pi], shape (...,) for e_ecef (..., 3) unit receiver -> satellite.

    R_body_from_ecef (3, 3) or (..., 3, 3) broadcasting over e's leading axes but the last (satellites):
    pass (n_ep, 3, 3) with e (n_ep, n_sv, 3)."""
    R_ant_from_ecef = mount.R_ant_from_body @ np.asarray(R_body_from_ecef, dtype=np.float64)
    e = np.asarray(e_ecef, dtype=np.float64)
    if R_ant_from_ecef.ndim == 3:
        R_ant_from_ecef = R_ant_from_ecef[:, None]
    s_ant = np.einsum("...ij,...j->...i", R_ant_from_ecef, e)
    h_ant = h_cartesian_antenna(mount.antenna, s_ant)
    h_ecef = np.einsum("...ji,...j->...i", R_ant_from_ecef, h_ant)          # R_ecef_from_ant h_ant
    u, v = polarisation_ecef(-e, x_sat_ecef, y_sat_ecef)
    voltage = np.einsum("...i,...i->...", h_ecef, u - 1j * v)              # h . (R1 - j R2), eq. 16
    return -np.angle(voltage)


def unwrap_to(delta: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """delta + 2 pi k with k the integer that brings it nearest to reference (the tracked, unwrapped delta)."""
    return delta + 2.0 * np.pi * np.round((reference - delta) / (2.0 * np.pi))


def _geometry(state: ReceiverState, geom: EpochGeometry):
    d = geom.r_sat_ecef_m - state.position_ecef_m
    rho = np.linalg.norm(d, axis=-1)
    return rho, d / rho[:, None]


def model_cycles(state: ReceiverState, geom: EpochGeometry, mount: AntennaMount,
                 delta_reference: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(Psi_s - N_s in cycles (n_sv,), delta_s rad (n_sv,)) of eq. 35; delta unwrapped to delta_reference."""
    rho, e = _geometry(state, geom)
    delta = delta_rad(mount, state.R_body_from_ecef, e, geom.x_sat_ecef, geom.y_sat_ecef)
    if delta_reference is not None:
        delta = unwrap_to(delta, delta_reference)
    return rho / mount.wavelength_m + state.clock_cyc + delta / (2.0 * np.pi), delta


def jacobian(state: ReceiverState, geom: EpochGeometry, mount: AntennaMount) -> np.ndarray:
    """d Psi / d (position_ecef_m, clock_cyc, eps_body_rad), (n_sv, 7): range part analytic (-e / lambda; the
    delta part's dependence on position is ~h/rho and neglected), attitude part by forward differences (step
    ATTITUDE_STEP_RAD: truncation ~1e-6 relative, far below the phase noise's effect)."""
    rho, e = _geometry(state, geom)
    J = np.empty((len(rho), N_STATE))
    J[:, :3] = -e / mount.wavelength_m
    J[:, 3] = 1.0
    here = delta_rad(mount, state.R_body_from_ecef, e, geom.x_sat_ecef, geom.y_sat_ecef)
    for axis in range(3):
        step = np.zeros(3)
        step[axis] = ATTITUDE_STEP_RAD
        moved = delta_rad(mount, perturb_body(state.R_body_from_ecef, step), e, geom.x_sat_ecef, geom.y_sat_ecef)
        J[:, 4 + axis] = np.angle(np.exp(1j * (moved - here))) / ATTITUDE_STEP_RAD / (2 * np.pi)
    return J
