"""The platform's position and velocity at a set's epochs when the set carries no SP3 of the platform: from the
code observations of one antenna, by single point positioning with velocity (gnssatt.gnss.positioning.spp), as
CONVENTIONS.md promises ("Without it the service computes the platform's position and velocity itself").

What calibration needs them for: the lines of sight (a few metres of position error turn a line of sight by
< 1e-6 rad at GNSS distances) and the range rates of the clock/sampling term kappa rhodot / c of
gnssatt.calibration.kinematic (1 m/s of velocity error with a 1 us differential clock: 1 mm; the SPP velocity
from Doppler is good to cm/s). Epochs without a fix take the nearest fix propagated linearly with its velocity.

Implements: the attitude job's own fallback (gnssatt.attitude.process, single point positioning of the master
antenna), over the calibration's epochs.
"""
from __future__ import annotations

import numpy as np

from gnssatt.gnss.time import GpsTime

__all__ = ["PlatformState", "platform_state_from_code"]

#: longest distance (s) from an SPP fix over which an epoch's position is propagated with the fix's velocity
MAX_PROPAGATION_S = 30.0


class PlatformState:
    """r_ecef_m, v_ecef_m_s (n_ep, 3) at the epochs (NaN where none) and where they came from."""

    def __init__(self, r_ecef_m: np.ndarray, v_ecef_m_s: np.ndarray, source: str):
        self.r_ecef_m, self.v_ecef_m_s, self.source = r_ecef_m, v_ecef_m_s, source


def _tag_ms(t: GpsTime) -> np.ndarray:
    return np.asarray(t.s).astype(np.int64) * 1000 + np.round(np.asarray(t.frac) * 1000.0).astype(np.int64)


def platform_state_from_code(obs, ephemeris, epochs: GpsTime, name: str) -> PlatformState:
    """PlatformState of the receiver of `obs` (RinexObs) at `epochs` (receiver time tags) by SPP with velocity.

    Raises ValueError naming `name` (the observation file) when no epoch gets a position.
    """
    from gnssatt.gnss.positioning import SppOptions, spp

    sol = spp(obs, ephemeris, SppOptions(systems=("G",), velocity=True))
    tags, want = _tag_ms(sol.time_tag), _tag_ms(epochs)
    good = np.isfinite(sol.position_ecef_m).all(-1) & np.isfinite(sol.velocity_ecef_m_s).all(-1)
    if not good.any():
        raise ValueError(f"{name}: single point positioning gave no position with velocity (too few GPS code "
                         "observations or no Doppler); add an SP3 of the platform to the set")
    gi = np.flatnonzero(good)
    g_tags = tags[gi]
    pos = np.searchsorted(g_tags, want)
    lo, hi = np.clip(pos - 1, 0, len(gi) - 1), np.clip(pos, 0, len(gi) - 1)
    near = np.where(np.abs(g_tags[hi] - want) <= np.abs(g_tags[lo] - want), hi, lo)
    dt_s = (want - g_tags[near]) / 1000.0
    r0, v0 = sol.position_ecef_m[gi[near]], sol.velocity_ecef_m_s[gi[near]]
    r = r0 + dt_s[:, None] * v0
    ok = np.abs(dt_s) <= MAX_PROPAGATION_S
    r[~ok], v = np.nan, np.where(ok[:, None], v0, np.nan)
    return PlatformState(r, v, f"single point positioning of {name} (no SP3 of the platform)")
