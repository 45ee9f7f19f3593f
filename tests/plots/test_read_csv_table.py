"""read_csv_table reads CSV text column-wise; it must give what csv.DictReader row by row gives (the plots of the
products depend on it): quoted cells with commas, blank lines, short and long rows, blanks around cells."""
import csv
import io

import numpy as np
import pytest

from gnssatt.plots.common import read_csv_table


def _reference(text: str) -> dict:
    reader = csv.DictReader(io.StringIO(text))
    rows = list(reader)
    out = {}
    for name in reader.fieldnames or []:
        cells = [(r.get(name) or "").strip() for r in rows]
        try:
            out[name.strip()] = np.array([float(c) if c != "" else np.nan for c in cells], dtype=np.float64)
        except ValueError:
            out[name.strip()] = np.array(cells, dtype=str)
    return out


TEXTS = {
    "plain": "t,a,b,name\n2018-06-06T12:20:07.000,1.5,,G01\n2018-06-06T12:20:08.000,-0.00000,2e3,G02\n",
    "quoted": 'time_gps,event,detail\n2018-01-01T00:00:00.000,fix,"3 DD, ratio 4.1"\n'
              '2018-01-01T00:00:01.000,slip,"x"\n',
    "blank_lines_and_spaces": "a, b ,c\n\n 1 , x ,3\n2,y,\n\n",
    "short_and_long_rows": "a,b,c\n1,2\n3,4,5,6\n7,8,9\n",
    "numeric_then_text": "a,b\n1,2\n3,abc\n",
    "header_only": "a,b\n",
    "only_blank_lines": "\n\n",
}


@pytest.mark.parametrize("name", sorted(TEXTS))
def test_same_table_as_dictreader(name):
    got, ref = read_csv_table(TEXTS[name]), _reference(TEXTS[name])
    assert list(got) == list(ref)
    for k in ref:
        assert got[k].dtype.kind == ref[k].dtype.kind, k
        if ref[k].dtype.kind == "f":
            assert np.array_equal(got[k], ref[k], equal_nan=True), k
        else:
            assert got[k].tolist() == ref[k].tolist(), k


@pytest.mark.parametrize("values", [["b", "a", "b", "c", "a"], ["GPS-2>GPS-0", "GPS-2>GPS-1", "G", "GPS-2>GPS-0"],
                                    ["é", "e", "", "é", ""], [], ["x"]])
def test_categories_are_first_appearance_order_and_codes(values):
    from gnssatt.plots.common import categories

    names, codes = categories(np.array(values, dtype=str))
    assert names == list(dict.fromkeys(values))
    assert [names[c] for c in codes] == values


def test_first_per_epoch_and_key_keeps_the_first_row_of_each_pair():
    from gnssatt.plots.common import first_per_epoch_and_key

    t = np.array(["2018-01-01T00:00:00", "2018-01-01T00:00:00", "2018-01-01T00:00:00", "2018-01-01T00:00:01",
                  "2018-01-01T00:00:01", "2018-01-01T00:00:00"], dtype="datetime64[ms]")
    codes = np.array([0, 1, 0, 1, 1, 2])
    assert first_per_epoch_and_key(t, codes, np.arange(6)).tolist() == [0, 1, 3, 5]
    assert first_per_epoch_and_key(t, codes, np.array([2, 3, 4])).tolist() == [2, 3]


def test_category_memo_reuses_the_codes_of_the_same_array_only_inside_the_block():
    from gnssatt.plots.common import categories, category_memo

    a, b = np.array(["x", "y", "x"]), np.array(["x", "y", "x"])
    with category_memo():
        first = categories(a)
        assert categories(a) is first                      # same array object: computed once
        assert categories(b) is not first and categories(b)[0] == first[0]
    assert categories(a) is not first and categories(a)[1].tolist() == [0, 1, 0]
