"""Reference attitude (star tracker) at observation epochs: spherical linear interpolation, gap refusal, frames.

The reference attitude CSV (CONVENTIONS.md "Reference attitude") gives GCRF->body or ECEF->body quaternions at
its own epochs. Calibration needs R_body_from_ecef at the GNSS epochs: each is interpolated between the two
bracketing reference rows by slerp (exact for a constant angular rate between the rows), in the frame the rows
are given in, and GCRF rows are then taken to ECEF with R_gcrf_from_ecef at the GNSS epoch (IAU 2006/2000A, EOP
as CONVENTIONS.md). An epoch whose bracketing rows are further apart than `max_gap_s`, or that lies outside the
reference span (beyond `edge_tolerance_s`), gets no reference (NaN and a False mask): a star-tracker gap is never
bridged by a guess.

Implements: Shoemake (1985) slerp on unit quaternions (shorter arc); CONVENTIONS.md quaternions (scalar first,
passive, w >= 0). Neglects: the angular acceleration between two rows (error ~ alpha h^2 / 8: < 0.01 arcsec for
an Earth-pointing platform at 1 Hz).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.gnss.frames import R_gcrf_from_ecef
from gnssatt.gnss.rotations import quat_multiply, quat_normalize, quat_to_dcm, dcm_to_quat
from gnssatt.gnss.time import GpsTime

DEFAULT_MAX_GAP_S = 10.0  # a star tracker at 1 Hz missing 9 samples is still bridged; longer gaps are not
DEFAULT_EDGE_TOLERANCE_S = 0.0  # GNSS epochs outside the reference span are not extrapolated


@dataclass
class ReferenceAtEpochs:
    """Reference attitude at n GNSS epochs.

    q_body_from_ecef: (n, 4) scalar-first, w >= 0, NaN where `ok` is False.
    R_body_from_ecef: (n, 3, 3) NaN where not ok.
    ok: (n,) bool, the epoch lies inside the reference span and between rows at most max_gap_s apart.
    """

    q_body_from_ecef: np.ndarray
    R_body_from_ecef: np.ndarray
    ok: np.ndarray

    @property
    def coverage(self) -> float:
        """Fraction of epochs with a reference."""
        return float(np.mean(self.ok)) if self.ok.size else 0.0


def slerp(q0, q1, u) -> np.ndarray:
    """Unit quaternions (..., 4) a fraction u (...,) of the way from q0 to q1 (..., 4) along the shorter arc.

    q(u) = q0 sin((1-u) W)/sin W + q1' sin(u W)/sin W, cos W = |q0 . q1|, q1' = sign(q0 . q1) q1; linear
    interpolation (then normalised) below W = 1e-6 rad where the ratio of sines is 1 to 1e-13.
    Implements: Shoemake (1985) "Animating rotation with quaternion curves", SIGGRAPH 85, eq. on p. 248.
    """
    q0 = np.asarray(q0, dtype=np.float64)
    q1 = np.asarray(q1, dtype=np.float64)
    u = np.asarray(u, dtype=np.float64)[..., None]
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0.0, -q1, q1)
    dot = np.clip(np.abs(dot), 0.0, 1.0)
    omega = np.arccos(dot)
    small = omega < 1e-6
    s = np.where(small, 1.0, np.sin(omega))
    a = np.where(small, 1.0 - u, np.sin((1.0 - u) * omega) / s)
    b = np.where(small, u, np.sin(u * omega) / s)
    return quat_normalize(a * q0 + b * q1)


def _interp_rows(t_ref: GpsTime, q_ref: np.ndarray, t: GpsTime, max_gap_s: float,
                 edge_tolerance_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(q (n, 4), ok (n,)) slerped between bracketing rows; see module docstring."""
    n = len(t)
    out = np.full((n, 4), np.nan)
    ok = np.zeros(n, dtype=bool)
    if len(t_ref) == 0 or n == 0:
        return out, ok
    # seconds relative to the first reference row, computed part by part (GpsTime differences)
    x_ref = t_ref - t_ref[0]
    x = t - t_ref[0]
    if len(t_ref) == 1:
        ok = np.abs(x) <= edge_tolerance_s
        out[ok] = q_ref[0]
        return out, ok
    k = np.clip(np.searchsorted(x_ref, x, side="right") - 1, 0, len(x_ref) - 2)
    h = x_ref[k + 1] - x_ref[k]
    u = (x - x_ref[k]) / h
    inside = (x >= x_ref[0] - edge_tolerance_s) & (x <= x_ref[-1] + edge_tolerance_s)
    ok = inside & (h <= max_gap_s)
    # at the edges (within the tolerance) hold the end row instead of extrapolating
    u = np.clip(u, 0.0, 1.0)
    q = slerp(q_ref[k], q_ref[k + 1], u)
    out[ok] = q[ok]
    return out, ok


def reference_at_epochs(ref, t: GpsTime, *, max_gap_s: float = DEFAULT_MAX_GAP_S,
                        edge_tolerance_s: float = DEFAULT_EDGE_TOLERANCE_S, eop=None) -> ReferenceAtEpochs:
    """ReferenceAtEpochs: ECEF->body attitude of a reference attitude at GNSS epochs t.

    Args:
        ref: gnssatt.gnss.io.reference_attitude.ReferenceAttitude (time, frame per row, q_body_from_frame).
        t: GpsTime (n,) epochs, GPS time.
        max_gap_s: longest step between reference rows that is interpolated across, s.
        edge_tolerance_s: how far outside the reference span an epoch may lie and still take the end row, s.
        eop: EOP source for GCRF<->ECEF (None: zero EOP, CONVENTIONS.md).
    Rows all in one frame are interpolated in that frame; a file mixing GCRF and ECEF rows is first brought to
    GCRF at each row's own time.
    Implements: slerp (Shoemake 1985); R_body_from_ecef = R_body_from_gcrf R_gcrf_from_ecef (IERS 2010 eq. 5.1).
    """
    frames = np.asarray(ref.frame).astype(str)
    q_ref = np.asarray(ref.q_body_from_frame, dtype=np.float64)
    if frames.size and np.all(frames == "ECEF"):
        q, ok = _interp_rows(ref.time, q_ref, t, max_gap_s, edge_tolerance_s)
    else:
        ecef_rows = frames == "ECEF"
        if np.any(ecef_rows):
            # q_body_from_gcrf = q_body_from_ecef (x) q_ecef_from_gcrf at the row's time
            R_e_g = np.swapaxes(R_gcrf_from_ecef(ref.time[np.flatnonzero(ecef_rows)], eop), -1, -2)
            q_ref = q_ref.copy()
            q_ref[ecef_rows] = quat_multiply(q_ref[ecef_rows], dcm_to_quat(R_e_g))
        q_gcrf, ok = _interp_rows(ref.time, q_ref, t, max_gap_s, edge_tolerance_s)
        q = np.full_like(q_gcrf, np.nan)
        if np.any(ok):
            idx = np.flatnonzero(ok)
            R_g_e = R_gcrf_from_ecef(t[idx], eop)
            q[idx] = quat_multiply(q_gcrf[idx], dcm_to_quat(R_g_e))
    R = np.full((len(t), 3, 3), np.nan)
    if np.any(ok):
        R[ok] = quat_to_dcm(q[ok])
    return ReferenceAtEpochs(q, R, ok)


def uncovered_spans(t: GpsTime, ok: np.ndarray, limit: int = 5) -> list[tuple[str, str]]:
    """Up to `limit` (first, last) ISO times of runs of epochs without a reference, for error messages."""
    spans = []
    bad = np.flatnonzero(~np.asarray(ok))
    if bad.size == 0:
        return spans
    breaks = np.flatnonzero(np.diff(bad) > 1)
    starts = np.concatenate([[bad[0]], bad[breaks + 1]])
    ends = np.concatenate([bad[breaks], [bad[-1]]])
    for a, b in zip(starts[:limit], ends[:limit]):
        spans.append((t[int(a)].iso(), t[int(b)].iso()))
    return spans


__all__ = ["ReferenceAtEpochs", "slerp", "reference_at_epochs", "uncovered_spans", "DEFAULT_MAX_GAP_S"]
