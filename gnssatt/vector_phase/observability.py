"""Observability of the seven unknowns of eq. 45 at one epoch: rank and condition of the information matrix,
the unobservable direction and which rotation it is, and which Euler angles it leaves undetermined.

The information matrix is N = J^T W J of the epoch's phase Jacobian (gnssatt.vector_phase.phase_model.jacobian).
Its columns are scaled first by fixed nominal sensitivities (phase_model.nominal_scale: metres, cycles and radians
are not comparable), so the condition number is that of the scaled problem and the rank counts singular values
above RANK_TOLERANCE times the largest.
A short dipole leaves the rotation about its axis unobservable (seed 003 sec. I: two angles from six satellites);
an ideal RHCP antenna leaves the rotation about its boresight unobservable, coupled with the receiver clock (its
phase changes alike for every satellite, the common phase wind-up).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.gnss.rotations import dcm_to_euler321
from gnssatt.vector_phase.rotation import perturb_body

__all__ = ["Observability", "analyse", "undetermined_angles", "RANK_TOLERANCE", "UNDETERMINED_SPREAD_DEG",
           "describe_axis"]

#: singular values of the scaled Jacobian below this fraction of the largest count as zero: the numerical
#: derivatives are good to ~1e-9 relative, a real but weak direction (the asymmetric patch's yaw) is > 1e-4
RANK_TOLERANCE = 1e-6
#: an Euler angle is not reported as determined when some rotation about the unobservable axis moves it by more
#: than this, deg (a fraction of the smallest sigma the method reaches with mm-level phase noise)
UNDETERMINED_SPREAD_DEG = 0.5


@dataclass(frozen=True)
class Observability:
    """rank (of 7), condition (scaled; inf when rank-deficient), singular_values (7,), column_scale (7,),
    V (7, 7) right singular vectors (scaled coordinates, columns by decreasing singular value),
    null_rotation_body (3,) unit rotation axis of the unobservable direction (NaN when rank 7),
    clock_coupled: the unobservable direction moves the clock too, description: text for the products."""

    rank: int
    condition: float
    singular_values: np.ndarray
    column_scale: np.ndarray
    V: np.ndarray
    null_rotation_body: np.ndarray
    clock_coupled: bool
    description: str


def describe_axis(axis_body: np.ndarray, R_ant_from_body: np.ndarray) -> str:
    """Name of a body rotation axis: the antenna boresight / antenna x / y when within 5 deg, else its body
    components."""
    a = np.asarray(axis_body, float)
    ant = R_ant_from_body @ a
    for i, name in ((2, "the antenna boresight (z)"), (0, "the antenna x axis (a dipole's axis)"),
                    (1, "the antenna y axis")):
        if abs(ant[i]) > np.cos(np.radians(5.0)):
            return name
    return "body axis [" + ", ".join(f"{c:+.3f}" for c in a) + "]"


def analyse(J: np.ndarray, sigma_cyc: np.ndarray, R_ant_from_body: np.ndarray, scale: np.ndarray) -> Observability:
    """Observability of one epoch from its Jacobian J (n_sv, 7), phase sigmas (n_sv,) in cycles and the column
    scale (7,) (phase_model.nominal_scale)."""
    A = J / np.asarray(sigma_cyc, float)[:, None]
    _, s, Vt = np.linalg.svd(A / scale, full_matrices=True)
    s_full = np.zeros(7)
    s_full[: len(s)] = s
    rank = int(np.sum(s_full > RANK_TOLERANCE * s_full[0]))
    V = Vt.T
    condition = float(s_full[0] / s_full[-1]) if rank == 7 else float("inf")
    null_rot = np.full(3, np.nan)
    coupled = False
    text = "all seven unknowns observable"
    if rank < 7:
        v = V[:, -1] / scale                                # physical units: m, cycles, rad
        rot = v[4:]
        if np.linalg.norm(rot) > 1e-9:
            null_rot = rot / np.linalg.norm(rot)
            null_rot = null_rot * np.sign(null_rot[np.argmax(np.abs(null_rot))])
            coupled = abs(v[3]) / np.linalg.norm(rot) > 1e-3
            text = (f"rotation about {describe_axis(null_rot, R_ant_from_body)} unobservable"
                    + (" (indistinguishable from the receiver clock)" if coupled else ""))
        else:
            text = "position or clock unobservable (too few or degenerate satellites)"
        if rank < 6:
            text += f"; {7 - rank} unobservable directions in all"
    return Observability(rank, condition, s_full, scale, V, null_rot, coupled, text)


def undetermined_angles(R_body_from_ecef: np.ndarray, R_ref_from_ecef: np.ndarray,
                        null_rotation_body: np.ndarray, n_samples: int = 24) -> np.ndarray:
    """(3,) bool for (yaw, pitch, roll) relative to the reference frame (NED or orbital): True where turning the
    body about the unobservable axis (any angle: the data cannot tell them apart) moves the angle by more than
    UNDETERMINED_SPREAD_DEG. Pitch and roll of a level platform about an unobservable vertical survive; of a
    tilted one they do not (only the boresight direction is then determined)."""
    if not np.all(np.isfinite(null_rotation_body)):
        return np.zeros(3, bool)
    here = np.array(dcm_to_euler321(R_body_from_ecef @ R_ref_from_ecef.T), dtype=float)
    spread = np.zeros(3)
    for chi in np.linspace(0.0, 2 * np.pi, n_samples, endpoint=False)[1:]:
        R = perturb_body(R_body_from_ecef, chi * null_rotation_body) @ R_ref_from_ecef.T
        d = np.array(dcm_to_euler321(R), dtype=float) - here
        spread = np.maximum(spread, np.abs((d + 180.0) % 360.0 - 180.0))
    return spread > UNDETERMINED_SPREAD_DEG
