"""Fast RINEX 3.04 observation writer for simulated GPS data (private; the shared writer is
gnssatt/gnss/io/rinex_obs_write.py once it lands).

Implements: RINEX 3.04 sec. 5 and Tables A1-A3: header labels, EPOCH record
`A1,1X,I4,4(1X,I2.2),F11.7,2X,I1,I3,6X,F15.12`, observation records `A1,I2.2,m(F14.3,I1,I1)`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gnssatt.gnss.time import GpsTime


def _h(text: str, label: str) -> str:
    return f"{text:<60.60}{label:<20.20}\n"


def _t(t: GpsTime) -> tuple:
    y, mo, d, hh, mi, ss = t.calendar()
    return int(y), int(mo), int(d), int(hh), int(mi), float(ss)


def write_obs(path: Path, *, marker: str, obs_types: list[str], epochs: GpsTime, sats: list[str],
              values: np.ndarray, lli: np.ndarray, ssi: np.ndarray, interval_s: float, approx_xyz_m,
              antenna_delta_xyz_m, boresight, receiver: str, antenna_type: str, leap_s: int,
              comments: list[str], date_text: str) -> Path:
    """Write one RINEX 3.04 GPS observation file.

    Args:
        values: (n_ep, n_sv, n_obs) float, NaN = blank; lli/ssi: (n_ep, n_sv, n_obs) int, 0 = blank.
        epochs: (n_ep,) receiver time tags (epochs without any value are skipped).
    """
    n_ep, n_sv, n_obs = values.shape
    present = ~np.isnan(values)
    any_sat = present.any(axis=2)
    keep = any_sat.any(axis=1)
    head = [_h(f"{'3.04':>9s}{'':11s}{'OBSERVATION DATA':<20s}{'G: GPS':<20s}", "RINEX VERSION / TYPE"),
            _h(f"{'gnssatt-sim':<20s}{'gnssatt':<20s}{date_text:<20s}", "PGM / RUN BY / DATE")]
    head += [_h(c, "COMMENT") for c in comments]
    head += [_h(marker, "MARKER NAME"), _h("SPACEBORNE" if "space" in receiver.lower() else "GEODETIC",
                                           "MARKER TYPE"),
             _h(f"{'simulator':<20s}{'gnssatt':<40s}", "OBSERVER / AGENCY"),
             _h(f"{'SIM-' + marker:<20.20s}{receiver:<20.20s}{'sim':<20s}", "REC # / TYPE / VERS"),
             _h(f"{'SIM-' + marker:<20.20s}{antenna_type:<20.20s}", "ANT # / TYPE"),
             _h("".join(f"{v:14.4f}" for v in approx_xyz_m), "APPROX POSITION XYZ"),
             _h("".join(f"{v:14.4f}" for v in (0.0, 0.0, 0.0)), "ANTENNA: DELTA H/E/N"),
             _h("".join(f"{v:14.4f}" for v in antenna_delta_xyz_m), "ANTENNA: DELTA X/Y/Z"),
             _h("".join(f"{v:14.4f}" for v in boresight), "ANTENNA: B.SIGHT XYZ")]
    types = "".join(f" {t}" for t in obs_types)
    head.append(_h(f"G{n_obs:5d}{types[:52]}", "SYS / # / OBS TYPES"))
    rest = obs_types[13:]
    while rest:
        head.append(_h(f"{'':6s}" + "".join(f" {t}" for t in rest[:13]), "SYS / # / OBS TYPES"))
        rest = rest[13:]
    head.append(_h("DBHZ", "SIGNAL STRENGTH UNIT"))
    head.append(_h(f"{interval_s:10.3f}", "INTERVAL"))
    idx = np.nonzero(keep)[0]
    if len(idx):
        for k, label in ((idx[0], "TIME OF FIRST OBS"), (idx[-1], "TIME OF LAST OBS")):
            y, mo, d, hh, mi, ss = _t(epochs[int(k)])
            head.append(_h(f"{y:6d}{mo:6d}{d:6d}{hh:6d}{mi:6d}{ss:13.7f}     GPS", label))
    for t in obs_types:
        if t.startswith("L"):
            head.append(_h(f"G {t} {0.0:8.5f}", "SYS / PHASE SHIFT"))
    head.append(_h(f"{leap_s:6d}", "LEAP SECONDS"))
    head.append(_h("", "END OF HEADER"))
    out = ["".join(head)]
    y, mo, d, hh, mi, ss = (np.atleast_1d(a) for a in epochs.calendar())
    # preformat every field: 14.3f + LLI + SSI, or 16 blanks
    vtxt = np.where(present, values, 0.0)
    blank = " " * 16
    lli_c = np.where(lli > 0, lli, -1)
    ssi_c = np.where(ssi > 0, ssi, -1)
    sats_arr = np.asarray(sats)
    for k in idx:
        ks = np.nonzero(any_sat[k])[0]
        out.append(f"> {int(y[k]):4d} {int(mo[k]):02d} {int(d[k]):02d} {int(hh[k]):02d} {int(mi[k]):02d}"
                   f"{float(ss[k]):11.7f}  0{len(ks):3d}\n")
        rows_v = vtxt[k, ks].tolist()
        rows_p = present[k, ks].tolist()
        rows_l = lli_c[k, ks].tolist()
        rows_s = ssi_c[k, ks].tolist()
        for sat, vv, pp, ll, sg in zip(sats_arr[ks].tolist(), rows_v, rows_p, rows_l, rows_s):
            fields = [(f"{v:14.3f}{(str(l) if l >= 0 else ' ')}{(str(s) if s >= 0 else ' ')}" if p else blank)
                      for v, p, l, s in zip(vv, pp, ll, sg)]
            out.append((sat + "".join(fields)).rstrip() + "\n")
    path.write_text("".join(out), encoding="ascii")
    return path
