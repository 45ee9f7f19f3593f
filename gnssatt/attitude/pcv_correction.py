"""Differential phase-centre-variation (PCV) corrections of single differences in the attitude filter.

A map (../shared/CONVENTIONS.md "phase-centre-variation maps") holds, per antenna pair (first, second) and
frequency, the differential carrier-phase correction in mm to subtract from the single difference (second minus
first), on an azimuth x elevation grid of bin centres in the antenna frame of the pair's first antenna. Here:
looking a map up (bilinear between bin centres, azimuth periodic when the grid covers the circle) and the
correction of every (baseline, satellite, signal) of an epoch from the current attitude.

Empty bins (null) are never filled in: a direction whose nearest bin centre is empty, or that lies outside the
grid by more than half a bin, has no correction (NaN), and the filter then leaves that phase out once the
baseline is fixed (seed 000 sec. 3.2: after a fix, only satellites with a correction are used). Neighbouring
empty bins only drop out of the interpolation weights.

Implements: seed 000 sec. 3 (differential PCV maps applied to the single differences), CONVENTIONS.md map layout;
antenna frame of gnssatt.gnss.geometry.R_antenna_from_body.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PcvTable", "pcv_table", "lookup_mm", "pcv_tables_for", "epoch_correction_m"]


@dataclass(frozen=True)
class PcvTable:
    """A map prepared for lookups: axes of bin centres (azimuth extended by one wrapped bin at each end when
    periodic) and the values in mm (NaN where empty)."""

    azimuth_deg: np.ndarray    # (n_az_ext,) increasing
    elevation_deg: np.ndarray  # (n_el,) increasing
    values_mm: np.ndarray      # (n_el, n_az_ext)
    periodic: bool
    half_az_deg: float         # half a bin: how far outside the axes a direction may lie (non-periodic)
    half_el_deg: float


def _half_step(axis: np.ndarray) -> float:
    return 0.5 * float(np.min(np.diff(axis))) if axis.size > 1 else 0.5


def pcv_table(azimuth_deg, elevation_deg, values_mm) -> PcvTable:
    """PcvTable of a map given by its bin centres (increasing) and values (n_el, n_az), NaN (or None) empty.

    The azimuth axis is periodic when it spans the circle: a regular grid whose n steps make 360 deg (bin
    centres such as 1.25 ... 358.75), or nodes whose last equals the first + 360 (0 ... 360)."""
    az = np.asarray(azimuth_deg, dtype=np.float64)
    el = np.asarray(elevation_deg, dtype=np.float64)
    v = np.array([[np.nan if x is None else x for x in row] for row in values_mm], dtype=np.float64) \
        if isinstance(values_mm, list) else np.asarray(values_mm, dtype=np.float64)
    if v.shape != (el.size, az.size):
        raise ValueError(f"values {v.shape} do not match (elevation, azimuth) = ({el.size}, {az.size})")
    half_az = _half_step(az)
    periodic = False
    if az.size > 1:
        span = az[-1] - az[0]
        if abs(span - 360.0) < 1e-6:          # nodes with 360 == 0: interpolation never needs to wrap
            periodic = True
        elif abs(span + 2 * half_az - 360.0) < 1e-6 and np.allclose(np.diff(az), 2 * half_az):
            az = np.concatenate([[az[-1] - 360.0], az, [az[0] + 360.0]])
            v = np.concatenate([v[:, -1:], v, v[:, :1]], axis=1)
            periodic = True
    return PcvTable(az, el, v, periodic, half_az, _half_step(el))


def _bracket(axis: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower index i (0 .. n-2) and fraction f in [0, 1] of x between axis[i] and axis[i+1] (clamped)."""
    if axis.size == 1:
        return np.zeros(x.shape, np.int64), np.zeros(x.shape)
    i = np.clip(np.searchsorted(axis, x, side="right") - 1, 0, axis.size - 2)
    f = np.clip((x - axis[i]) / (axis[i + 1] - axis[i]), 0.0, 1.0)
    return i, f


def lookup_mm(table: PcvTable, az_deg, el_deg) -> np.ndarray:
    """Map value (mm) at each direction (az, el in the first antenna's frame, deg): bilinear between bin centres,
    over the filled neighbours only; NaN when the nearest bin centre is empty or the direction is off the grid.

    Implements: bilinear interpolation on a rectangular (azimuth, elevation) grid; CONVENTIONS.md map layout.
    """
    az = np.asarray(az_deg, dtype=np.float64)
    el = np.asarray(el_deg, dtype=np.float64)
    shape = np.broadcast_shapes(az.shape, el.shape)
    az = np.broadcast_to(az, shape).ravel()
    el = np.broadcast_to(el, shape).ravel()
    if table.periodic:
        a = np.mod(az, 360.0)
        a = np.where(a < table.azimuth_deg[0], a + 360.0, a)
        a = np.where(a > table.azimuth_deg[-1], a - 360.0, a)
    else:
        a = az
    off = ~np.isfinite(a) | ~np.isfinite(el) \
        | (el < table.elevation_deg[0] - table.half_el_deg - 1e-9) \
        | (el > table.elevation_deg[-1] + table.half_el_deg + 1e-9)
    if not table.periodic:
        off |= (a < table.azimuth_deg[0] - table.half_az_deg - 1e-9) \
            | (a > table.azimuth_deg[-1] + table.half_az_deg + 1e-9)
    a = np.nan_to_num(a)
    e = np.nan_to_num(el)
    ia, fa = _bracket(table.azimuth_deg, a)
    ie, fe = _bracket(table.elevation_deg, e)
    V = table.values_mm
    n_az, n_el = table.azimuth_deg.size, table.elevation_deg.size
    ia1 = np.minimum(ia + 1, n_az - 1)
    ie1 = np.minimum(ie + 1, n_el - 1)
    corners = [(ie, ia, (1 - fe) * (1 - fa)), (ie, ia1, (1 - fe) * fa), (ie1, ia, fe * (1 - fa)), (ie1, ia1, fe * fa)]
    num = np.zeros(a.shape)
    den = np.zeros(a.shape)
    for ei, ai, w in corners:
        val = V[ei, ai]
        ok = np.isfinite(val) & (w > 0)
        num += np.where(ok, w * np.nan_to_num(val), 0.0)
        den += np.where(ok, w, 0.0)
    # the nearest bin centre decides whether there is a correction at all (empty bins are not invented)
    near = V[np.where(fe < 0.5, ie, ie1), np.where(fa < 0.5, ia, ia1)]
    out = np.where(np.isfinite(near) & (den > 0) & ~off, num / np.where(den > 0, den, 1.0), np.nan)
    return out.reshape(shape)


def pcv_tables_for(maps: dict, antennas: list[str], baselines: list[tuple[int, int]],
                   signals: list[str]) -> dict[tuple[int, int], PcvTable]:
    """(baseline index, signal index) -> PcvTable for every map of `maps` ((first, second, freq) -> map dict in
    the CONVENTIONS layout) that belongs to a baseline and signal in use; maps of other pairs are ignored."""
    out = {}
    for j, (a, b) in enumerate(baselines):
        for f, sig in enumerate(signals):
            doc = maps.get((antennas[a], antennas[b], sig))
            if doc is None:                     # GPS "L1"/"L2" maps also serve "G:L1"/"G:L2" and the reverse
                from gnssatt.attitude.settings import SIGNAL_ALIASES
                canon = SIGNAL_ALIASES.get(sig, sig)
                doc = next((d for (x, y, fq), d in maps.items() if x == antennas[a] and y == antennas[b]
                            and SIGNAL_ALIASES.get(fq, fq) == canon), None)
            if doc is not None:
                out[(j, f)] = pcv_table(doc["azimuth_deg"], doc["elevation_deg"], doc["values_mm"])
    return out


def epoch_correction_m(tables: dict, los_body: np.ndarray, R_ant_from_body_first: np.ndarray,
                       n_sig: int) -> tuple[np.ndarray, np.ndarray]:
    """Differential PCV (m) to subtract from each single difference of one epoch, and where a map exists.

    Args:
        tables: (baseline, signal) -> PcvTable (pcv_tables_for).
        los_body: (n_sat, 3) unit lines of sight in the body frame (current attitude).
        R_ant_from_body_first: (n_bl, 3, 3) antenna-from-body rotation of each baseline's first antenna.
    Returns:
        corr_m (n_bl, n_sat, n_sig): the correction, NaN where the map has none (empty bin, off grid); 0 where
        the baseline/signal has no map. has_map (n_bl, n_sig) bool.
    """
    n_bl = R_ant_from_body_first.shape[0]
    n_sat = los_body.shape[0]
    corr = np.zeros((n_bl, n_sat, n_sig))
    has = np.zeros((n_bl, n_sig), bool)
    for (j, f), tab in tables.items():
        d = los_body @ R_ant_from_body_first[j].T                       # (n_sat, 3) antenna frame
        az = np.degrees(np.mod(np.arctan2(d[:, 1], d[:, 0]), 2 * np.pi))
        el = np.degrees(np.arctan2(d[:, 2], np.hypot(d[:, 0], d[:, 1])))
        corr[j, :, f] = lookup_mm(tab, az, el) * 1e-3
        has[j, f] = True
    return corr, has
