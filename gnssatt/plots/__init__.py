"""Server-side plots of gnssatt products: pure functions from arrays / CSV text to PNG bytes.

Every plot has two faces: `<name>_figure(...) -> matplotlib.figure.Figure` (what tests read back: the
data handed to the axes, labels, titles) and `<name>_plot(...) -> bytes` (the PNG a pipeline writes as a
product). Figures are made with `matplotlib.figure.Figure` directly, never through pyplot, so they are
thread-safe in a worker and need no display (Agg canvas).

Modules: `inspect` (tracking and C/N0 overview), `attitude` (Euler angles with reference and errors in the
style of seed 000 Figs. 5-7, fix status and satellite count, DOP, residuals, antenna-frame sky plot),
`calibration` (polar differential PCV maps on one colour scale as seed 000 Figs. 3-4, sample counts,
baseline table), `ttff` (seed 000 Table 5 layout and TTFF histogram). Input columns: docs/pages.md.

This package never imports web code (fastapi, starlette, sqlalchemy, huey, httpx, app).
"""
from gnssatt.plots.common import PlotContext, figure_png, read_csv_table

__all__ = ["PlotContext", "figure_png", "read_csv_table"]
