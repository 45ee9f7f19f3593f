"""The carrier-phase wind-up of a real receive antenna for the multi-antenna simulator: the orientation-dependent
phase delta_s of seed 003 eq. 32 (gnssatt.vector_phase.phase_model) for an antenna described as in
docs/formats/antenna_vector_length.md, instead of the ideal crossed-dipole wind-up of Wu et al. 1993.

Used when SimParams.windup_antenna is set (a pattern object, e.g. {"model": "asymmetric-patch", "asymmetry":
0.3}); every antenna of the platform is that antenna, mounted in its own antenna frame. With the ideal
{"model": "rhcp-patch"} it equals gnssatt.sim.observables.windup_cycles to 1e-6 cycles
(tests/vector_phase/test_sim_windup.py), so the option's default (None: the Wu form) keeps every existing output.
"""
from __future__ import annotations

import numpy as np

from gnssatt.vector_phase.pattern_file import parse_antenna_pattern
from gnssatt.vector_phase.phase_model import AntennaMount, delta_rad

__all__ = ["vector_windup_cycles"]


def vector_windup_cycles(pattern: dict, e_ecef: np.ndarray, R_ecef_from_body: np.ndarray, R_ant_from_body: np.ndarray,
                         x_sat_ecef: np.ndarray, y_sat_ecef: np.ndarray) -> np.ndarray:
    """Wind-up in cycles (n_ep, n_sv), unwrapped along the epochs, first value in (-0.5, 0.5].

    Args: pattern: an antenna_pattern.json object; e_ecef (n_ep, n_sv, 3) antenna -> satellite; R_ecef_from_body
    (n_ep, 3, 3); R_ant_from_body (3, 3) the antenna's frame; x_sat_ecef, y_sat_ecef (n_ep, n_sv, 3) the
    satellite body axes. Implements: seed 003 eq. 32 with the transmitter polarisation of eq. 15.
    """
    mount = AntennaMount(parse_antenna_pattern(pattern, name="SimParams.windup_antenna"), np.asarray(R_ant_from_body))
    delta = delta_rad(mount, np.swapaxes(R_ecef_from_body, -1, -2), e_ecef, x_sat_ecef, y_sat_ecef)
    return np.unwrap(delta, axis=0) / (2.0 * np.pi)
