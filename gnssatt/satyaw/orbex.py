"""IGS ORBEX attitude files (ATT records): writer and reader (docs/formats/orbex.md).

ORBEX 0.09 (IGS, Loyer et al. 2019): a `%=ORBEX` version line, `+FILE/DESCRIPTION` ... `-FILE/DESCRIPTION`
keyword block, `+SATELLITE/ID_AND_DESCRIPTION` block, `+EPHEMERIS/DATA` with one `## yyyy mm dd hh mm ss.s n`
epoch line followed by n records ` ATT <id> 4 q0 q1 q2 q3`, then `-EPHEMERIS/DATA` and `%END_ORBEX`.
ATT quaternions rotate terrestrial-frame (T) coordinates to body-frame (B) ones by the Hamilton product
(0, B) = q (0, T) q^-1. gnssatt's quaternions (CONVENTIONS.md) are passive: v_body = R(q) v_T with
R(q) = (w^2 - |u|^2) I + 2 u u^T - 2 w [u x], so the ORBEX quaternion of the same rotation is the conjugate
(w, -x, -y, -z). Both readers and writers here take and give gnssatt's `q_body_from_ecef`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.time import GpsTime

__all__ = ["OrbexAttitude", "orbex_text", "write_orbex", "read_orbex", "parse_orbex"]

ORBEX_VERSION = "0.09"
_EPOCH_LAYOUT = "'## yyyy mm dd hh mm ss.sssssssss n' (epoch line: date, time, number of records)"
_ATT_LAYOUT = "' ATT <satellite id> 4 q0 q1 q2 q3' (attitude record, scalar-first quaternion)"


@dataclass
class OrbexAttitude:
    """Attitude records of one ORBEX file: time (n,) GpsTime, sat (n,) ids, q_body_from_ecef (n, 4) in the
    gnssatt convention (passive, scalar first, w >= 0), and the header keywords (name -> text)."""

    time: GpsTime
    sat: np.ndarray
    q_body_from_ecef: np.ndarray
    header: dict[str, str] = field(default_factory=dict)


def _cal(t: GpsTime) -> str:
    y, mo, d, h, mi, s = (np.asarray(a) for a in t.calendar())
    return f"{int(y):4d} {int(mo):02d} {int(d):02d} {int(h):02d} {int(mi):02d} {float(s):015.12f}"


def orbex_text(att: OrbexAttitude, *, description: str = "Satellite attitude", created_by: str = "gnssatt",
               comments: tuple[str, ...] = ()) -> str:
    """The ORBEX text of `att` (records grouped by epoch in time order), frame ECEF, time system GPS."""
    q = np.asarray(att.q_body_from_ecef, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    q = np.where(q[:, :1] < 0, -q, q)
    q_orbex = q * np.array([1.0, -1.0, -1.0, -1.0])     # Hamilton active = conjugate of the passive one
    t_sec = att.time.s.astype(np.float64) + att.time.frac
    order = np.lexsort((np.asarray(att.sat).astype(str), t_sec))
    sats = sorted(set(np.asarray(att.sat).astype(str).tolist()))
    steps = np.diff(np.unique(t_sec))
    interval = float(np.median(steps)) if steps.size else 0.0
    hdr = {"DESCRIPTION": description, "CREATED_BY": created_by, "TIME_SYSTEM": "GPS",
           "START_TIME": _cal(att.time[order[0]]) if len(order) else "",
           "END_TIME": _cal(att.time[order[-1]]) if len(order) else "",
           "EPOCH_INTERVAL": f"{interval:.3f}", "COORD_SYSTEM": att.header.get("COORD_SYSTEM", "IGS14"),
           "FRAME_TYPE": "ECEF", "LIST_OF_REC_TYPES": "ATT"}
    lines = [f"%=ORBEX  {ORBEX_VERSION}", "%%", "+FILE/DESCRIPTION"]
    lines += [f" {k:<19} {v}" for k, v in hdr.items()]
    lines.append("-FILE/DESCRIPTION")
    lines += [f"* {c}" for c in comments]
    lines.append("+SATELLITE/ID_AND_DESCRIPTION")
    lines += [f" {s}" for s in sats]
    lines += ["-SATELLITE/ID_AND_DESCRIPTION", "+EPHEMERIS/DATA",
              "*ATT RECORDS: TRANSFORMATION FROM TERRESTRIAL FRAME COORDINATES (T) TO SAT. BODY FRAME ONES (B) SUCH AS",
              "*                                 (0,B) = q.(0,T).trans(q)",
              "*REC ID_              N ___q0_(scalar)_____ ____q1__x__________ ____q2__y__________ ____q3__z__________"]
    i = 0
    while i < len(order):
        j = i
        while j < len(order) and t_sec[order[j]] == t_sec[order[i]]:
            j += 1
        lines.append(f"## {_cal(att.time[order[i]])} {j - i:3d}")
        for k in order[i:j]:
            qq = " ".join(f"{v:19.16f}" for v in q_orbex[k])
            lines.append(f" ATT {str(att.sat[k]):<17}4 {qq}")
        i = j
    lines += ["-EPHEMERIS/DATA", "%END_ORBEX"]
    return "\n".join(lines) + "\n"


def write_orbex(path, att: OrbexAttitude, **kwargs) -> str:
    """Write `att` as an ORBEX file at `path`; returns the text written (see `orbex_text`)."""
    text = orbex_text(att, **kwargs)
    Path(path).write_text(text, encoding="ascii")
    return text


def _epoch(line: str, name: str, ln: int) -> tuple[GpsTime, int]:
    parts = line[2:].split()
    try:
        y, mo, d, h, mi = (int(p) for p in parts[:5])
        sec = float(parts[5])
        n = int(parts[6])
    except (ValueError, IndexError):
        raise ParseError(name, ln, _EPOCH_LAYOUT, line, column=1) from None
    return GpsTime.from_calendar(y, mo, d, h, mi, sec), n


def _att(line: str, name: str, ln: int) -> tuple[str, np.ndarray]:
    parts = line.split()
    if len(parts) < 3 or parts[0] != "ATT":
        raise ParseError(name, ln, _ATT_LAYOUT, line, column=2)
    try:
        n = int(parts[2])
        vals = np.array([float(v) for v in parts[3:3 + n]])
    except ValueError:
        raise ParseError(name, ln, _ATT_LAYOUT, line, column=24) from None
    if n != 4 or vals.size != 4:
        raise ParseError(name, ln, "4 quaternion values after N = 4", line, column=22)
    norm = np.linalg.norm(vals)
    if not 0.99 < norm < 1.01:
        raise ParseError(name, ln, "a unit quaternion (norm 1 within 1 %)", f"norm {norm:.4f}: {line}", column=24)
    return parts[1], vals / norm


def parse_orbex(text: str, name: str = "orbex") -> OrbexAttitude:
    """OrbexAttitude of an ORBEX text (ATT records only; other record types are skipped).

    Raises ParseError (file, line, column, expected layout) on a malformed epoch or ATT line, a record count
    that does not match its epoch line, or a file without the `%=ORBEX` first line.
    """
    lines = text.splitlines()
    if not lines or not lines[0].startswith("%=ORBEX"):
        raise ParseError(name, 1, "'%=ORBEX <version>' as the first line", lines[0] if lines else "")
    header: dict[str, str] = {"VERSION": lines[0][7:].strip()}
    times, sats, quats = [], [], []
    block = None
    pending = 0
    epoch_t: GpsTime | None = None
    epoch_ln = 0
    for ln, line in enumerate(lines, start=1):
        if line.startswith("+"):
            block = line[1:].strip()
            continue
        if line.startswith("-"):
            if block == "EPHEMERIS/DATA" and pending:
                raise ParseError(name, epoch_ln, f"{pending} more record(s) for this epoch", line)
            block = None
            continue
        if line.startswith("*") or line.startswith("%") or not line.strip():
            continue
        if block == "FILE/DESCRIPTION":
            key, _, value = line.strip().partition(" ")
            header[key] = value.strip()
        elif block == "EPHEMERIS/DATA":
            if line.startswith("##"):
                if pending:
                    raise ParseError(name, epoch_ln, f"{pending} more record(s) for this epoch", line)
                epoch_t, pending = _epoch(line, name, ln)
                epoch_ln = ln
            elif line[1:4] == "ATT":
                if epoch_t is None or pending <= 0:
                    raise ParseError(name, ln, "an epoch line '## ...' announcing this record", line)
                sat, q = _att(line, name, ln)
                times.append(epoch_t)
                sats.append(sat)
                quats.append(q)
                pending -= 1
            else:
                pending -= 1  # another record type counts towards the epoch's n; skipped
    if pending > 0:
        raise ParseError(name, epoch_ln, f"{pending} more record(s) for this epoch", "end of file")
    q = np.array(quats).reshape(-1, 4) * np.array([1.0, -1.0, -1.0, -1.0])
    q = np.where(q[:, :1] < 0, -q, q)
    t = GpsTime.concatenate(times) if times else GpsTime(np.zeros(0, dtype=np.int64))
    return OrbexAttitude(t, np.array(sats, dtype=str), q, header)


def read_orbex(path, name: str | None = None) -> OrbexAttitude:
    """OrbexAttitude of the ORBEX file at `path` (see `parse_orbex`)."""
    p = Path(path)
    return parse_orbex(p.read_text(encoding="ascii", errors="replace"), name or p.name)
