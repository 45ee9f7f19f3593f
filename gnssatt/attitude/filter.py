"""The attitude EKF of seed 000 sec. 2 over single-differenced carrier phase and code, with quality control and
integer ambiguity resolution.

State (fixed layout with index maps; ambiguities appended and removed as satellites come and go):
    [omega (3, dynamic mode only)] + per baseline j: [b_j ECEF (3), c*dt_j (1), code bias of signals 2.. (1 each, dual
    frequency only)] + SD ambiguities (cycles), one per (baseline, satellite, signal) in use.
Measurement model of a single difference (second antenna minus first) of satellite s, signal f, after removing
an epoch clock estimate c*dt0 from code:
    SD_code  = -u_s . b_j + (1 - rho_dot_s / c) (c dt_j) [+ B_j for signal 2] + e
    SD_phase = -u_s . b_j + (1 - rho_dot_s / c) (c dt_j) + lambda_f A_jsf + e
The factor (1 - rho_dot/c) makes the model exact for receivers whose clocks differ by up to a millisecond: the
second antenna measured at t - dt_j relative to the first, and the range moved by rho_dot dt_j meanwhile (so
free-running receiver clocks need no resampling of observations). The model is linear in the state.
Dynamics: b' = omega x b, omega random walk (dynamic); b random walk, no omega (kinematic); c*dt white noise.

Implements: seed 000 sec. 2 eq. 1-2, Table 1 (noise), Table 2 (editing: local / antenna elevation, C/N0,
triple differences of code and phase, baseline-length acceptance), fixed-step RK4 propagation, MLAMBDA on DD of
float SD ambiguities with a zero-variance pseudo-measurement for accepted fixes, sec. 3.2 compromise (all
satellites until fixed, then only those above the antenna horizon).
The epoch loop follows seed 000 Fig. 2, one function per box (gnssatt.attitude.boxes):
    initialisation (gnssatt.attitude.filter_state.FilterRun) -> per epoch: propagate -> quality_control ->
    measurement_update -> ambiguity_resolution (with validation) -> fix_monitor -> output.
Neglects: differential troposphere/ionosphere (baselines of metres); correlation of the baselines through the
common master antenna's noise (each SD is treated as independent, as in the paper).
"""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.boxes.ambiguity_resolution import ambiguity_resolution, pseudo_update
from gnssatt.attitude.boxes.fix_monitor import fix_monitor
from gnssatt.attitude.boxes.measurement_update import measurement_update
from gnssatt.attitude.boxes.output import filter_result, output
from gnssatt.attitude.boxes.propagate import propagate
from gnssatt.attitude.boxes.quality_control import quality_control
from gnssatt.attitude.filter_state import REASONS, EpochData, FilterResult, FilterRun, FilterState
from gnssatt.attitude.settings import AttitudeSettings

__all__ = ["FilterResult", "run_filter", "REASONS"]

_State = FilterState            # the former name (tests)
_pseudo_update = pseudo_update


def run_filter(pobs, geom, baselines: list[tuple[int, int]], body_baselines_m: np.ndarray,
               boresight_body: np.ndarray, settings: AttitudeSettings, R_body_from_ecef_0: np.ndarray,
               attitude_fn=None, progress=None, q_omega: np.ndarray = None, noise0: dict = None) -> FilterResult:
    """FilterResult of the EKF over all epochs of `pobs` (PlatformObs) with `geom` (EpochGeometry): seed 000 Fig. 2.

    Args:
        baselines: (first, second) antenna indices into pobs.antennas.
        body_baselines_m: (n_bl, 3) known body-frame baselines (a priori or calibrated).
        boresight_body: (n_ant, 3) antenna boresights, for the antenna-frame elevation mask.
        R_body_from_ecef_0: (3, 3) initial attitude (Earth pointing or given) for the initial baselines.
        attitude_fn: callable (b_ecef (n_bl, 3), fixed (n_bl,), epoch index k) -> R_body_from_ecef (3, 3) or None;
            used for the antenna-frame mask and PCV maps once every baseline is fixed. None: no antenna-frame mask.
        progress: callable(fraction) called every ~100 epochs.
        q_omega: dynamic mode, (n_ep, 3, 3) omega random-walk rate (rad^2/s^3) of the propagation into each epoch,
            in place of Table 1's (and of the adapter's); None: Table 1's (smoother_adaptive_noise's second pass).
        noise0: the noise estimator's state to start from (a first pass's smoother_data["noise_state"]); None:
            Table 1's sigmas until the triple differences give an estimate.
    """
    run = FilterRun(pobs, geom, baselines, body_baselines_m, boresight_body, settings, R_body_from_ecef_0,
                    attitude_fn, q_omega, noise0)
    for k in range(run.n_ep):
        run.st.epoch = k
        if progress is not None and k % 100 == 0:
            progress(k / max(run.n_ep, 1))
        ep = EpochData(k, run.t_s[k], run.prev_t)
        propagate(run, ep)
        quality_control(run, ep)
        measurement_update(run, ep)
        ambiguity_resolution(run, ep)
        fix_monitor(run, ep)
        output(run, ep)
    if progress is not None:
        progress(1.0)
    return filter_result(run)
