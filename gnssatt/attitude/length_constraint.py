"""Dynamic mode: the known (rigid) baseline length as a soft constraint on the baseline states after each update.

The dynamic model only turns a baseline (b' = omega x b, no process noise along b), so its length sigma shrinks to
~0.1 mm and nothing brings the length back once the updates have moved it: the additive update b + db lengthens
b by |db_t|^2 / (2 |b|) per epoch (db_t the part of db across b), which adds up to +1.3 mm on average (+1.8 to
+2.1 mm at the end) over the clean 106-minute pass. Here, after the update of an epoch, the length of each fixed
baseline is moved towards the body length L (the platform's or the calibrated baseline) by the gain of a
pseudo-measurement |b| = L of variance sigma_L^2:
    |b| <- |b| + k (L - |b|),   k = r^T P_bb r / (r^T P_bb r + sigma_L^2),   r = b / |b|,
along b only (the direction, the angular velocity and every other state are left as they are), with P left as it
is: the body length is the same information at every epoch, and counting it as a new measurement each time would
shrink the length sigma to nothing. The attitude uses the directions and is not changed by it.

Implements: estimate projection onto a soft state constraint (Simon & Chia 2002, "Kalman filtering with state
equality constraints", IEEE TAES 38(1); Simon 2010, IET Control Theory Appl. 4(8), sec. 2.5) restricted to the
baseline's length; the known baseline length of seed 000 sec. 2.
"""
from __future__ import annotations

import numpy as np

__all__ = ["project_lengths", "rescale_lengths"]


def project_lengths(x: np.ndarray, P: np.ndarray, b_idx: np.ndarray, lengths_m: np.ndarray, sigma_m: float,
                    active: np.ndarray) -> np.ndarray:
    """In place: the length of each active baseline j (b_idx (n_bl, 3) its state indices) moved towards
    lengths_m[j] by the soft constraint's gain (module doc); returns the length changes applied (m, 0 where not)."""
    out = np.zeros(b_idx.shape[0])
    for j in np.flatnonzero(active):
        ix = b_idx[j]
        b = x[ix]
        n = float(np.sqrt(b @ b))
        if n <= 0.0:
            continue
        r = b / n
        p_r = float(r @ P[np.ix_(ix, ix)] @ r)
        if not p_r > 0.0:
            continue
        dl = p_r / (p_r + sigma_m * sigma_m) * (float(lengths_m[j]) - n)
        x[ix] = r * (n + dl)
        out[j] = dl
    return out


def rescale_lengths(b_m: np.ndarray, lengths_m: np.ndarray) -> np.ndarray:
    """Baselines b_m (..., 3) with their directions and the lengths lengths_m (...) (the smoother's baselines with
    the forward filter's lengths: its backward corrections are rotations of a rigid baseline, applied additively they
    change the length by their second order, as the forward update does)."""
    n = np.linalg.norm(b_m, axis=-1, keepdims=True)
    return b_m / np.where(n > 0, n, 1.0) * lengths_m[..., None]
