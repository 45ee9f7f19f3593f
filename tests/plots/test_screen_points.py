"""Plots drawn from screen-decimated series (gnssatt.plots.common.screen_points): fewer points than the full
series, every one of them a point of it, and a spike of the full series (one sample far outside the noise) still
drawn; the table columns that carry their categories give what sorting the strings gives."""
from __future__ import annotations

import numpy as np
import pytest

from gnssatt.plots import attitude as A
from gnssatt.plots import elevation as E
from gnssatt.plots.common import (categories, coded_strings, first_per_epoch_and_key, screen_points,
                                  _categories)


def _noise_with_spike(n: int, spike_at: int, spike: float, seed: int = 0):
    rng = np.random.default_rng(seed)
    y = rng.normal(0.0, 1.0, n)
    y[spike_at] = spike
    return np.arange(n, dtype=float), y


@pytest.mark.parametrize("spike", [40.0, -40.0])
@pytest.mark.parametrize("height_px", [None, 220])
def test_a_single_sample_spike_survives_the_decimation(spike, height_px):
    x, y = _noise_with_spike(200_000, 123_457, spike)
    k = screen_points(x, y, 400, height_px)
    assert 123_457 in k
    assert k.size < 200_000 / 10                       # a real reduction: <= 4 per column + occupied cells
    assert np.all(np.diff(k) > 0)                      # sorted, so lines keep their time order
    if height_px is None:
        assert k.size <= 4 * 400


def test_the_envelope_per_pixel_column_is_kept():
    x, y = _noise_with_spike(100_000, 10, 0.0, seed=3)
    k = screen_points(x, y, 250)
    col = np.minimum((x * 250 / x.max()).astype(int), 249)
    for c in (0, 17, 249):
        in_c = col == c
        assert y[k][col[k] == c].max() == y[in_c].max() and y[k][col[k] == c].min() == y[in_c].min()


def test_non_finite_points_are_dropped_and_short_series_kept_whole():
    y = np.array([1.0, np.nan, 3.0, np.inf, 5.0])
    assert screen_points(np.arange(5.0), y, 100).tolist() == [0, 2, 4]


def _residual_table(n_epochs: int, spike_epoch: int, spike_m: float) -> dict:
    rng = np.random.default_rng(1)
    t = np.datetime64("2018-06-06T12:00:00.000") + np.arange(n_epochs).astype("timedelta64[s]")
    r = rng.normal(0.0, 0.003, n_epochs)
    r[spike_epoch] = spike_m
    return {"time_gps": t, "gps_sow": np.arange(n_epochs, dtype=float), "baseline": np.array(["A>B"] * n_epochs),
            "sat": np.array(["G01"] * n_epochs), "signal": np.array(["L1C"] * n_epochs),
            "observable": np.array(["phase"] * n_epochs), "residual_m": r,
            "az_ant_deg": np.linspace(0.0, 350.0, n_epochs), "el_ant_deg": np.linspace(5.0, 85.0, n_epochs),
            "cn0_dbhz": np.full(n_epochs, 45.0), "used": np.ones(n_epochs), "reason": np.array([""] * n_epochs)}


def test_a_residual_spike_is_drawn_in_the_residual_and_elevation_plots():
    tab = _residual_table(20_000, 7_777, 0.25)                  # one 250 mm outlier in 3 mm noise
    fig = A.residuals_figure(tab)
    ax = [a for a in fig.axes if a.get_title().startswith("A>B · phase")][0]
    line = [ln for ln in ax.get_lines() if ln.get_label().startswith("L1C")][0]
    drawn = np.asarray(line.get_ydata())
    assert len(drawn) < 20_000 and "drawn (screen-decimated" in ax.get_title()
    assert drawn.max() == pytest.approx(250.0, abs=1e-9)
    assert "RMS" in line.get_label() and "n=20000" in line.get_label()       # statistics of every row
    ax_r = E.elevation_figure(tab).axes[0]
    dots = [ln for ln in ax_r.get_lines() if ln.get_marker() == "."][0]
    assert len(dots.get_ydata()) < 20_000 and np.max(dots.get_ydata()) == pytest.approx(250.0, abs=1e-9)


def test_first_per_epoch_and_key_in_time_order_equals_the_definition():
    rng = np.random.default_rng(5)
    t = np.sort(rng.integers(0, 300, 5000)).astype("datetime64[s]").astype("datetime64[ms]")
    codes = rng.integers(0, 7, 5000)
    rows = np.flatnonzero(rng.random(5000) < 0.7)
    seen, want = set(), []
    for i in rows.tolist():
        if (t[i], codes[i]) not in seen:
            seen.add((t[i], codes[i]))
            want.append(i)
    assert first_per_epoch_and_key(t, codes, rows).tolist() == want
    shuffled = rng.permutation(rows)                           # not in time order: the sorting path
    seen, want = set(), []
    for i in shuffled.tolist():
        if (t[i], codes[i]) not in seen:
            seen.add((t[i], codes[i]))
            want.append(i)
    assert sorted(first_per_epoch_and_key(t, codes, shuffled).tolist()) == sorted(want)


def test_coded_strings_carry_what_categories_computes():
    labels, codes = ["G05", "G02", "G17", "G09"], np.array([2, 2, 0, 3, 0, 2, 3])
    col = coded_strings(labels, codes)
    assert col.tolist() == [labels[c] for c in codes]
    levels, code = categories(col)
    want = _categories(np.asarray(col, dtype=str))
    assert levels == want[0] == ["G17", "G05", "G09"] and code.tolist() == want[1].tolist()
    assert not hasattr(coded_strings(["a", "a"], [0, 1]), "coded")    # repeated labels: computed as usual
    assert categories(col[1:])[0] == ["G17", "G05", "G09"]           # a view sorts again, same answer


def test_a_table_handed_to_the_plots_keeps_its_coded_columns(monkeypatch):
    """attitude_plots reads the job's column tables through read_csv_table: a CodedStrings column must come out
    as itself (its categories carried), not as a plain copy the plots would sort again (~6e5 residual rows)."""
    from gnssatt.plots import common

    col = coded_strings(["G05", "G02"], np.array([1, 0, 1]))
    table = common.read_csv_table({"sat": col, "x": [1.0, 2.0, 3.0]})
    assert table["sat"] is col and table["x"].tolist() == [1.0, 2.0, 3.0]

    def no_sorting(values):
        raise AssertionError("categories sorted a coded column")

    monkeypatch.setattr(common, "_categories", no_sorting)
    levels, codes = common.categories(table["sat"])
    assert levels == ["G02", "G05"] and codes.tolist() == [0, 1, 0]


def test_warm_up_loads_the_kernels_the_plots_call():
    from gnssatt.plots import common

    common.warm_up()
    assert common._screen_kernel.signatures and common._first_per_time_and_code.signatures
