"""Defaults of the vector-phase EKF that follow from the set, with their reasons (the job's config schema lists
them as "x-platform-defaults"; summary.json `defaults_applied` says which one a job used).

Position random walk (`position_random_walk_m_per_sqrt_s` left unset): a set without a velocity (velocity.csv,
docs/formats/inertial_csv.md) is a static antenna, 0; with one, the antenna moves: the filter propagates the
position with that velocity and the walk covers the velocity's error, sigma_v per sqrt(s) (q = sigma_v^2 x 1 s).
"""
from __future__ import annotations

__all__ = ["POSITION_WALK_DEFAULTS", "DEFAULT_VELOCITY_SIGMA_M_S", "position_walk_default"]

#: a receiver's own (Doppler) velocity: a few cm/s; used when velocity.csv has no sigma_m_s column
DEFAULT_VELOCITY_SIGMA_M_S = 0.05

POSITION_WALK_DEFAULTS: dict = {
    "static (no velocity in the set)": {
        "value": 0.0,
        "reason": "the antenna is modelled static: with exactly 7 satellites a 1 mm/sqrt(s) walk on a static "
                  "antenna made the attitude error/sigma 2-6 (yaw/pitch/roll 3.96 / 1.93 / 5.67 at 0.05 mm), 0 "
                  "gave 0.97 / 0.99 / 0.88 (docs/vector_phase.md \"Consistency with seven satellites\")"},
    "velocity given (velocity.csv)": {
        "value": f"the file's median sigma_m_s ({DEFAULT_VELOCITY_SIGMA_M_S} without that column), per sqrt(s)",
        "reason": "the antenna moves: the position is propagated with the set's velocity, and walks by that "
                  "velocity's error over each second (q = sigma_v^2 x 1 s)"},
}


def position_walk_default(has_velocity: bool, sigma_velocity_m_s: float | None) -> tuple[float, dict]:
    """(position random walk m/sqrt(s), {setting, value, reason}) for a set with or without a velocity."""
    if not has_velocity:
        key = "static (no velocity in the set)"
        value = 0.0
    else:
        key = "velocity given (velocity.csv)"
        value = float(sigma_velocity_m_s) if sigma_velocity_m_s else DEFAULT_VELOCITY_SIGMA_M_S
    return value, {"setting": "position_random_walk_m_per_sqrt_s", "value": value, "case": key,
                   "reason": POSITION_WALK_DEFAULTS[key]["reason"]}
