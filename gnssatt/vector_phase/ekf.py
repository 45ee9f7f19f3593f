"""The vector-phase EKF (seed 003 eq. 35, 44-45) from a known initial state: one filter from the initial rate
(gnssatt.vector_phase.ekf_filter, its state and noise model) or, by default, a bank of filters from several initial
rates whose accumulated costs decide between them (gnssatt.vector_phase.rate_bank)."""
from __future__ import annotations

from gnssatt.vector_phase.ekf_filter import EkfOptions, run_single
from gnssatt.vector_phase.phase_model import AntennaMount, ReceiverState
from gnssatt.vector_phase.rate_bank import bank_solve
from gnssatt.vector_phase.solution import Solution

__all__ = ["EkfOptions", "ekf_solve"]


def ekf_solve(obs, mount: AntennaMount, initial: ReceiverState, options: EkfOptions | None = None,
              progress=None) -> Solution:
    """Solution of the EKF over PhaseObservations obs from the known initial state (clock datum 0 at t0); with
    options.rate_hypotheses_step_deg_s > 0 a bank of filters from several initial rates (rate_bank)."""
    opt = options or EkfOptions()
    if opt.rate_hypotheses_step_deg_s > 0:
        return bank_solve(obs, mount, initial, opt, progress)
    return run_single(obs, mount, initial, opt, progress)
