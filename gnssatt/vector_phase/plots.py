"""PNG plots of the vector-phase products: Euler angles with their 1-sigma band (and the reference attitude's
angles when the set has one), observability per epoch (rank and condition), and phase residuals."""
from __future__ import annotations

import numpy as np

from gnssatt.plots.common import figure_png, new_figure

__all__ = ["vector_phase_plots"]


def _euler(t_s, euler, reference_deg):
    fig = new_figure(10.0, 7.5)
    axes = fig.subplots(3, 1, sharex=True)
    for i, (ax, name) in enumerate(zip(axes, ("yaw", "pitch", "roll"))):
        val, sig = euler.euler_deg[:, i], euler.sigma_deg[:, i]
        ax.plot(t_s, val, lw=1.0, label="vector phase")
        ax.fill_between(t_s, val - sig, val + sig, alpha=0.3, label="1 sigma")
        if reference_deg is not None:
            ax.plot(t_s, reference_deg[:, i], "k--", lw=0.8, label="reference")
        if not np.isfinite(val).any():
            ax.text(0.5, 0.5, f"{name} not determined (unobservable rotation)", transform=ax.transAxes, ha="center")
        ax.set_ylabel(f"{name} (deg)")
    axes[0].legend(loc="best", fontsize=8)
    axes[-1].set_xlabel("time since first epoch (s)")
    fig.suptitle("Attitude from one antenna's carrier phase (seed 003)")
    return figure_png(fig)


def _observability(t_s, sol):
    fig = new_figure(10.0, 5.0)
    a1, a2 = fig.subplots(2, 1, sharex=True)
    a1.step(t_s, sol.rank, where="post")
    a1.set_ylabel("rank (of 7)")
    a1.set_ylim(0, 7.5)
    cond = np.where(np.isfinite(sol.condition), sol.condition, np.nan)
    a2.semilogy(t_s, cond)
    a2.set_ylabel("condition (scaled)")
    a2.set_xlabel("time since first epoch (s)")
    fig.suptitle("Observability of position, clock and attitude per epoch")
    return figure_png(fig)


def _residuals(t_s, sol):
    fig = new_figure(10.0, 4.5)
    ax = fig.subplots()
    for j, sat in enumerate(sol.sats):
        r = sol.residuals_cyc[:, j]
        if np.isfinite(r).any():
            ax.plot(t_s, r * 1e3, ".", ms=2, label=sat)
    ax.set_ylabel("phase residual (mcycles)")
    ax.set_xlabel("time since first epoch (s)")
    ax.legend(ncol=6, fontsize=7)
    return figure_png(fig)


def vector_phase_plots(sol, euler, reference_deg=None) -> dict[str, bytes]:
    """{file name: PNG} of attitude.png, observability.png, residuals.png."""
    t_s = sol.t_gps_s - sol.t_gps_s[0]
    return {"attitude.png": _euler(t_s, euler, reference_deg), "observability.png": _observability(t_s, sol),
            "residuals.png": _residuals(t_s, sol)}
