"""CSV texts without per-row Python: columns formatted by compiled (numba) kernels into byte tables, rows assembled
into one byte buffer; the same text as Python's ``"%.Nf" % x`` / ``"%d" % i`` joined with commas.

A column is a `Cells`: a byte table (k, width) with the length of each entry and, per CSV row, the table row it
shows (`index`; None: row i shows entry i). `fixed_cells` formats floats, `int_cells` integers, `label_cells`
indexes a few texts (names, epoch times); `csv_text(header, columns)` joins them; `csv_text_blocks` builds a long
table a block of rows at a time (the byte tables of one block stay small and are reused, instead of ~40 bytes per
cell of fresh memory for every row at once).

Fixed-point digits, exactly as Python's correctly rounded ``%.Nf`` (round half to even on the exact binary
value, sign kept on a negative value that rounds to zero: ``-0.00``): y = |x| 10^N is split into
hi + lo exactly (Dekker's two-product, 10^N exact for N <= 22), k = floor(hi), and the exact fraction
(hi - k) + lo decides the rounding of k (Shewchuk 1997, "Adaptive precision floating-point arithmetic", sec. 2.4:
two-product without FMA). Values with y >= 2^52 and non-finite values are formatted by Python (few or none in the
products). tests/test_csv_text.py compares with Python's formatting on random and edge values.
"""
from __future__ import annotations

from dataclasses import dataclass

import math

import numpy as np
from numba import njit

__all__ = ["Cells", "fixed_cells", "int_cells", "label_cells", "csv_text", "csv_text_blocks", "warm_up"]

#: 10^N for N = 0..22, every one exactly representable in binary64
_POW10 = np.array([10.0 ** n for n in range(23)])
_POW10_INT = np.array([10 ** n for n in range(19)], dtype=np.int64)
#: y = |x| 10^N below this: floor, rounding and int64 digits stay exact
_Y_MAX = 2.0 ** 52
#: widest text of the kernel: sign, 16 integer digits, point, 22 decimals
_FIXED_WIDTH = 40


@dataclass
class Cells:
    """One CSV column: entry j is table[j, :lens[j]] (UTF-8 bytes); row i of the CSV shows entry index[i]
    (or entry i when index is None)."""
    table: np.ndarray        # uint8 (k, width)
    lens: np.ndarray         # int64 (k,)
    index: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.lens) if self.index is None else len(self.index)

    def rows(self, lo: int, hi: int) -> "Cells":
        """The column's CSV rows lo..hi-1 (views, no copy)."""
        if self.index is None:
            return Cells(self.table[lo:hi], self.lens[lo:hi])
        return Cells(self.table, self.lens, self.index[lo:hi])


@njit(cache=True, nogil=True)
def _two_product_err(a, b, p):
    """lo with a * b = p + lo exactly, p = fl(a * b) (Dekker's split, no FMA)."""
    c = 134217729.0 * a
    ah = c - (c - a)
    al = a - ah
    c = 134217729.0 * b
    bh = c - (c - b)
    bl = b - bh
    return ((ah * bh - p) + ah * bl + al * bh) + al * bl


@njit(cache=True, nogil=True)
def _rounded(ax, scale):
    """round-half-even(ax * scale) of the exact product as an int64, ax >= 0, ax * scale < 2^52."""
    hi = ax * scale
    lo = _two_product_err(ax, scale, hi)
    k = np.floor(hi)
    r = hi - k                   # exact: 0 <= hi < 1, or k in [hi / 2, hi] (Sterbenz)
    ki = np.int64(k)
    # |lo| <= ulp(hi) / 2 cannot move r + lo across 0.5 unless r is 0.5 itself
    if r > 0.5 or (r == 0.5 and (lo > 0.0 or (lo == 0.0 and ki % 2 == 1))):
        ki += 1
    return ki


@njit(cache=True, nogil=True)
def _put_digits(out, i, pos, v, n_min):
    """Decimal digits of v >= 0 (at least n_min, zero-padded) into out[i, pos:]; returns the new pos."""
    n = 1
    t = v // 10
    while t > 0:
        n += 1
        t //= 10
    if n < n_min:
        n = n_min
    for j in range(n - 1, -1, -1):
        out[i, pos + j] = 48 + v % 10
        v //= 10
    return pos + n


@njit(cache=True, nogil=True)
def _fixed_kernel(values, decimals, blank_nonfinite, out, lens):
    """'%.{decimals}f' % values[i] into out[i], its length into lens[i]; 0 (an empty cell) for a non-finite value
    when blank_nonfinite; -1 where Python must format it (non-finite, or |x| 10^decimals >= 2^52)."""
    scale = _POW10[decimals]
    div = _POW10_INT[decimals]
    for i in range(values.shape[0]):
        x = values[i]
        ax = abs(x)
        if not math.isfinite(x) and blank_nonfinite:
            lens[i] = 0
            continue
        if not math.isfinite(x) or ax * scale >= _Y_MAX:
            lens[i] = -1
            continue
        k = _rounded(ax, scale)
        pos = 0
        if math.copysign(1.0, x) < 0.0:
            out[i, 0] = 45                                  # '-'
            pos = 1
        pos = _put_digits(out, i, pos, k // div, 1)
        if decimals > 0:
            out[i, pos] = 46                                # '.'
            pos = _put_digits(out, i, pos + 1, k % div, decimals)
        lens[i] = pos


@njit(cache=True, nogil=True)
def _int_kernel(values, out, lens):
    """'%d' % values[i] into out[i] (int64 values)."""
    for i in range(values.shape[0]):
        v = values[i]
        pos = 0
        if v < 0:
            out[i, 0] = 45
            pos = 1
            v = -v
            if v < 0:                                       # -(-2^63) overflows: Python formats it
                lens[i] = -1
                continue
        lens[i] = _put_digits(out, i, pos, v, 1)


@njit(cache=True, nogil=True)
def _row_put(out, pos, table, lens, index, sep):
    """Row i: entry index[i] of the column (index[0] < 0: entry i) and the separator byte at pos[i]; pos advances."""
    direct = index.shape[0] == 0 or index[0] < 0
    for i in range(pos.shape[0]):
        j = i if direct else index[i]
        p = pos[i]
        n = lens[j]
        for c in range(n):
            out[p + c] = table[j, c]
        out[p + n] = sep
        pos[i] = p + n + 1


def _with_python_texts(table: np.ndarray, lens: np.ndarray, texts: dict[int, str]) -> tuple[np.ndarray, np.ndarray]:
    """table/lens with the rows of `texts` (row -> text) written in, the table widened when a text needs it."""
    data = {i: t.encode() for i, t in texts.items()}
    if not data:
        return table, lens
    width = max([table.shape[1], *(len(b) for b in data.values())])
    if width > table.shape[1]:
        wide = np.zeros((table.shape[0], width), np.uint8)
        wide[:, :table.shape[1]] = table
        table = wide
    for i, b in data.items():
        table[i, :len(b)] = np.frombuffer(b, np.uint8)
        lens[i] = len(b)
    return table, lens


def fixed_cells(values, decimals: int, blank_nonfinite: bool = False) -> Cells:
    """'%.{decimals}f' % x of each value (Python's text, bit for bit); blank_nonfinite: an empty cell for NaN and
    +-inf instead of Python's 'nan' / 'inf'."""
    if not 0 <= decimals <= 18:
        raise ValueError(f"decimals must be 0..18, not {decimals}")
    vals = np.ascontiguousarray(values, dtype=np.float64).ravel()
    table = np.zeros((vals.size, _FIXED_WIDTH), np.uint8)
    lens = np.zeros(vals.size, np.int64)
    _fixed_kernel(vals, decimals, blank_nonfinite, table, lens)
    todo = np.flatnonzero(lens < 0)
    if todo.size:
        fmt = f"%.{decimals}f"
        table, lens = _with_python_texts(table, lens, {int(i): fmt % float(vals[i]) for i in todo})
    return Cells(table, lens)


def int_cells(values) -> Cells:
    """'%d' % v of each value: integers (and bools as 0/1); floats as Python's %d does (truncated toward zero;
    NaN raises as it does in Python)."""
    arr = np.asarray(values).ravel()
    if arr.dtype.kind == "f":
        whole = np.isfinite(arr) & (np.abs(arr) < 2.0 ** 62)
        ints = np.zeros(arr.size, np.int64)
        ints[whole] = np.trunc(arr[whole]).astype(np.int64)
    else:
        ints, whole = arr.astype(np.int64), None
    table = np.zeros((arr.size, 21), np.uint8)
    lens = np.zeros(arr.size, np.int64)
    _int_kernel(np.ascontiguousarray(ints), table, lens)
    todo = np.flatnonzero(lens < 0) if whole is None else np.flatnonzero((lens < 0) | ~whole)
    if todo.size:
        table, lens = _with_python_texts(table, lens, {int(i): "%d" % arr[i].item() for i in todo})
    return Cells(table, lens)


def label_cells(labels, index=None) -> Cells:
    """Row i shows labels[index[i]] (index None: labels[i]); labels: a few texts (names, epoch times)."""
    data = [str(t).encode() for t in (labels.tolist() if isinstance(labels, np.ndarray) else labels)]
    lens = np.fromiter(map(len, data), np.int64, len(data))
    width = max(int(lens.max()) if lens.size else 1, 1)
    table = np.array(data, dtype=f"S{width}").view(np.uint8).reshape(len(data), width)
    idx = None if index is None else np.ascontiguousarray(index, dtype=np.int64).ravel()
    if idx is not None and idx.size and (idx.min() < 0 or idx.max() >= len(data)):
        raise IndexError("label index out of range")
    return Cells(table, lens, idx)


def csv_text(header: str, columns: list[Cells]) -> str:
    """header, then one line per row: the columns' cells joined by ',' (every line ends with a newline); the
    text _join of the products gave with Python's str.join."""
    if not columns or len(columns[0]) == 0:
        return header + "\n"
    return str(_rows_bytes((header + "\n").encode(), columns).data, "utf-8")


#: rows per block of csv_text_blocks: ~1.3e5 rows x 40-byte cells = ~5 MB per float column, reused block after block
BLOCK_ROWS = 1 << 17


def csv_text_blocks(header: str, n_rows: int, columns_of, block_rows: int = BLOCK_ROWS) -> str:
    """csv_text(header, columns_of(0, n_rows)) built block_rows rows at a time: columns_of(lo, hi) gives the Cells
    of rows lo..hi-1 (e.g. fixed_cells of values[lo:hi], or a label column's Cells.rows(lo, hi)). Same text: each
    line depends on its own row only."""
    if n_rows == 0:
        return header + "\n"
    parts = [(header + "\n").encode()]
    for lo in range(0, n_rows, block_rows):
        hi = min(lo + block_rows, n_rows)
        parts.append(_rows_bytes(b"", columns_of(lo, hi)).data)
    return str(b"".join(parts), "utf-8")


def _rows_bytes(head: bytes, columns: list[Cells]) -> np.ndarray:
    """uint8 buffer: head, then one line per row of the columns (cells joined by ',', a newline at the end)."""
    n = len(columns[0])
    if any(len(c) != n for c in columns):
        raise ValueError("columns of different lengths")
    row_len = np.full(n, len(columns), np.int64)             # the separators and the newline
    for c in columns:
        row_len += c.lens if c.index is None else c.lens[c.index]
    pos = np.empty(n, np.int64)
    pos[0] = len(head)
    np.cumsum(row_len[:-1], out=pos[1:])
    pos[1:] += len(head)
    out = np.empty(len(head) + int(row_len.sum()), np.uint8)
    out[:len(head)] = np.frombuffer(head, np.uint8)
    none = np.full(1, -1, np.int64)
    for k, c in enumerate(columns):
        _row_put(out, pos, c.table, c.lens, none if c.index is None else c.index, 10 if k == len(columns) - 1 else 44)
    return out


def warm_up() -> None:
    """Compile (or load from the cache) the kernels on tiny inputs of the types the products pass."""
    csv_text("a,b,c", [fixed_cells(np.array([0.5, -1.25]), 1), int_cells(np.array([1, -2])),
                       label_cells(["x"], np.zeros(2, np.int64))])
