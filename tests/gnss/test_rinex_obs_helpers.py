"""Helpers (no tests) of the RINEX observation tests: cut real files to their first epochs, compare with georinex,
small writer inputs. Named test_* only to stay within the files this reader owns."""
from __future__ import annotations

import re
import warnings
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


def ns_since_gps_epoch(obs) -> np.ndarray:
    """Epoch times of a RinexObs as int64 ns since 1980-01-06 (exact for 1e-7 s time tags)."""
    return obs.time.s * 1_000_000_000 + np.rint(obs.time.frac * 1e9).astype(np.int64)


def load_georinex(path: Path):
    import georinex as gr

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gr.load(path, useindicators=True)


#: georinex's time tags can lag the text by up to 1 ms (truncation, see compare_with_georinex).
GEORINEX_TIME_TRUNCATION_NS = 1_000_000


def compare_with_georinex(obs, ds) -> int:
    """Assert that every value, LLI and SSI georinex holds equals ours; return the number of values compared."""
    gps0 = np.datetime64("1980-01-06T00:00:00", "ns")
    t_gr = (ds.time.values.astype("datetime64[ns]") - gps0).astype(np.int64)
    t_us = ns_since_gps_epoch(obs)
    # georinex truncates time tags (obs2/obs3 `_timeobs`: int(float(sec) % 1 * 1e6) us, and its fast RINEX 2
    # path keeps whole ms), so a 30.0020000 s epoch can come back as 30.001 s: match within 1 ms, and check
    # our exact times elsewhere (against the text itself).
    e_idx = np.searchsorted(t_us, t_gr)
    e_idx = np.clip(e_idx, 0, len(t_us) - 1)
    prev = np.clip(e_idx - 1, 0, len(t_us) - 1)
    e_idx = np.where(np.abs(t_us[prev] - t_gr) < np.abs(t_us[e_idx] - t_gr), prev, e_idx)
    lag_ns = np.abs(t_us[e_idx] - t_gr)
    assert lag_ns.max(initial=0) <= GEORINEX_TIME_TRUNCATION_NS, f"epochs differ by up to {lag_ns.max()} ns"
    assert len(np.unique(e_idx)) == len(e_idx) == len(t_us), "epoch sets differ"
    sv = [str(s) for s in ds.sv.values]
    j_idx = np.array([obs.sats.index(s) if s in obs.sats else -1 for s in sv])
    n = 0
    for var in ds.data_vars:
        if var.endswith("lli") or var.endswith("ssi"):
            continue
        gr_vals = ds[var].values
        k = obs.codes.index(var)
        present = j_idx >= 0
        ours = obs.values[e_idx][:, j_idx[present], k]
        theirs = gr_vals[:, present]
        both = ~np.isnan(theirs)
        # georinex drops nothing we keep and keeps nothing we drop (blank <-> NaN)
        np.testing.assert_array_equal(np.isnan(ours), np.isnan(theirs), err_msg=f"blank pattern of {var}")
        np.testing.assert_array_equal(ours[both], theirs[both], err_msg=f"values of {var}")
        # satellites georinex lists but we do not must be empty there
        assert np.all(np.isnan(gr_vals[:, ~present])), f"{var}: georinex has data for satellites we lack"
        n += int(both.sum())
        for suffix, arr in (("lli", obs.lli), ("ssi", obs.ssi)):
            if var + suffix in ds:
                ind = ds[var + suffix].values[:, present]
                mine = arr[e_idx][:, j_idx[present], k].astype(np.float64)
                mine[mine < 0] = np.nan
                np.testing.assert_array_equal(mine, ind, err_msg=f"{var}{suffix}")
    # and we hold nothing georinex lacks
    assert int(np.count_nonzero(~np.isnan(obs.values))) == n, "we hold values georinex does not"
    return n


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
