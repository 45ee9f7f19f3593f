"""Helpers (no tests) of the RINEX observation tests: cut real files to their first epochs, small writer inputs
(the georinex cross-check is bench/georinex_check.py, shared with bench/bench_rinex_obs.py). Named test_* only to stay within the files this reader owns."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from gnssatt.gnss.io.compression import read_text_bytes

# An epoch line: RINEX 3/4 '> yyyy ...', RINEX 2 ' yy mm dd hh mm ss.sssssss  f'.
_EPOCH_RE = re.compile(rb"^(> \d{4} |  ?\d{1,2} [ \d]\d [ \d]\d [ \d]\d [ \d]\d [ \d]\d\.\d{7}  [0-6])", re.M)


def cut_rinex(path: Path, max_bytes: int) -> bytes:
    """The header and the first whole epochs of a real RINEX observation file, at most ~max_bytes long."""
    data = read_text_bytes(path).replace(b"\r\n", b"\n")
    if len(data) <= max_bytes:
        return data
    head_end = data.index(b"\n", data.index(b"END OF HEADER")) + 1
    for m in _EPOCH_RE.finditer(data, head_end):
        if m.start() >= max_bytes:
            return data[:m.start()]
    return data


def small_obs(n_epochs: int = 5, sats=("E11", "G01", "G05", "R07"), codes=("C1C", "L1C", "D1C", "S1C"),
              seed: int = 1, interval_s: float = 1.0, start=(2024, 6, 24, 8, 20, 0.0)):
    """A RinexObs-like namespace with plausible values, LLI/SSI digits, a blank and a 0.000 (writer input)."""
    from types import SimpleNamespace

    from gnssatt.gnss.time import GpsTime

    rng = np.random.default_rng(seed)
    t0 = GpsTime.from_calendar(*start)
    time = t0 + np.arange(n_epochs) * interval_s
    shape = (n_epochs, len(sats), len(codes))
    base = {"C": 2.2e7, "L": 1.15e8, "D": -1500.0, "S": 45.0}
    values = np.empty(shape)
    for k, c in enumerate(codes):
        values[:, :, k] = np.round(base.get(c[0], 1.0) + rng.normal(0, 1000.0 if c[0] in "CL" else 3.0, shape[:2]), 3)
    lli = np.full(shape, -1, dtype=np.int8)
    ssi = rng.integers(4, 9, shape).astype(np.int8)
    for k, c in enumerate(codes):
        if c[0] == "L":
            lli[:, :, k] = np.where(rng.random(shape[:2]) < 0.3, 1, -1)
    if n_epochs > 2 and len(sats) > 1 and len(codes) > 2:
        values[1, 0, 0] = np.nan  # a blank field (signal not tracked)
        ssi[1, 0, 0] = -1
        values[2, 1, 2] = 0.0  # a real 0.000
    header = SimpleNamespace(obs_types={s: list(codes) for s in sorted({x[0] for x in sats})},
                             marker_name="ANT1", receiver_type="TEST RX", antenna_type="TEST ANT",
                             approx_position_ecef_m=np.array([-3976219.5082, 3382372.5671, 3652512.9849]),
                             antenna_delta_hen_m=np.zeros(3), interval_s=interval_s, glonass_slots={"R07": 5})
    return SimpleNamespace(time=time, sats=list(sats), codes=list(codes), values=values, lli=lli, ssi=ssi,
                           epoch_flag=np.zeros(n_epochs, np.int8), clock_offset_s=np.full(n_epochs, np.nan),
                           header=header)


def replace_header_line(text: str, label: str, new: str | None) -> str:
    """Replace (or delete, new=None) the header line carrying `label` in columns 61-80."""
    out = []
    for line in text.split("\n"):
        if line[60:].strip() == label:
            if new is None:
                continue
            line = f"{new:<60}{label}"
        out.append(line)
    return "\n".join(out)
