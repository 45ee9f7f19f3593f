"""Random starts of a TTFF study for the simulator: an off-pointing start orientation that slews back to Earth
pointing, as simulator overrides (one set per start).

The simulator's `ttff` preset draws its own starts (yaw +-135, pitch +-(10..68), roll -30..60 deg, 60 s hold,
0.15 deg/s); issue 7 asks for yaw +-180, pitch +-70, roll +-40 deg slewing back at 0.1-0.5 deg/s, so a start is
given to the simulator explicitly as `waypoints` (minimum-jerk slerp, peak rate 1.875 angle / T) with
`random_initial_attitude` off.
"""
from __future__ import annotations

import math

import numpy as np

from gnssatt.gnss.time import GpsTime

__all__ = ["Start", "random_starts", "start_overrides", "BENIGN_OVERRIDES", "STUDY_EPOCH_GPS",
           "STUDY_SPACING_S"]

#: First start and spacing of the starts (the ttff preset's: seed 000 Fig. 7 date, ~5 days apart so the GPS
#: geometry differs from start to start).
STUDY_EPOCH_GPS = "2017-08-10T14:01:00"
STUDY_SPACING_S = 5 * 86400.0 + 3 * 3600.0 + 17 * 60.0

#: The realism issue 7 item 2 asks for (50 mm p-p differential PCV, ~1 m code multipath at the antenna horizon,
#: C/N0-dependent noise with L2 P(Y) worst, carrier multipath of a few mm, tracking below the antenna horizon) is
#: the simulator's `ttff` preset itself (gnssatt/sim/scenarios.py TtffParams, docs/simulator.md). These overrides
#: switch it off for consistency checks only (the job's `simulate.realistic: false`): white noise only, no PCV.
BENIGN_OVERRIDES: dict = {
    "pcv": False,
    "multipath": False,
    "noise_grows_with_cn0": False,
    "l2_noise_factor": 1.0,
    "cn0_jitter_db": 0.0,
}


class Start(dict):
    """One start: yaw_deg, pitch_deg, roll_deg (orbital frame), rate_deg_s (peak slew-back rate), index."""


def random_starts(count: int, seed: int, yaw_max_deg: float = 180.0, pitch_max_deg: float = 70.0,
                  roll_max_deg: float = 40.0, rate_deg_s: tuple = (0.1, 0.5)) -> list[Start]:
    """`count` starts, uniform in yaw (+-yaw_max), pitch (+-pitch_max), roll (+-roll_max) and peak rate."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 7007]))
    out = []
    for i in range(int(count)):
        y = float(rng.uniform(-yaw_max_deg, yaw_max_deg))
        p = float(rng.uniform(-pitch_max_deg, pitch_max_deg))
        r = float(rng.uniform(-roll_max_deg, roll_max_deg))
        w = float(rng.uniform(*rate_deg_s))
        out.append(Start(index=i, yaw_deg=round(y, 3), pitch_deg=round(p, 3), roll_deg=round(r, 3),
                         rate_deg_s=round(w, 4)))
    return out


def _rotation_angle_deg(yaw: float, pitch: float, roll: float) -> float:
    from gnssatt.gnss.rotations import euler321_to_dcm

    R = euler321_to_dcm(yaw, pitch, roll)
    return math.degrees(math.acos(max(-1.0, min(1.0, (float(np.trace(R)) - 1.0) / 2.0))))


def start_overrides(start: dict, duration_s: float, hold_s: float = 0.0, base: dict | None = None) -> dict:
    """Simulator overrides (preset `ttff`, count 1) for one start: its own date and the slew-back waypoints.

    Args:
        start: a Start (yaw_deg, pitch_deg, roll_deg, rate_deg_s, index).
        duration_s: length of the set.
        hold_s: time the start orientation is held before the slew back.
        base: further overrides (e.g. BENIGN_OVERRIDES), applied first.
    """
    y, p, r = start["yaw_deg"], start["pitch_deg"], start["roll_deg"]
    ang = _rotation_angle_deg(y, p, r)
    T = max(1.875 * ang / float(start["rate_deg_s"]), 1.0)        # min-jerk: peak rate = 1.875 angle / T
    wp = [[0.0, y, p, r]]
    if hold_s > 0:
        wp.append([float(hold_s), y, p, r])
    wp.append([float(hold_s) + T, 0.0, 0.0, 0.0])
    t0 = GpsTime.from_iso(STUDY_EPOCH_GPS) + float(start["index"]) * STUDY_SPACING_S
    ov = dict(base or {})
    ov.update({"count": 1, "start_gps": t0.iso(0), "duration_s": float(duration_s), "random_initial_attitude": False,
               "attitude_profile": "waypoints", "waypoints": wp, "truth_components": False})
    return ov
