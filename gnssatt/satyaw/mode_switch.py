"""Attitude-mode switches found in an estimated yaw series: departures from the attitude model, orbit-normal
intervals (seed 004 Fig. 8, manoeuvres) and 360 deg yaw turns (Fig. 5).

An epoch departs from a reference yaw when |wrap(yaw - ref)| exceeds max(min_dev_deg, k_sigma sigma). Runs of
departing epochs shorter than min_duration_s are ignored (noise), as are gaps between runs shorter than it
(merged). Within a departure, the epochs within the threshold of yaw 180 (orbit-normal, sec. 2.5) for at least
min_duration_s form an orbit-normal interval; a departure whose unwrapped excursion from the model reaches
turn_deg is a 360 deg turn.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.satyaw.attitude_models import wrap_deg

__all__ = ["SwitchOptions", "ModeEvent", "detect_mode_switches"]


@dataclass(frozen=True)
class SwitchOptions:
    k_sigma: float = 4.0
    min_dev_deg: float = 5.0
    min_duration_s: float = 300.0
    orbit_normal_yaw_deg: float = 180.0
    turn_deg: float = 300.0


@dataclass(frozen=True)
class ModeEvent:
    """kind: leave-model, back-to-model, orbit-normal, leave-orbit-normal, turn-360-start, turn-360-end;
    time_s (from the series' start), index into the series."""

    kind: str
    time_s: float
    index: int

    def to_dict(self) -> dict:
        return {"kind": self.kind, "time_s": self.time_s, "index": self.index}


def _runs(flag: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) of the True runs."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], flag.astype(np.int8), [0]))))
    return list(zip(edges[0::2].tolist(), edges[1::2].tolist()))


def _clean(flag: np.ndarray, t: np.ndarray, min_s: float) -> np.ndarray:
    """Close gaps shorter than min_s, then drop runs shorter than min_s."""
    out = flag.copy()
    for a, b in _runs(~out):
        if a > 0 and b < len(out) and t[b] - t[a - 1] < min_s:
            out[a:b] = True
    for a, b in _runs(out):
        if t[b - 1] - t[a] < min_s:
            out[a:b] = False
    return out


def detect_mode_switches(t_s, yaw_deg, sigma_deg, model_yaw_deg, options: SwitchOptions | None = None,
                         ) -> list[ModeEvent]:
    """ModeEvents of an estimated yaw (T,) with sigma (T,) against the model yaw (T,) at times t_s (T,).
    Epochs without an estimate (NaN) are left out."""
    o = options or SwitchOptions()
    ok = np.isfinite(yaw_deg) & np.isfinite(sigma_deg) & np.isfinite(model_yaw_deg)
    idx = np.flatnonzero(ok)
    if idx.size < 2:
        return []
    t = np.asarray(t_s, dtype=np.float64)[idx]
    y = np.asarray(yaw_deg)[idx]
    thr = np.maximum(o.min_dev_deg, o.k_sigma * np.asarray(sigma_deg)[idx])
    dev = wrap_deg(y - np.asarray(model_yaw_deg)[idx])
    away = _clean(np.abs(dev) > thr, t, o.min_duration_s)
    on = _clean(np.abs(wrap_deg(y - o.orbit_normal_yaw_deg)) <= thr, t, o.min_duration_s) & away
    events: list[ModeEvent] = []
    for a, b in _runs(away):
        events.append(ModeEvent("leave-model", float(t[a]), int(idx[a])))
        for c, d in _runs(on[a:b]):
            events.append(ModeEvent("orbit-normal", float(t[a + c]), int(idx[a + c])))
            events.append(ModeEvent("leave-orbit-normal", float(t[a + d - 1]), int(idx[a + d - 1])))
        excursion = np.degrees(np.unwrap(np.radians(dev[a:b])))
        if np.ptp(excursion) >= o.turn_deg:
            events.append(ModeEvent("turn-360-start", float(t[a]), int(idx[a])))
            events.append(ModeEvent("turn-360-end", float(t[b - 1]), int(idx[b - 1])))
        if b < len(t):
            events.append(ModeEvent("back-to-model", float(t[b]), int(idx[b])))
    return sorted(events, key=lambda e: (e.time_s, e.kind))
