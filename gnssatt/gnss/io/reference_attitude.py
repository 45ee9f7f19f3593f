"""Reference attitude CSV (star tracker or other): `time_gps,frame,qw,qx,qy,qz[,sigma_arcsec]`.

Implements: ../shared/CONVENTIONS.md "Reference attitude" (frame GCRF or ECEF, scalar-first unit
quaternions frame->body, GPS time in ISO 8601 without zone).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.time import GpsTime

REQUIRED = ("time_gps", "frame", "qw", "qx", "qy", "qz")
NORM_TOLERANCE = 1e-6  # a quaternion printed to 9+ digits is unit to this level


@dataclass
class ReferenceAttitude:
    time: GpsTime  # (n,)
    frame: np.ndarray  # (n,) 'GCRF' or 'ECEF'
    q_body_from_frame: np.ndarray  # (n, 4) scalar first, w >= 0
    sigma_arcsec: np.ndarray  # (n,) NaN where absent


def read_reference_attitude(text: str | bytes, name: str = "reference_attitude.csv") -> ReferenceAttitude:
    """Parse and check a reference attitude CSV; ParseError with the line on any malformed row."""
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise ParseError(name, None, "UTF-8 text", "binary data") from exc
    lines = text.splitlines()
    if not lines:
        raise ParseError(name, 1, "a header line " + ",".join(REQUIRED), "empty file")
    header = [h.strip() for h in lines[0].split(",")]
    missing = [c for c in REQUIRED if c not in header]
    if missing:
        raise ParseError(name, 1, "a header line with columns " + ",".join(REQUIRED) + "[,sigma_arcsec]",
                         lines[0])
    col = {h: i for i, h in enumerate(header)}
    y, mo, d, hh, mi, ss, frames, quats, sigmas = [], [], [], [], [], [], [], [], []
    prev = None
    for line_no, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        cells = [c.strip() for c in line.split(",")]
        if len(cells) < len(header):
            raise ParseError(name, line_no, f"{len(header)} comma-separated values", line)
        try:
            date, _, clock = cells[col["time_gps"]].partition("T")
            yy, mm, dd = (int(v) for v in date.split("-"))
            h, m, s = clock.split(":")
            q = [float(cells[col[k]]) for k in ("qw", "qx", "qy", "qz")]
            sig = float(cells[col["sigma_arcsec"]]) if "sigma_arcsec" in col and cells[col["sigma_arcsec"]] else np.nan
            t_key = (yy, mm, dd, int(h), int(m), float(s))
            if not (1 <= mm <= 12 and 1 <= dd <= 31 and 0 <= int(h) < 24 and 0 <= int(m) < 60 and 0 <= float(s) < 61):
                raise ValueError("time out of range")
        except (ValueError, IndexError) as exc:
            raise ParseError(name, line_no, "time_gps as YYYY-MM-DDTHH:MM:SS.sss and numeric qw,qx,qy,qz",
                             line) from exc
        frame = cells[col["frame"]].upper()
        if frame not in ("GCRF", "ECEF"):
            raise ParseError(name, line_no, "frame GCRF or ECEF", cells[col["frame"]])
        qn = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])   # plain floats: ~10 us/row less
        if not all(map(math.isfinite, q)) or abs(qn - 1.0) > NORM_TOLERANCE:
            raise ParseError(name, line_no, f"a unit quaternion (|q| = 1 within {NORM_TOLERANCE:g})",
                             f"|q| = {qn:.9f}")
        if prev is not None and t_key <= prev:
            raise ParseError(name, line_no, "rows in increasing time order", cells[col["time_gps"]])
        prev = t_key
        for lst, v in zip((y, mo, d, hh, mi, ss), t_key):
            lst.append(v)
        frames.append(frame)
        quats.append(q)
        sigmas.append(sig)
    if not quats:
        raise ParseError(name, 2, "at least one data row", "header only")
    q_arr = np.asarray(quats)
    q_arr = np.where(q_arr[:, :1] < 0, -q_arr, q_arr)
    return ReferenceAttitude(GpsTime.from_calendar(y, mo, d, hh, mi, ss), np.asarray(frames), q_arr,
                             np.asarray(sigmas))


def summarize_reference_attitude(text: str | bytes, name: str = "reference_attitude.csv") -> dict:
    ref = read_reference_attitude(text, name)
    return {"format": "reference attitude CSV", "rows": len(ref.frame), "frames": sorted(set(ref.frame.tolist())),
            "time_first": ref.time[0].iso(), "time_last": ref.time[-1].iso()}
