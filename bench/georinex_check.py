"""The RINEX observation reader against georinex, value for value (an independent reader: the cross-check of
tests/gnss/test_rinex_obs_georinex.py and bench/bench_rinex_obs.py). georinex is a test/bench dependency only; the
product never imports this module."""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

__all__ = ["compare_with_georinex", "load_georinex", "ns_since_gps_epoch", "GEORINEX_TIME_TRUNCATION_NS"]


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
