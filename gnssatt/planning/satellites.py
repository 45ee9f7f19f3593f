"""GNSS satellite positions for a plan (gnssatt.planning.series.SatPositions) from a navigation file's broadcast
ephemerides (IS-GPS-200 / the RINEX nav records, through gnssatt.gnss.ephemeris.BroadcastEphemeris)."""
from __future__ import annotations

import numpy as np

from gnssatt.gnss.ephemeris import BroadcastEphemeris

__all__ = ["positions_from_nav"]


def positions_from_nav(nav):
    """Callable t (GpsTime, n epochs) -> (sats, r_ecef_m (n, m, 3), NaN where no valid record) over every Kepler
    satellite of the NavData `nav`."""
    eph = BroadcastEphemeris(nav)
    sats = sorted({str(x) for k in nav.kepler.values() for x in k.sat})

    def positions(t):
        n = len(np.atleast_1d(t.s))
        r_ecef_m = np.full((n, len(sats), 3), np.nan)
        for j, sat in enumerate(sats):
            st = eph.state([sat] * n, t)
            r_ecef_m[:, j] = np.where(st.valid[:, None], st.r_ecef_m, np.nan)
        return sats, r_ecef_m
    return positions
