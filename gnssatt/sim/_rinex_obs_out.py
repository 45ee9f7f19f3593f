"""Fast RINEX 3.04 observation writer for simulated GPS / GLONASS data (private; the shared writer is
gnssatt/gnss/io/rinex_obs_write.py once it lands).

Implements: RINEX 3.04 sec. 5 and Tables A1-A3: header labels, EPOCH record
`A1,1X,I4,4(1X,I2.2),F11.7,2X,I1,I3,6X,F15.12`, observation records `A1,I2.2,m(F14.3,I1,I1)`; GLONASS SLOT /
FRQ # `I3,1X,8(A1,I2.2,1X,I2,1X)` and GLONASS COD/PHS/BIS `4(1X,A3,1X,F8.3)` (RINEX 3.04 Table A2).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gnssatt.gnss.time import GpsTime


def _h(text: str, label: str) -> str:
    return f"{text:<60.60}{label:<20.20}\n"


def _t(t: GpsTime) -> tuple:
    y, mo, d, hh, mi, ss = t.calendar()
    return int(y), int(mo), int(d), int(hh), int(mi), float(ss)


@dataclass(frozen=True)
class ObsHeader:
    """What the header of one simulated observation file says besides the data (RINEX 3.04 Table A2 labels)."""

    marker: str                      # MARKER NAME (the antenna id)
    obs_types: list[str]             # SYS / # / OBS TYPES, e.g. ["C1C", "L1C", "D1C", "S1C"]
    interval_s: float                # INTERVAL
    approx_xyz_m: np.ndarray         # APPROX POSITION XYZ (ECEF, m)
    antenna_delta_xyz_m: np.ndarray  # ANTENNA: DELTA X/Y/Z (body frame, m)
    boresight: np.ndarray            # ANTENNA: B.SIGHT XYZ (body frame unit vector)
    receiver: str                    # REC # / TYPE / VERS (also decides MARKER TYPE)
    antenna_type: str                # ANT # / TYPE
    leap_s: int                      # LEAP SECONDS
    comments: list[str]              # COMMENT lines
    date_text: str                   # PGM / RUN BY / DATE
    systems: str = "G"               # "G", "R" or "GR": which SYS / # / OBS TYPES lines (and the file type)
    glonass_obs_types: tuple = ()    # SYS / # / OBS TYPES of R (as many as obs_types, same columns)
    glonass_slots: tuple = ()        # ((slot, k), ...) for GLONASS SLOT / FRQ #
    marker_type: str = ""            # MARKER TYPE; "" -> SPACEBORNE for a spaceborne receiver, else GEODETIC


def write_obs(path: Path, header: ObsHeader, *, epochs: GpsTime, sats: list[str], values: np.ndarray,
              lli: np.ndarray, ssi: np.ndarray) -> Path:
    """Write one RINEX 3.04 observation file (GPS, GLONASS or mixed: header.systems).

    Args:
        header: the header fields (ObsHeader).
        values: (n_ep, n_sv, n_obs) float, NaN = blank; lli/ssi: (n_ep, n_sv, n_obs) int, 0 = blank.
        epochs: (n_ep,) receiver time tags (epochs without any value are skipped).
    """
    present = ~np.isnan(values)
    any_sat = present.any(axis=2)
    idx = np.nonzero(any_sat.any(axis=1))[0]
    out = [_header_text(header, epochs, idx, values.shape[2])]
    out += _epoch_records(epochs, sats, values, lli, ssi, idx)
    path.write_text("".join(out), encoding="ascii")
    return path


def _header_text(hd: ObsHeader, epochs: GpsTime, idx: np.ndarray, n_obs: int) -> str:
    """The header of the file, RINEX 3.04 Table A2; ``idx`` are the epochs written (first/last obs)."""
    marker, obs_types, receiver = hd.marker, hd.obs_types, hd.receiver
    system = {"G": "G: GPS", "R": "R: GLONASS"}.get(hd.systems, "M: MIXED")
    head = [_h(f"{'3.04':>9s}{'':11s}{'OBSERVATION DATA':<20s}{system:<20s}", "RINEX VERSION / TYPE"),
            _h(f"{'gnssatt-sim':<20s}{'gnssatt':<20s}{hd.date_text:<20s}", "PGM / RUN BY / DATE")]
    head += [_h(c, "COMMENT") for c in hd.comments]
    marker_type = hd.marker_type or ("SPACEBORNE" if "space" in receiver.lower() else "GEODETIC")
    head += [_h(marker, "MARKER NAME"), _h(marker_type, "MARKER TYPE"),
             _h(f"{'simulator':<20s}{'gnssatt':<40s}", "OBSERVER / AGENCY"),
             _h(f"{'SIM-' + marker:<20.20s}{receiver:<20.20s}{'sim':<20s}", "REC # / TYPE / VERS"),
             _h(f"{'SIM-' + marker:<20.20s}{hd.antenna_type:<20.20s}", "ANT # / TYPE"),
             _h("".join(f"{v:14.4f}" for v in hd.approx_xyz_m), "APPROX POSITION XYZ"),
             _h("".join(f"{v:14.4f}" for v in (0.0, 0.0, 0.0)), "ANTENNA: DELTA H/E/N"),
             _h("".join(f"{v:14.4f}" for v in hd.antenna_delta_xyz_m), "ANTENNA: DELTA X/Y/Z"),
             _h("".join(f"{v:14.4f}" for v in hd.boresight), "ANTENNA: B.SIGHT XYZ")]
    by_sys = [(x, obs_types if x == "G" else list(hd.glonass_obs_types)) for x in "GR" if x in hd.systems]
    for sys_char, sys_types in by_sys:
        types = "".join(f" {t}" for t in sys_types)
        head.append(_h(f"{sys_char}{n_obs:5d}{types[:52]}", "SYS / # / OBS TYPES"))
        rest = sys_types[13:]
        while rest:
            head.append(_h(f"{'':6s}" + "".join(f" {t}" for t in rest[:13]), "SYS / # / OBS TYPES"))
            rest = rest[13:]
    head.append(_h("DBHZ", "SIGNAL STRENGTH UNIT"))
    head.append(_h(f"{hd.interval_s:10.3f}", "INTERVAL"))
    if len(idx):
        for k, label in ((idx[0], "TIME OF FIRST OBS"), (idx[-1], "TIME OF LAST OBS")):
            y, mo, d, hh, mi, ss = _t(epochs[int(k)])
            head.append(_h(f"{y:6d}{mo:6d}{d:6d}{hh:6d}{mi:6d}{ss:13.7f}     GPS", label))
    for sys_char, sys_types in by_sys:
        for t in sys_types:
            if t.startswith("L"):
                head.append(_h(f"{sys_char} {t} {0.0:8.5f}", "SYS / PHASE SHIFT"))
    if "R" in hd.systems:
        head += _glonass_header_lines(hd.glonass_slots)
    head.append(_h(f"{hd.leap_s:6d}", "LEAP SECONDS"))
    head.append(_h("", "END OF HEADER"))
    return "".join(head)


def _glonass_header_lines(slots) -> list[str]:
    """GLONASS SLOT / FRQ # (8 per line) and GLONASS COD/PHS/BIS (zero: no code-phase bias correction)."""
    out = []
    for i in range(0, max(len(slots), 1), 8):
        body = "".join(f"R{s:02d} {k:2d} " for s, k in slots[i:i + 8])
        out.append(_h((f"{len(slots):3d} " if i == 0 else "    ") + body, "GLONASS SLOT / FRQ #"))
    out.append(_h("".join(f" {c} {0.0:8.3f}" for c in ("C1C", "C1P", "C2C", "C2P")), "GLONASS COD/PHS/BIS"))
    return out


def _epoch_records(epochs: GpsTime, sats: list[str], values: np.ndarray, lli: np.ndarray, ssi: np.ndarray,
                   idx: np.ndarray) -> list[str]:
    """EPOCH and observation records of the epochs ``idx`` (RINEX 3.04 Table A3), blanks where NaN / 0."""
    present = ~np.isnan(values)
    any_sat = present.any(axis=2)
    out = []
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
    return out
