"""Single differences and the state-independent editing of a block of epochs, computed at once for the filter.

Everything here depends only on the observations and the geometry, not on the filter state, so the attitude
filter (gnssatt.attitude.filter.run_filter) takes it per block of epochs (bounded memory on long passes) instead
of recomputing it with a dozen small numpy calls per epoch. Values are the same element-wise operations as before.

Implements: seed 000 sec. 2 single differences (second antenna minus first), Table 2 editing by the local
elevation mask and by C/N0 (reason codes of gnssatt.attitude.filter.REASONS: 8 no geometry / partner, 1 local
elevation; C/N0 returned as a mask because the antenna-frame mask (state dependent) comes before it).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.gnss.constants import C_M_S

__all__ = ["SdBlock", "sd_block"]

BLOCK_EPOCHS = 256


@dataclass
class SdBlock:
    """Arrays over epochs k0..k1-1 (first axis, index k - k0)."""

    k0: int
    pa: np.ndarray        # (nb, n_bl) both antennas present
    u: np.ndarray         # (nb, n_sat, 3) line of sight, 0 where the geometry is invalid
    cfac: np.ndarray      # (nb, n_sat) clock partial 1 - rho_dot / c
    sdc: np.ndarray       # (nb, n_bl, n_sat, n_sig) SD code (m)
    sdp: np.ndarray       # SD phase (m)
    cn0: np.ndarray       # the lower C/N0 of the two antennas
    lli: np.ndarray       # (int) LLI bits of either antenna
    avail_c: np.ndarray   # SD code exists (finite, both present, geometry)
    avail_p: np.ndarray   # SD phase exists too
    reason: np.ndarray    # (int) 8 no SD / geometry, 1 below the local mask, else 0
    low_cn0: np.ndarray   # C/N0 below the signal's mask


def sd_block(pobs, geom, ia: np.ndarray, ib: np.ndarray, k0: int, k1: int, el_mask_local_rad: float,
             sig_cn0_dbhz: np.ndarray) -> SdBlock:
    """SdBlock of epochs k0..k1-1 for baselines (ia[j], ib[j])."""
    sl = slice(k0, k1)
    # epoch-major and C-contiguous, so each epoch's slice is a contiguous array (one compiled variant of the
    # filter's kernels whatever the number of baselines)
    ep = lambda a: np.ascontiguousarray(np.swapaxes(a, 0, 1))  # noqa: E731
    pa = ep(pobs.present[ia, sl] & pobs.present[ib, sl])                       # (nb, n_bl)
    gv = geom.valid[sl]                                                        # (nb, n_sat)
    u = np.where(gv[:, :, None], geom.los_ecef[sl], 0.0)
    cfac = 1.0 - geom.range_rate_m_s[sl] / C_M_S
    sdc = ep(pobs.code_m[ib, sl] - pobs.code_m[ia, sl])                        # (nb, n_bl, n_sat, n_sig)
    sdp = ep(pobs.phase_m[ib, sl] - pobs.phase_m[ia, sl])
    cn0 = ep(np.fmin(pobs.cn0_dbhz[ia, sl], pobs.cn0_dbhz[ib, sl]))
    lli = ep(np.maximum(pobs.lli[ia, sl], 0) | np.maximum(pobs.lli[ib, sl], 0))
    avail_c = np.isfinite(sdc) & pa[:, :, None, None] & gv[:, None, :, None]
    avail_p = np.isfinite(sdp) & avail_c
    reason = np.where(avail_c, 0, 8)
    bad_el = ~(geom.elevation_local_rad[sl] >= el_mask_local_rad)               # (nb, n_sat)
    reason = np.where((reason == 0) & bad_el[:, None, :, None], 1, reason)
    low = cn0 < sig_cn0_dbhz[None, None, None, :]
    return SdBlock(k0, pa, u, cfac, sdc, sdp, cn0, lli, avail_c, avail_p, reason, low)
