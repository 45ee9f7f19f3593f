"""gnssatt.csv_text gives Python's own text: '%.Nf' % x and '%d' % i, joined by commas, byte for byte, on random
arrays and on the edge values (NaN, +-inf, negative zero, values that round to -0, exact binary ties, the next
doubles either side of a decimal tie, large and tiny magnitudes, the int64 limits)."""
from __future__ import annotations

import numpy as np
import pytest

from gnssatt.csv_text import csv_text, csv_text_blocks, fixed_cells, int_cells, label_cells

EDGE = [np.nan, -np.nan, np.inf, -np.inf, 0.0, -0.0, -1e-300, 5e-324, -5e-324, 0.5, 1.5, 2.5, -0.5, -2.5, 0.125,
        0.375, -0.625, 0.05, 0.15, 0.25, 0.35, 1.005, 2.675, 999.9995, 1e15, -1e15, 2.0 ** 52, 2.0 ** 53 + 2.0,
        1e22, 1e300, -1e300, 4503.599627370495, 0.999999999999, 0.9999999999995, 9.5, 99.5, 1e-5, -1e-13]


def _texts(cells) -> list[str]:
    """The text of each row of one column, through csv_text (one column: row text = cell text)."""
    return csv_text("h", [cells]).split("\n")[1:-1]


def _python(values, decimals: int) -> list[str]:
    fmt = f"%.{decimals}f"
    return [fmt % v for v in np.asarray(values, float).tolist()]


def _random_values(rng, n: int, decimals: int) -> np.ndarray:
    """Normal values over 16 decades, dyadic values (exact ties at most decimals), decimal ties and their
    neighbouring doubles either side, and the residual/angle/C/N0 magnitudes of the products."""
    scale = 10.0 ** decimals
    ties = (rng.integers(-10 ** 6, 10 ** 6, n) + 0.5) / scale
    return np.concatenate([
        rng.normal(0.0, 1.0, n) * 10.0 ** rng.uniform(-8.0, 8.0, n),
        np.round(rng.normal(0.0, 100.0, n) * 2.0 ** 10) / 2.0 ** rng.integers(1, 12, n),
        ties, np.nextafter(ties, np.inf), np.nextafter(ties, -np.inf),
        rng.normal(0.0, 0.01, n), rng.uniform(-180.0, 360.0, n), np.round(rng.uniform(20, 55, n) * 4) / 4])


@pytest.mark.parametrize("decimals", [0, 1, 2, 3, 5, 6, 12])
def test_fixed_cells_equal_python_on_random_values(decimals):
    rng = np.random.default_rng(decimals)
    values = _random_values(rng, 4000, decimals)
    got, want = _texts(fixed_cells(values, decimals)), _python(values, decimals)
    bad = [(v, w, g) for v, w, g in zip(values.tolist(), want, got) if w != g]
    assert not bad, f"{len(bad)} texts differ, e.g. {bad[:3]}"


@pytest.mark.parametrize("decimals", [0, 1, 2, 3, 5, 6, 12, 18])
def test_fixed_cells_equal_python_on_edge_values(decimals):
    assert _texts(fixed_cells(np.array(EDGE), decimals)) == _python(EDGE, decimals)


def test_negative_zero_and_values_rounding_to_zero_keep_their_sign():
    assert _texts(fixed_cells(np.array([-0.0, -0.004, 0.004, -0.005]), 2)) == ["-0.00", "-0.00", "0.00", "-0.01"]


def test_blank_nonfinite_leaves_empty_cells_and_formats_the_rest():
    v = np.array([np.nan, 1.25, np.inf, -np.inf, -0.0])
    assert _texts(fixed_cells(v, 1, blank_nonfinite=True)) == ["", "1.2", "", "", "-0.0"]
    assert _texts(fixed_cells(v, 1)) == ["nan", "1.2", "inf", "-inf", "-0.0"]


def test_int_cells_equal_python():
    ints = np.array([0, -1, 7, 2 ** 63 - 1, -2 ** 63, 10 ** 18, -(10 ** 17)], np.int64)
    assert _texts(int_cells(ints)) == ["%d" % i for i in ints.tolist()]
    assert _texts(int_cells(np.array([True, False]))) == ["1", "0"]
    floats = np.array([2000.0, 2000.7, -0.5, -3.9, 1e30, -0.0])
    assert _texts(int_cells(floats)) == ["%d" % f for f in floats.tolist()]
    with pytest.raises(ValueError):
        int_cells(np.array([np.nan]))                  # as '%d' % nan in Python


def test_rows_join_labels_numbers_and_ints_like_str_join():
    rng = np.random.default_rng(7)
    n = 500
    names = ["A>B", "A>C", "Ä>B"]                        # a non-ASCII name survives as UTF-8
    idx, x, k = rng.integers(0, 3, n), rng.normal(0, 1, n), rng.integers(-50, 50, n)
    x[::7] = np.nan
    text = csv_text("name,x,k", [label_cells(names, idx), fixed_cells(x, 5, True), int_cells(k)])
    rows = [",".join((names[i], "" if np.isnan(v) else "%.5f" % v, "%d" % j))
            for i, v, j in zip(idx.tolist(), x.tolist(), k.tolist())]
    assert text == "name,x,k\n" + "\n".join(rows) + "\n"


def test_blocks_give_the_text_of_all_rows_at_once_without_new_kernel_signatures():
    """csv_text_blocks (residuals.csv, ~1e6 rows) = csv_text of the whole columns, whatever the block size (a
    last block shorter than the others, a block of one row), and the sliced tables are the layouts csv_text
    already compiled for (no compilation inside a job)."""
    from gnssatt import csv_text as module

    module.warm_up()
    rng = np.random.default_rng(11)
    n = 1001
    names, idx = ["A>B", "A>C", "Ä>B"], rng.integers(0, 3, n)
    x, k = rng.normal(0, 100, n), rng.integers(-50, 50, n)
    x[::9] = np.nan
    labels = label_cells(names, idx)
    whole = csv_text("name,x,k", [labels, fixed_cells(x, 3, True), int_cells(k)])
    signatures = len(module._row_put.signatures)
    for block in (1, 7, 128, 1000, 1001, 5000):
        def columns_of(lo, hi):
            return [labels.rows(lo, hi), fixed_cells(x[lo:hi], 3, True), int_cells(k[lo:hi]).rows(0, hi - lo)]

        assert csv_text_blocks("name,x,k", n, columns_of, block_rows=block) == whole, block
    assert len(module._row_put.signatures) == signatures
    assert csv_text_blocks("a,b", 0, lambda lo, hi: []) == "a,b\n"


def test_empty_table_is_the_header_line_and_mismatched_columns_are_refused():
    assert csv_text("a,b", [fixed_cells(np.array([]), 2), int_cells(np.array([], int))]) == "a,b\n"
    with pytest.raises(ValueError):
        csv_text("a,b", [fixed_cells(np.zeros(2), 2), int_cells(np.zeros(3, int))])
    with pytest.raises(IndexError):
        label_cells(["x"], [0, 1])


def test_warm_up_loads_the_kernels_the_products_call():
    from gnssatt import csv_text

    csv_text.warm_up()
    assert all(k.signatures for k in (csv_text._fixed_kernel, csv_text._int_kernel, csv_text._row_put))
