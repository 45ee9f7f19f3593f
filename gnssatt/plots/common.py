"""Shared helpers of the plots: CSV products as column arrays, GPS-time axes, titles, PNG encoding."""
from __future__ import annotations

import csv
import gc
import io
import threading
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping

import numpy as np
from matplotlib import dates as mdates
from numba import njit
from matplotlib.figure import Figure

#: One product table: column name -> 1-D array (float64 where every non-empty cell is a number, else str).
Table = dict[str, np.ndarray]

#: Colours of seed 000 Figs. 5-7: yaw red, pitch green, roll blue.
EULER_COLOURS = {"yaw": "#d62728", "pitch": "#2ca02c", "roll": "#1f77b4"}
DPI = 100


@dataclass(frozen=True)
class PlotContext:
    """What a plot's title names: the observation set, the job and its configuration."""

    set_name: str | None = None
    job_id: str | None = None
    config: Mapping[str, Any] = field(default_factory=dict)

    @classmethod
    def of(cls, context: "PlotContext | Mapping[str, Any] | None") -> "PlotContext":
        if context is None:
            return cls()
        if isinstance(context, PlotContext):
            return context
        return cls(set_name=context.get("set_name") or context.get("set"),
                   job_id=context.get("job_id") or context.get("job"),
                   config=dict(context.get("config") or {}))

    def subtitle(self, max_chars: int = 110) -> str:
        """'set NAME · job 1a2b3c4d · mode=kinematic, frequencies=L1+L2' (config shortened to max_chars)."""
        parts = []
        if self.set_name:
            parts.append(f"set {self.set_name}")
        if self.job_id:
            parts.append(f"job {self.job_id[:8]}")
        if self.config:
            cfg = ", ".join(f"{k}={_short(v)}" for k, v in self.config.items())
            parts.append(cfg if len(cfg) <= max_chars else cfg[:max_chars - 1] + "…")
        else:
            parts.append("default configuration")
        return " · ".join(parts)


def _short(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, (list, tuple)):
        return "+".join(str(v) for v in value)
    return str(value)


def set_title(fig: Figure, what: str, context: "PlotContext | Mapping[str, Any] | None") -> None:
    """Figure title: what is shown (first line) and set, job and configuration (second line)."""
    import textwrap

    width_chars = max(60, int(fig.get_figwidth() * 13))  # ~13 characters per inch at 9 pt: never clipped
    sub = textwrap.fill(PlotContext.of(context).subtitle(), width=width_chars)
    fig.suptitle(f"{what}\n{sub}", fontsize=9)


@dataclass(frozen=True)
class Margins:
    """Fixed figure margins and gaps between axes [inches], for `new_figure(..., margins=)`: the constrained
    layout measures every text of a figure before drawing it (about a third of a plot's CPU time); a plot
    whose texts are known in advance sets its margins once instead. rows/cols: the grid of axes the gaps
    separate."""

    left: float = 0.75
    right: float = 0.2
    top: float = 0.75
    bottom: float = 0.55
    hgap: float = 0.4
    wgap: float = 0.8
    rows: int = 1
    cols: int = 1


def new_figure(width_in: float = 10.0, height_in: float = 6.0, margins: Margins | None = None) -> Figure:
    """A pyplot-free Figure (thread-safe; rendered by the Agg canvas on savefig): constrained layout, or the
    fixed `margins` when given (set before the axes are added, so fig.subplots / add_subplot use them)."""
    if margins is None:
        return Figure(figsize=(width_in, height_in), dpi=DPI, layout="constrained")
    fig = Figure(figsize=(width_in, height_in), dpi=DPI, layout=None)
    m = margins
    axes_h = max(height_in - m.top - m.bottom - (m.rows - 1) * m.hgap, 0.1) / m.rows
    axes_w = max(width_in - m.left - m.right - (m.cols - 1) * m.wgap, 0.1) / m.cols
    fig.subplots_adjust(left=m.left / width_in, right=1.0 - m.right / width_in, top=1.0 - m.top / height_in,
                        bottom=m.bottom / height_in, hspace=m.hgap / axes_h, wspace=m.wgap / axes_w)
    return fig


#: zlib level of the PNGs: 1 encodes ~3x faster than the default 6 for ~10-30 % larger files (plots of long passes
#: are encoded in the job, so the job's wall time counts more than a few kB)
PNG_COMPRESS_LEVEL = 1


def figure_png(fig: Figure, dpi: int = DPI) -> bytes:
    """The figure as PNG bytes (no timestamp or software metadata, so equal figures give equal bytes)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, metadata={"Software": None},
                pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})
    return buf.getvalue()


def read_csv_table(data: "str | bytes | Table | Iterable[Mapping[str, Any]] | None") -> Table:
    """Column arrays of a CSV product (text with a header line), a list of row dicts, or a ready Table.

    Columns whose every non-empty cell parses as a number become float64 with NaN for empty cells;
    others stay as str arrays. Column names are stripped of blanks.
    """
    if data is None:
        return {}
    if isinstance(data, dict):
        return {str(k): np.asanyarray(v) for k, v in data.items()}   # asany: a CodedStrings column keeps its categories
    if isinstance(data, bytes):
        data = data.decode("utf-8")
    if isinstance(data, str):
        return _table_of_text(data)
    rows = [dict(r) for r in data]
    names = list(dict.fromkeys(k for r in rows for k in r))
    raw = {n: ["" if r.get(n) is None else str(r.get(n)).strip() for r in rows] for n in names}
    return {n: _column_array(v) for n, v in raw.items()}


def _table_of_text(text: str) -> Table:
    """Column arrays of CSV text, as csv.DictReader would read it (blank lines skipped, short rows padded with
    empty cells, extra cells dropped), but column-wise: without quotes and with every row complete, one split of
    the whole text sliced per column; numeric columns converted by one numpy cast (residuals.csv, ~6e5 rows, is
    read in ~1 s instead of ~10 s)."""
    lines = text.splitlines()
    if not lines:
        return {}
    if '"' not in text and "\r" not in text:
        lines = [ln for ln in lines if ln] if "" in lines else lines
        if not lines:
            return {}
        fields = lines[0].split(",")
        n = len(fields)
        if all(ln.count(",") == n - 1 for ln in lines):
            flat = ",".join(lines[1:]).split(",") if len(lines) > 1 else []
            cols = [flat[i::n] for i in range(n)]
            return _columns(fields, cols)
    gc_was = gc.isenabled()
    gc.disable()               # millions of small row lists: the cyclic collector would run over them again and again
    try:
        rows = [r for r in csv.reader(io.StringIO(text)) if r]
        if not rows:
            return {}
        fields, body = rows[0], rows[1:]
        n = len(fields)
        if any(len(r) != n for r in body):
            body = [(r + [""] * n)[:n] for r in body]
        cols = [list(c) for c in zip(*body)] if body else [[] for _ in range(n)]
    finally:
        if gc_was:
            gc.enable()
    return _columns(fields, cols)


def _columns(fields: list[str], cols: list[list[str]]) -> Table:
    out: Table = {}
    for name, cells in zip(fields, cols):
        key = name.strip()
        out.pop(key, None)        # DictReader keeps the last of duplicate names
        out[key] = _column_array_fast(np.array(cells, dtype=str))
    return out


def _column_array(cells: list[str]) -> np.ndarray:
    try:
        return np.array([float(c) if c != "" else np.nan for c in cells], dtype=np.float64)
    except ValueError:
        return np.array(cells, dtype=str)


def _column_array_fast(cells: np.ndarray) -> np.ndarray:
    """float64 (NaN for empty cells) if every non-empty cell is a number, else the stripped str array."""
    stripped = np.strings.strip(cells)
    empty = stripped == ""
    out = np.full(stripped.shape, np.nan)
    first = np.flatnonzero(~empty[:1000])
    try:
        if first.size:
            float(stripped[first[0]])         # a text column (times, names) fails here, before the whole cast
    except ValueError:
        return stripped
    try:
        out[~empty] = stripped[~empty].astype(np.float64)
    except ValueError:
        return stripped
    return out


def column(table: Table, *names: str) -> np.ndarray | None:
    """The first of `names` present in `table` (case-insensitive), or None."""
    lower = {k.lower(): k for k in table}
    for n in names:
        if n.lower() in lower:
            return table[lower[n.lower()]]
    return None


def numeric(table: Table, *names: str) -> np.ndarray | None:
    """Like `column` but as float64 (None when absent)."""
    col = column(table, *names)
    if col is None:
        return None
    if col.dtype.kind == "f":
        return col
    out = np.full(len(col), np.nan)
    for i, c in enumerate(col):
        try:
            out[i] = float(c)
        except ValueError:
            pass
    return out


_memo = threading.local()


@contextmanager
def category_memo():
    """Within this block (this thread), `categories` of the same array object is computed once: several plots of
    one table (residuals.csv feeds three) share the codes of its baseline/satellite/signal columns."""
    outer = getattr(_memo, "table", None)
    _memo.table = {} if outer is None else outer
    try:
        yield
    finally:
        _memo.table = outer


class CodedStrings(np.ndarray):
    """A str column built from a few labels and a code per row (`coded_strings`), carrying what `categories`
    gives for it (`coded`), so the plots do not sort ~6e5 strings to find the labels again. Views and results
    of operations on it are plain-behaving arrays without `coded` (categories then computes as usual)."""


def coded_strings(labels, codes) -> np.ndarray:
    """labels[codes] as a str column that carries its categories (CodedStrings); a plain str array when the
    labels repeat (categories would merge them)."""
    labels = [str(v) for v in labels]
    codes = np.asarray(codes, dtype=np.int64)
    column_ = np.asarray(labels or [""], dtype=str)[codes]
    if len(set(labels)) != len(labels) or codes.size == 0:
        return column_
    first = np.full(len(labels), codes.size, np.int64)
    np.minimum.at(first, codes, np.arange(codes.size))       # first row of each label (no sort)
    present = np.flatnonzero(first < codes.size)
    order = present[np.argsort(first[present])]               # label indices in order of first appearance
    rank = np.full(len(labels), -1, np.int64)
    rank[order] = np.arange(order.size)
    out = column_.view(CodedStrings)
    out.coded = ([labels[j] for j in order], rank[codes])
    return out


def categories(values: np.ndarray) -> tuple[list[str], np.ndarray]:
    """(distinct values in order of first appearance, int code per row indexing that list) of a column, as
    `list(dict.fromkeys(values))` and a lookup would give, by one sort of the fixed-width cells as raw bytes
    (~6e5 residual rows: 0.07 s instead of ~0.3 s for dict/set over numpy str scalars); a CodedStrings column
    gives the categories it carries."""
    coded = getattr(values, "coded", None) if isinstance(values, CodedStrings) else None
    if coded is not None:
        return coded[0], coded[1]
    memo = getattr(_memo, "table", None)
    if memo is not None:
        hit = memo.get(id(values))
        if hit is not None and hit[0] is values:
            return hit[1]
        result = _categories(values)
        memo[id(values)] = (values, result)     # the array is kept alive, so its id is not reused meanwhile
        return result
    return _categories(values)


def _categories(values: np.ndarray) -> tuple[list[str], np.ndarray]:
    arr = np.asarray(values)
    if arr.dtype.kind != "U":
        arr = arr.astype(str)
    arr = np.ascontiguousarray(arr.ravel())
    if arr.size == 0:
        return [], np.zeros(0, dtype=np.int64)
    raw = arr.view(np.dtype((np.void, arr.dtype.itemsize)))
    _, first, inverse = np.unique(raw, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return [str(arr[first[j]]) for j in order], rank[inverse.ravel()]


def first_per_epoch_and_key(time: np.ndarray, codes: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The subset of `rows` (sorted indices) that is the first row of each (time, code) pair, in row order: one
    row per epoch and satellite of a long table with one row per signal/observable. time: datetime64 per row,
    codes: int per row (e.g. from `categories`)."""
    rows = np.asarray(rows, dtype=np.int64)
    if rows.size == 0:
        return rows
    n_codes = int(codes.max()) + 1 if codes.size else 1
    t_ms = np.asarray(time, dtype="datetime64[ms]").astype(np.int64)
    t_rows, c_rows = t_ms[rows], np.asarray(codes, np.int64)[rows]
    if np.all(t_rows[1:] >= t_rows[:-1]) and c_rows.min() >= 0:
        return rows[_first_per_time_and_code(t_rows, c_rows, n_codes)]     # rows in time order: one pass
    key = t_rows * n_codes + c_rows
    _, first = np.unique(key, return_index=True)
    return rows[np.sort(first)]


@njit(cache=True, nogil=True)
def _first_per_time_and_code(t, codes, n_codes):
    """keep[i]: row i is the first of its (t, code) pair; t nondecreasing, so each pair's rows share one run of t."""
    last_t = np.zeros(n_codes, np.int64)
    seen = np.zeros(n_codes, np.bool_)
    keep = np.zeros(t.shape[0], np.bool_)
    for i in range(t.shape[0]):
        c = codes[i]
        if not seen[c] or last_t[c] != t[i]:
            keep[i] = True
            seen[c] = True
            last_t[c] = t[i]
    return keep


def truthy(values: np.ndarray) -> np.ndarray:
    """bool array of a 0/1 or true/false column (NaN / empty -> False)."""
    if values.dtype.kind == "f":
        return np.nan_to_num(values, nan=0.0) != 0
    return np.isin(np.char.lower(values.astype(str)), ["1", "true", "yes", "y", "t"])


def gps_time(table: Table) -> np.ndarray:
    """datetime64[ms] of the `time_gps` column (ISO 8601 in GPS time, CONVENTIONS.md); plotted as written,
    i.e. the axis is GPS time, not UTC."""
    col = column(table, "time_gps")
    if col is None:
        raise KeyError("the table has no time_gps column")
    if col.dtype.kind in "UM":
        return col.astype("datetime64[ms]")      # text: one cast, same parser as per-element np.array(str)
    return np.array([str(c) for c in col], dtype="datetime64[ms]")


def time_axis(ax, t: np.ndarray, label: bool = True, maxticks: int = 9) -> None:
    """Format an x axis holding GPS datetimes: HH:MM:SS ticks (at most `maxticks`: fewer on narrow axes, so the
    labels do not run into each other), label naming GPS time and the date."""
    locator = mdates.AutoDateLocator(minticks=3, maxticks=maxticks) if maxticks < 9 else \
        mdates.AutoDateLocator(minticks=4, maxticks=maxticks)
    ax.xaxis.set_major_locator(locator)
    ax.xaxis.set_major_formatter(mdates.DateFormatter("%H:%M:%S"))
    if label:
        day = str(np.min(t))[:10] if len(t) else ""
        ax.set_xlabel(f"GPS time [hh:mm:ss] on {day}" if day else "GPS time [hh:mm:ss]")


def no_data(ax, message: str = "no data") -> None:
    ax.text(0.5, 0.5, message, ha="center", va="center", transform=ax.transAxes, color="0.4")


def wrap_deg(angle_deg: np.ndarray) -> np.ndarray:
    """Angles wrapped into (-180, 180] degrees."""
    wrapped = np.mod(np.asarray(angle_deg, dtype=np.float64) + 180.0, 360.0) - 180.0
    return np.where(wrapped == -180.0, 180.0, wrapped)


def axes_pixels(ax) -> tuple[int, int]:
    """(width, height) of an axes' plotting area in output pixels (figure size x DPI x axes position)."""
    fig = ax.get_figure()
    pos = ax.get_position()
    w_in, h_in = fig.get_size_inches()
    return max(int(round(pos.width * w_in * DPI)), 1), max(int(round(pos.height * h_in * DPI)), 1)


def screen_points(x: np.ndarray, y: np.ndarray, width_px: int, height_px: int | None = None,
                  cell_px: float = 2.0) -> np.ndarray:
    """Sorted indices of the points of (x, y) that a width_px-wide panel can show apart: in each pixel column the
    first, last, lowest and highest finite point (M4 aggregation: Jugel et al. 2014, "M4: a visualization-oriented
    time series data aggregation", PVLDB 7(10)), so spikes and the envelope stay as the full series draws them;
    with height_px, also the first point of every occupied cell of cell_px x cell_px pixels (a scatter's dots
    fill the same cells). Columns and cells span the finite data's own range. Non-finite points are dropped; a
    series of at most 4 points per pixel column is kept whole."""
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    ok = np.flatnonzero(np.isfinite(x) & np.isfinite(y))
    n_cols = max(int(width_px), 1)
    if ok.size <= 4 * n_cols:
        return ok                                        # no more than M4 would keep: drawn whole
    xs, ys = np.ascontiguousarray(x[ok]), np.ascontiguousarray(y[ok])
    grid = (0, 0) if height_px is None else (max(int(np.ceil(width_px / cell_px)), 1),
                                             max(int(np.ceil(height_px / cell_px)), 1))
    keep = np.zeros(ok.size, np.bool_)
    _screen_kernel(xs, ys, n_cols, grid[0], grid[1], keep)
    return ok[keep]


@njit(cache=True, nogil=True)
def _bin(v, lo, hi, n):
    """Bin 0..n-1 of v in [lo, hi] split into n equal bins (all in bin 0 when hi == lo)."""
    if hi <= lo:
        return 0
    return min(int((v - lo) * (n / (hi - lo))), n - 1)


@njit(cache=True, nogil=True)
def _screen_kernel(x, y, n_cols, cell_cols, cell_rows, keep):
    """keep[i] = True for screen_points' points of finite (x, y): per column first/last/min/max, and the first
    point of each occupied cell of a cell_cols x cell_rows grid (none when cell_rows == 0)."""
    x0, x1, y0, y1 = x.min(), x.max(), y.min(), y.max()
    ext = np.full((4, n_cols), -1, np.int64)             # first, last, lowest, highest per column
    occupied = np.zeros(max(cell_cols * cell_rows, 1), np.bool_)
    for i in range(x.shape[0]):
        c = _bin(x[i], x0, x1, n_cols)
        if ext[0, c] < 0 or x[i] < x[ext[0, c]]:
            ext[0, c] = i
        if ext[1, c] < 0 or x[i] >= x[ext[1, c]]:
            ext[1, c] = i
        if ext[2, c] < 0 or y[i] < y[ext[2, c]]:
            ext[2, c] = i
        if ext[3, c] < 0 or y[i] > y[ext[3, c]]:
            ext[3, c] = i
        if cell_rows > 0:
            cell = _bin(x[i], x0, x1, cell_cols) * cell_rows + _bin(y[i], y0, y1, cell_rows)
            if not occupied[cell]:
                occupied[cell] = True
                keep[i] = True
    for k in range(4):
        for c in range(n_cols):
            if ext[k, c] >= 0:
                keep[ext[k, c]] = True


def polar_screen_points(ax, az_deg: np.ndarray, r: np.ndarray) -> np.ndarray:
    """screen_points of a polar axes' (azimuth, radius) points, on the plane the panel shows them in."""
    w, h = axes_pixels(ax)
    a = np.radians(az_deg)
    return screen_points(r * np.sin(a), r * np.cos(a), w, h)


def warm_up(draw: bool = True) -> None:
    """Compile (or load from the cache) the decimation kernels; with `draw`, also render one small figure with
    the artists and text sizes of the job plots (date axis, markers, band, legend, polar scatter, colour bar) to
    PNG, so that a process forked afterwards (the worker's job children) finds matplotlib's font lookups, loaded
    fonts and PIL's image plugins ready instead of loading them in every job (~0.1-0.2 s; docs/BENCHMARKS.md
    "Attitude job speed"). Drawing changes no later figure: every plot builds its own Figure."""
    screen_points(np.arange(8.0), np.arange(8.0), 1, 4)             # > 4 points per column: the kernel runs
    first_per_epoch_and_key(np.arange(3).astype("datetime64[ms]"), np.zeros(3, np.int64), np.arange(3))
    if draw:
        figure_png(_warm_up_figure())


def _warm_up_figure() -> Figure:
    """A 3 x 2 inch figure using what the job plots use (gnssatt.plots.attitude, gnssatt.plots.elevation)."""
    fig = new_figure(3.0, 2.0, Margins(left=0.4, top=0.4, bottom=0.3, wgap=0.4, cols=2))
    t = np.datetime64("2020-01-01T00:00:00", "ms") + np.arange(0, 60_000, 10_000).astype("timedelta64[ms]")
    ax = fig.add_subplot(1, 2, 1)
    y = np.arange(len(t), dtype=float)
    ax.plot(t, y, ".", ms=2.5, label="a")
    ax.plot(t, y, "-", lw=1.0, label="b")
    ax.fill_between(t, y - 1, y + 1, where=y > 0, alpha=0.12, lw=0)
    ax.step(t, y, where="post", lw=0.8)
    ax.set_ylabel("y [-]")
    ax.set_title("title", fontsize=8)
    ax.legend(fontsize=7, markerscale=4, loc="upper right")
    ax.grid(color="0.88", lw=0.5)
    ax.text(0.01, 0.02, "note", transform=ax.transAxes, fontsize=7, color="0.35")
    time_axis(ax, t, maxticks=5)
    polar = fig.add_subplot(1, 2, 2, projection="polar")
    sc = polar.scatter(np.radians(y * 60.0), 90.0 - y * 10.0, c=y, s=4, cmap="viridis", linewidths=0)
    polar.annotate("G01", (0.5, 30.0), fontsize=6, color="0.25")
    polar.set_rticks([0, 30, 60])
    polar.set_yticklabels(["90°", "60°", "30°"], fontsize=7)
    fig.colorbar(sc, ax=[polar], label="C/N0 [dB-Hz]", shrink=0.8)
    set_title(fig, "warm-up", None)
    return fig
