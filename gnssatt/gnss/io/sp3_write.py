"""Write an SP3-d orbit file (positions, optional velocities) for one or more satellites/platforms.

Implements: SP3-d (Hilla 2016, "The Extended Standard Product 3 Orbit Format (SP3-d)"): header lines
#d, ##, + / ++ (at least 5 each), %c, %f, %i (2 each), /* (at least 4); epoch lines `*  YYYY MM DD HH
MM SS.SSSSSSSS`; P records in km and clock in microseconds (999999.999999 = absent); V records in dm/s
and clock rate in 1e-4 us/s; `EOF`.
"""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from gnssatt.gnss.time import GpsTime

ABSENT = 999999.999999


def write_sp3(path: str | Path, times: GpsTime, sats: Sequence[str], r_ecef_m: np.ndarray,
              v_ecef_m_s: np.ndarray | None = None, clock_us: np.ndarray | None = None, *,
              coord_sys: str = "IGS14", orbit_type: str = "FIT", agency: str = "GSIM",
              data_used: str = "ORBIT", file_type: str = "L", comments: Sequence[str] = ()) -> Path:
    """Write SP3-d file `path`; returns the path.

    Args:
        times: (n_ep,) GpsTime epochs (equally spaced), sats: ids like 'L01', 'G05'.
        r_ecef_m: (n_ep, n_sat, 3) ECEF positions in metres; v_ecef_m_s: same shape in m/s or None.
        clock_us: (n_ep, n_sat) clock offsets in microseconds or None (written as absent).
        file_type: SP3 file type letter (G, M, R, L, E, ...).
    """
    path = Path(path)
    n_ep, n_sat = len(times), len(sats)
    r_ecef_m = np.asarray(r_ecef_m, dtype=np.float64).reshape(n_ep, n_sat, 3)
    y, mo, d, hh, mi, ss = (np.atleast_1d(a) for a in times.calendar())
    week, sow = times.week_sow()
    week, sow = np.atleast_1d(week), np.atleast_1d(sow)
    interval = float(times[1] - times[0]) if n_ep > 1 else 0.0
    mjd_full = (times[0].s // 86400) + 44244
    frac = float((times[0].s % 86400) + times[0].frac) / 86400.0
    pv = "V" if v_ecef_m_s is not None else "P"
    lines = [f"#d{pv}{int(y[0]):4d}{int(mo[0]):3d}{int(d[0]):3d}{int(hh[0]):3d}{int(mi[0]):3d}{float(ss[0]):12.8f}"
             f"{n_ep:8d} {data_used:5.5s} {coord_sys:5.5s} {orbit_type:3.3s} {agency:4.4s}",
             f"## {int(week[0]):4d} {float(sow[0]):15.8f} {interval:14.8f} {int(mjd_full):5d} {frac:15.13f}"]
    ids = list(sats) + ["  0"] * ((-n_sat) % 17 or 0)
    ids += ["  0"] * max(0, 85 - len(ids))
    for k in range(0, len(ids), 17):
        chunk = "".join(f"{s:>3s}" for s in ids[k:k + 17])
        lines.append((f"+  {n_sat:3d}   " if k == 0 else "+        ") + chunk)
    for k in range(0, len(ids), 17):
        lines.append("++       " + "".join("  0" for _ in ids[k:k + 17]))
    lines += [f"%c {file_type:2.2s} cc GPS ccc cccc cccc cccc cccc ccccc ccccc ccccc ccccc",
              "%c cc cc ccc ccc cccc cccc cccc cccc ccccc ccccc ccccc ccccc",
              "%f  1.2500000  1.025000000  0.00000000000  0.000000000000000",
              "%f  0.0000000  0.000000000  0.00000000000  0.000000000000000",
              "%i    0    0    0    0      0      0      0      0         0",
              "%i    0    0    0    0      0      0      0      0         0"]
    comments = list(comments) + ["gnssatt"] * max(0, 4 - len(comments))
    lines += [f"/* {c[:57]}" for c in comments]
    r_km = r_ecef_m / 1e3
    clk = np.full((n_ep, n_sat), ABSENT) if clock_us is None else np.asarray(clock_us).reshape(n_ep, n_sat)
    v_dm = None if v_ecef_m_s is None else np.asarray(v_ecef_m_s).reshape(n_ep, n_sat, 3) * 10.0
    for k in range(n_ep):
        lines.append(f"*  {int(y[k]):4d}{int(mo[k]):3d}{int(d[k]):3d}{int(hh[k]):3d}{int(mi[k]):3d}"
                     f"{float(ss[k]):12.8f}")
        for j, s in enumerate(sats):
            x = r_km[k, j]
            lines.append(f"P{s:3s}{x[0]:14.6f}{x[1]:14.6f}{x[2]:14.6f}{clk[k, j]:14.6f}")
            if v_dm is not None:
                v = v_dm[k, j]
                lines.append(f"V{s:3s}{v[0]:14.6f}{v[1]:14.6f}{v[2]:14.6f}{ABSENT:14.6f}")
    lines.append("EOF")
    path.write_text("\n".join(lines) + "\n", encoding="ascii")
    return path
