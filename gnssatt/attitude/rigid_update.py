"""Dynamic mode: the measurement update of a fixed baseline applied as a rotation plus a length change, with its
covariance carried along (the multiplicative form of the update of a rigid baseline).

The update of an epoch moves each baseline additively, b+ = b- + db. Split db at b- into the part along b-
(dl = r . db, r = b- / |b-|, a length change) and the part across it (db_t, a rotation by |db_t| / |b-|): the
additive step changes the length by dl + |db_t|^2 / (2 |b-|), and the second term, one-signed, adds up over the
epochs because nothing brings a rigid baseline's length back (no process noise along b). Here the baseline is set to
    b+ <- (|b-| + dl) b+ / |b+|,
the direction of the additive update with the length changed by dl only, and the baseline's rows and columns of P
are turned by the rotation T that takes r to b+ / |b+| (P <- T P T^T on the baseline's block): the covariance
after the update is that of the error at the linearisation point b-, whose small-variance axis (the length) lies
along r; carried to the new estimate it lies along the new direction again. Without T the length axis of P lags the
direction by the angle of each update, the radial variance picks up the across-b variance times that angle
squared, and the length drifts the other way (measured: -1.6 mm on the clean 106-min pass, docs/attitude.md).

Implements: the reset step of the multiplicative EKF (Markley 2003, "Attitude error representations for Kalman
filtering", J. Guid. Control Dyn. 26(2); Sola 2017, "Quaternion kinematics for the error-state Kalman filter",
sec. 7.2 "ESKF reset": the covariance turned with the error's reference) for the direction of a baseline of
known-constant length, and the additive update for its length.
"""
from __future__ import annotations

import numpy as np

__all__ = ["rotation_between", "rigid_retract"]


def rotation_between(u0: np.ndarray, u1: np.ndarray) -> np.ndarray:
    """(3, 3) rotation about u0 x u1 that takes the unit vector u0 to the unit vector u1 (Rodrigues' formula)."""
    v = np.cross(u0, u1)
    c = float(u0 @ u1)
    vx = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + vx + vx @ vx / (1.0 + c)


def rigid_retract(x: np.ndarray, P: np.ndarray, b_prior_m: np.ndarray, b_idx: np.ndarray,
                  active: np.ndarray) -> np.ndarray:
    """In place: each active baseline j (b_idx (n_bl, 3) its state indices, b_prior_m (n_bl, 3) before the update)
    set to the additive update's direction with the length changed by the update's part along b only, and its rows
    and columns of P turned with it (module doc); returns the length changes removed (m, 0 where not active)."""
    out = np.zeros(b_idx.shape[0])
    for j in np.flatnonzero(active):
        ix = b_idx[j]
        b0, b1 = b_prior_m[j], x[ix]
        n0, n1 = float(np.sqrt(b0 @ b0)), float(np.sqrt(b1 @ b1))
        if not (n0 > 0.0 and n1 > 0.0):
            continue
        u0, u1 = b0 / n0, b1 / n1
        n_new = n0 + float(u0 @ (b1 - b0))
        x[ix] = u1 * n_new
        out[j] = n1 - n_new
        if u0 @ u1 > -0.5:
            T = rotation_between(u0, u1)
            P[ix, :] = T @ P[ix, :]
            P[:, ix] = P[:, ix] @ T.T
    return out
