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

The baselines of one platform turn together: most of an epoch's move is a common rotation phi of the body
(db_j ~ phi x b_j, the least-squares phi over the fixed baselines). Normalising each b_j + db_j on its own turns b_j
about the part of phi across b_j only, which differs from the rotation by phi at second order, (phi . b_j) phi_t / 2,
and changes the angle between two baselines by ~ the product of phi's components along them per epoch: summed over
the updates of an hour (rms ~0.6 mrad per epoch, what the additive update's +1.3 mm length growth implies) the
angle between the two baselines of the clean 106-min pass drifted by -0.09 deg (measured; with the body rotation it
stays within 0.01 deg of -0.003 deg after the first 5 minutes). So phi is applied exactly, b_j <- exp(phi) (b_j +
db_j - phi x b_j) (the remainder, first order, added before the turn) with the length as above, and P's block of b_j
turned by exp(phi) followed by the small turn that takes exp(phi) r to the new direction: the body's rotation.
Against the first-order covariance of the retracted state, J P J^T with J = d(retraction)/d(b + db): J's length row
is exactly the turn's (u1^T J = r^T on the baseline's own move, 0 on the others'); its across-b rows differ by terms
of the order of phi (the exponential map's derivative, the coupling through phi), which change Table 1's filter on
seed 000 Fig. 6's pitch-up by -0.001..+0.003 deg (docs/BENCHMARKS.md "Rigid update: the covariance turn against the
retraction's Jacobian"), so the turn is kept.

Implements: the reset step of the multiplicative EKF (Markley 2003, "Attitude error representations for Kalman
filtering", J. Guid. Control Dyn. 26(2); Sola 2017, "Quaternion kinematics for the error-state Kalman filter",
sec. 7.2 "ESKF reset": the covariance turned with the error's reference) for the directions of the baselines of a
rigid body (the common rotation by the exponential map of SO(3)) of known-constant lengths, and the additive update
for each length.
"""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.rigid_kernels import rigid_retract_kernel
from gnssatt.gnss.rotations import skew

__all__ = ["common_rotation", "rotation_between", "rotation_exp", "rigid_retract", "rigid_retract_reference"]


def rotation_between(u0: np.ndarray, u1: np.ndarray) -> np.ndarray:
    """(3, 3) rotation about u0 x u1 that takes the unit vector u0 to the unit vector u1 (Rodrigues' formula)."""
    v = np.cross(u0, u1)
    c = float(u0 @ u1)
    vx = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + vx + vx @ vx / (1.0 + c)


def rotation_exp(phi: np.ndarray) -> np.ndarray:
    """(3, 3) rotation by the rotation vector phi (rad; Rodrigues' formula, the exponential map of SO(3)): the
    transpose of rotations.quat_to_dcm(rotations.quat_from_rotvec(phi)) (their frame rotation), written out here
    because the filter and the rigid smoother call it per epoch (~11 us against ~39 us through the quaternion)."""
    a = float(np.sqrt(phi @ phi))
    K = skew(phi)
    if a < 1e-8:
        return np.eye(3) + K + 0.5 * K @ K
    return np.eye(3) + np.sin(a) / a * K + (1.0 - np.cos(a)) / (a * a) * K @ K


def common_rotation(b0_m: np.ndarray, d_m: np.ndarray) -> np.ndarray:
    """(3,) rotation vector phi (rad) of the least-squares common rotation of the baselines b0_m (n, 3) that explains
    their moves d_m (n, 3) to first order: min sum_j |d_j - phi x b0_j|^2 (the body rotation; with one baseline, or
    parallel ones, the minimum-norm solution: no turn about the baseline)."""
    S = skew(np.asarray(b0_m, float))                          # phi x b = -[b]x phi
    N = np.einsum("jki,jkl->il", S, S)
    rhs = -np.einsum("jki,jk->i", S, d_m)
    return np.linalg.lstsq(N, rhs, rcond=1e-10)[0]


def rigid_retract(x: np.ndarray, P: np.ndarray, b_prior_m: np.ndarray, b_idx: np.ndarray,
                  active: np.ndarray) -> np.ndarray:
    """rigid_retract_reference (same arguments, in place, same return) by the compiled kernel
    (gnssatt.attitude.rigid_kernels.rigid_retract_kernel: one call where the reference makes ~30 numpy calls)."""
    out = np.zeros(b_idx.shape[0])
    rigid_retract_kernel(x, P, np.ascontiguousarray(b_prior_m, dtype=np.float64),
                         np.ascontiguousarray(b_idx, dtype=np.int64), np.ascontiguousarray(active, dtype=np.bool_), out)
    return out


def rigid_retract_reference(x: np.ndarray, P: np.ndarray, b_prior_m: np.ndarray, b_idx: np.ndarray,
                            active: np.ndarray) -> np.ndarray:
    """In place: the active baselines (b_idx (n_bl, 3) their state indices, b_prior_m (n_bl, 3) before the update)
    moved by the common rotation of their additive moves applied exactly (exp of common_rotation) and each one's
    remainder (what the common rotation leaves, first order), the length changed by the move's part along b only,
    and each baseline's rows and columns of P turned with it (module doc); returns the length changes removed (m, 0
    where not active)."""
    out = np.zeros(b_idx.shape[0])
    act = [j for j in np.flatnonzero(active) if np.linalg.norm(b_prior_m[j]) > 0 and np.linalg.norm(x[b_idx[j]]) > 0]
    if not act:
        return out
    B0 = np.asarray(b_prior_m, float)[act]
    D = np.stack([x[b_idx[j]] for j in act]) - B0
    phi = common_rotation(B0, D)
    R = rotation_exp(phi)
    for i, j in enumerate(act):
        ix = b_idx[j]
        b0, d = B0[i], D[i]
        n0 = float(np.sqrt(b0 @ b0))
        u0 = b0 / n0
        c = R @ (b0 + d - np.cross(phi, b0))               # the body rotation of b0 plus the remainder
        n_new = n0 + float(u0 @ d)
        u1 = c / np.linalg.norm(c)
        out[j] = float(np.linalg.norm(b0 + d)) - n_new
        x[ix] = u1 * n_new
        Ru0 = R @ u0
        if Ru0 @ u1 > -0.5:
            T = rotation_between(Ru0, u1) @ R
            P[ix, :] = T @ P[ix, :]
            P[:, ix] = P[:, ix] @ T.T
    return out
