"""Geometry of every epoch, computed once for the whole pass: platform state, lines of sight, range rates.

For baselines of a few metres the line of sight to a GNSS satellite is the same for every antenna to < 1e-6 rad,
so it is computed once per epoch at the platform reference point (its centre of mass from an SP3, or the master
antenna's position).

Implements: light time with the Sagnac rotation via gnssatt.gnss.geometry.emission_time_and_position;
range rate rho_dot = u . (v_sat - v_rx) (u receiver -> satellite, both Earth-fixed velocities).
Neglects: the lever arm between the reference point and each antenna in the line of sight (< 1e-6 rad).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnssatt.gnss.frames import ecef_to_geodetic
from gnssatt.gnss.geometry import elevation_azimuth_local, emission_time_and_position
from gnssatt.gnss.time import GpsTime

__all__ = ["EpochGeometry", "platform_state_from_sp3", "compute_geometry", "BACKGROUND_SHARE"]

#: compute_geometry(background=...): the share of the epochs computed here before the rest is ready (the rest in
#: the background while the filter runs through these). The filter takes ~3.5x longer per epoch than the geometry
#: (106-minute pass: 0.7-1.1 s against 0.23-0.31 s on an idle 2-core machine), so from a share of ~0.2 on it never
#: waits for the background part; 0.25 leaves a margin for a busy machine (docs/BENCHMARKS.md "Attitude job speed")
BACKGROUND_SHARE = 0.25
#: passes shorter than this many epochs are computed in one go (a fork costs more than their geometry)
BACKGROUND_MIN_EPOCHS = 1024


@dataclass
class EpochGeometry:
    """Per epoch (n_ep) and satellite (n_sat): los_ecef (n_ep, n_sat, 3) unit receiver -> satellite,
    range_rate_m_s (n_ep, n_sat), elevation_local_rad (n_ep, n_sat), valid (n_ep, n_sat) bool;
    r_platform_ecef_m, v_platform_ecef_m_s (n_ep, 3); platform_source: where the position came from."""

    los_ecef: np.ndarray
    range_rate_m_s: np.ndarray
    elevation_local_rad: np.ndarray
    valid: np.ndarray
    r_platform_ecef_m: np.ndarray
    v_platform_ecef_m_s: np.ndarray
    platform_source: str
    #: (first epoch, handle with result() and cancel()) of the epochs still computed in the background
    #: (compute_geometry(background=...)); None once every epoch is here
    pending: tuple | None = field(default=None, repr=False, compare=False)

    def ready(self, k_end: int) -> None:
        """Make epochs < k_end available: waits for the background part when k_end reaches into it."""
        if self.pending is not None and k_end > self.pending[0]:
            self.complete()

    def complete(self) -> None:
        """Every epoch available (waits for the background part, if any)."""
        if self.pending is None:
            return
        (k1, handle), self.pending = self.pending, None
        self.los_ecef[k1:], self.range_rate_m_s[k1:], self.elevation_local_rad[k1:], self.valid[k1:] = \
            handle.result()

    def cancel(self) -> None:
        """Stop the background part (the epochs it had not delivered stay invalid)."""
        if self.pending is not None:
            (_, handle), self.pending = self.pending, None
            handle.cancel()


def platform_state_from_sp3(sp3, t: GpsTime) -> tuple[np.ndarray, np.ndarray]:
    """(r_ecef_m (n, 3), v_ecef_m_s (n, 3)) of the first satellite of a platform SP3 at times t (NaN outside)."""
    from gnssatt.gnss.orbits.sp3_interp import interpolate_sp3, interpolate_sp3_velocity

    sat = sp3.sats[0]
    pos, _ = interpolate_sp3(sp3, [sat], t)
    vel = interpolate_sp3_velocity(sp3, [sat], t)
    return pos[:, 0], vel[:, 0]


def compute_geometry(t: GpsTime, sats: list[str], observed: np.ndarray, sat_state, r_platform_ecef_m: np.ndarray,
                     v_platform_ecef_m_s: np.ndarray, platform_source: str, background=None) -> EpochGeometry:
    """EpochGeometry for epochs t (n_ep,), satellites `sats`, where `observed` (n_ep, n_sat) is True.

    Args:
        sat_state: callable (sats, t) -> (r, v, clock, ...) ECEF (see gnssatt.gnss.geometry).
        r_platform_ecef_m, v_platform_ecef_m_s: (n_ep, 3) reference point state (NaN rows -> invalid epoch).
        background: None, or a callable fn -> handle (result(), cancel()) that runs fn elsewhere, e.g.
            worker.forked.Forked: the first BACKGROUND_SHARE of the epochs (whole SD blocks) are computed here,
            the rest by fn meanwhile; the geometry's `ready(k_end)` / `complete()` wait for it (the filter calls
            ready before each SD block). Each epoch's values are computed by the same vectorised code either way
            (per observation pair: the same numbers whatever the split).
    """
    n_ep = observed.shape[0]
    state = (t, sats, observed, sat_state, r_platform_ecef_m, v_platform_ecef_m_s)
    if background is None or n_ep < BACKGROUND_MIN_EPOCHS:
        los, rr, el, valid = _geometry_arrays(*state, 0, n_ep)
        return EpochGeometry(los, rr, el, valid, r_platform_ecef_m, v_platform_ecef_m_s, platform_source)
    from gnssatt.attitude.sd_block import BLOCK_EPOCHS

    k1 = BLOCK_EPOCHS * max(1, round(BACKGROUND_SHARE * n_ep / BLOCK_EPOCHS))
    handle = background(lambda: _geometry_arrays(*state, k1, n_ep))
    try:
        head = _geometry_arrays(*state, 0, k1)
    except BaseException:
        handle.cancel()
        raise
    n_sat = observed.shape[1]
    los, rr = np.full((n_ep, n_sat, 3), np.nan), np.zeros((n_ep, n_sat))
    el, valid = np.full((n_ep, n_sat), np.nan), np.zeros((n_ep, n_sat), bool)
    los[:k1], rr[:k1], el[:k1], valid[:k1] = head
    return EpochGeometry(los, rr, el, valid, r_platform_ecef_m, v_platform_ecef_m_s, platform_source,
                         pending=(k1, handle))


def _geometry_arrays(t: GpsTime, sats: list[str], observed: np.ndarray, sat_state, r_platform_ecef_m: np.ndarray,
                     v_platform_ecef_m_s: np.ndarray, k0: int, k1: int):
    """(los_ecef, range_rate_m_s, elevation_local_rad, valid) of epochs k0:k1 (compute_geometry's arrays)."""
    observed, r_rx, v_rx_all = observed[k0:k1], r_platform_ecef_m[k0:k1], v_platform_ecef_m_s[k0:k1]
    n_ep, n_sat = observed.shape
    los = np.full((n_ep, n_sat, 3), np.nan)
    rr = np.full((n_ep, n_sat), np.nan)
    el = np.full((n_ep, n_sat), np.nan)
    ok_rx = np.isfinite(r_rx).all(-1)
    ie, js = np.nonzero(observed & ok_rx[:, None])
    if ie.size:
        sat_ids = np.asarray(sats)[js]
        tr = GpsTime(t.s[k0:k1][ie], t.frac[k0:k1][ie])
        res = emission_time_and_position(sat_state, sat_ids, r_rx[ie], tr)
        los[ie, js] = res.los_ecef
        v_rx = np.nan_to_num(v_rx_all[ie])
        rr[ie, js] = np.einsum("ij,ij->i", res.los_ecef, res.v_sat_ecef_m_s - v_rx)
        e, _ = elevation_azimuth_local(r_rx[ie], res.r_sat_ecef_m)
        el[ie, js] = e
    valid = np.isfinite(los).all(-1) & np.isfinite(rr)
    rr = np.where(valid, rr, 0.0)
    return los, rr, el, valid


def geodetic_of(r_ecef_m: np.ndarray):
    """(lat_rad, lon_rad, h_m) of ECEF positions (..., 3) on WGS 84."""
    return ecef_to_geodetic(r_ecef_m)
