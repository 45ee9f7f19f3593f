"""plan.png: satellites in view, DOPs / ADOP and the expected yaw / pitch / roll sigma over the plan."""
from __future__ import annotations

import io

import numpy as np

from gnssatt.planning.series import PlanSeries


def plan_png(s: PlanSeries) -> bytes:
    """Three panels against minutes from the start: n_sats; HDOP, VDOP, ADOP; snapshot sigma of yaw/pitch/roll."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tm = np.asarray(s.time - s.time[0], float) / 60.0
    fig, ax = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    ax[0].step(tm, s.n_sats, where="mid")
    ax[0].set_ylabel("satellites")
    for y, lab in ((s.hdop, "HDOP"), (s.vdop, "VDOP"), (s.adop, "ADOP")):
        ax[1].plot(tm, y, label=lab)
    ax[1].legend()
    ax[1].set_ylabel("DOP")
    for i, lab in enumerate(("yaw", "pitch", "roll")):
        ax[2].plot(tm, s.sigma_euler_deg[:, i], label=lab)
    ax[2].set_ylabel("expected sigma (deg)")
    ax[2].set_xlabel("minutes from start")
    ax[2].legend()
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    plt.close(fig)
    return buf.getvalue()
