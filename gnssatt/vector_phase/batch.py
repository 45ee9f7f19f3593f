"""Epoch-wise (snapshot) estimator of position, clock and three-axis attitude from phase changes (seed 003
eq. 44-45): at every epoch the >= 7 phase changes since the arc's reference epoch are solved by Gauss-Newton
for the seven unknowns, started from the previous epoch (the first from the known initial state).

Measurement of satellite s at epoch t (cycles): y_s = Psi_s(t) - Psi_s(t_a) + M_s(t_a; x(t_a)) = M_s(t; x(t))
+ n_s(t) - n_s(t_a), with M the model of eq. 35 without N (gnssatt.vector_phase.phase_model.model_cycles) and
t_a the arc's first epoch: the initial epoch t0 with the known initial state (b(t0) = 0 defines the clock
datum, eq. 41), or, for an arc starting later, that epoch's own solution (its variance J P J^T added to the
reference's). Weights: 1 / (sigma^2 + var(reference)). delta is tracked (unwrapped) from epoch to epoch.
Rank-deficient epochs (observability.analyse) are solved in the observable subspace (truncated SVD): the
unobservable direction keeps the previous epoch's value and gets no variance.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.vector_phase.observability import RANK_TOLERANCE, analyse
from gnssatt.vector_phase.phase_model import (AntennaMount, EpochGeometry, ReceiverState, jacobian, model_cycles,
                                              nominal_scale)
from gnssatt.vector_phase.rotation import perturb_body
from gnssatt.vector_phase.solution import Solution

__all__ = ["BatchOptions", "batch_solve", "ArcReferences", "epoch_geometry", "apply_increment"]


@dataclass(frozen=True)
class BatchOptions:
    """max_iterations: Gauss-Newton iterations per epoch; tolerance_cyc: stop when the update changes the
    model by less (cycles); min_sats: fewer usable satellites leave the epoch without a solution."""

    max_iterations: int = 8
    tolerance_cyc: float = 1e-6
    min_sats: int = 7


def epoch_geometry(obs, k: int, cols: np.ndarray) -> EpochGeometry:
    """EpochGeometry of epoch k for the satellite columns cols."""
    return EpochGeometry(obs.r_sat_ecef_m[k, cols], obs.x_sat_ecef[k, cols], obs.y_sat_ecef[k, cols])


def apply_increment(state: ReceiverState, dx: np.ndarray) -> ReceiverState:
    """The state moved by dx = (d position m, d clock cyc, body rotation rad)."""
    return ReceiverState(state.position_ecef_m + dx[:3], state.clock_cyc + dx[3],
                         perturb_body(state.R_body_from_ecef, dx[4:]))


class ArcReferences:
    """Per satellite column: the reference value Psi_s(t_a) - M_s(t_a) (cycles, i.e. N_s + noise), its variance,
    and the tracked (unwrapped) delta_s."""

    def __init__(self, n_sv: int):
        self.offset_cyc = np.full(n_sv, np.nan)
        self.var_cyc2 = np.full(n_sv, np.nan)
        self.delta_rad = np.full(n_sv, np.nan)

    def start(self, obs, k: int, cols: np.ndarray, state: ReceiverState, mount: AntennaMount, state_var=None):
        """Reference new arcs (columns cols) at epoch k on the state (its 7x7 covariance state_var, or exact)."""
        if len(cols) == 0:
            return
        geom = epoch_geometry(obs, k, cols)
        model, delta = model_cycles(state, geom, mount)
        self.offset_cyc[cols] = obs.phase_cyc[k, cols] - model
        extra = 0.0
        if state_var is not None:
            J = jacobian(state, geom, mount)
            extra = np.einsum("ij,jk,ik->i", J, state_var, J)
        self.var_cyc2[cols] = obs.sigma_phase_cyc ** 2 + extra
        self.delta_rad[cols] = delta


def _solve(J, r, w, scale, cond_tol=RANK_TOLERANCE):
    """(dx, P) of the weighted least squares J dx = r, truncated SVD on the column-scaled system (scale (7,):
    phase_model.nominal_scale)."""
    A = J * np.sqrt(w)[:, None]
    U, s, Vt = np.linalg.svd(A / scale, full_matrices=False)
    keep = s > cond_tol * s[0]
    inv = np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0)
    dx = (Vt.T * inv) @ (U.T @ (r * np.sqrt(w))) / scale
    P = ((Vt.T * inv ** 2) @ Vt) / np.outer(scale, scale)
    return dx, P


def _epoch(obs, k, cols, state, refs: ArcReferences, mount, opt: BatchOptions):
    """Gauss-Newton at epoch k: (state, P, J, weights, residuals, delta)."""
    geom = epoch_geometry(obs, k, cols)
    y = obs.phase_cyc[k, cols] - refs.offset_cyc[cols]
    w = 1.0 / (obs.sigma_phase_cyc ** 2 + refs.var_cyc2[cols])
    for _ in range(opt.max_iterations):
        model, delta = model_cycles(state, geom, mount, refs.delta_rad[cols])
        J = jacobian(state, geom, mount)
        dx, P = _solve(J, y - model, w, nominal_scale(mount))
        state = apply_increment(state, dx)
        if np.max(np.abs(J @ dx)) < opt.tolerance_cyc:
            break
    model, delta = model_cycles(state, geom, mount, refs.delta_rad[cols])
    J = jacobian(state, geom, mount)
    _, P = _solve(J, y - model, w, nominal_scale(mount))
    return state, P, J, w, y - model, delta


def batch_solve(obs, mount: AntennaMount, initial: ReceiverState, options: BatchOptions | None = None,
                progress=None) -> Solution:
    """Solution of the epoch-wise estimator. obs: PhaseObservations (gnssatt.vector_phase.scenario); initial:
    the known state at the first epoch (its clock_cyc is the datum, set to 0)."""
    opt = options or BatchOptions()
    n_ep, n_sv = obs.phase_cyc.shape
    sol = Solution.empty(obs.t_gps_s, obs.sats, "batch")
    refs = ArcReferences(n_sv)
    state = ReceiverState(np.asarray(initial.position_ecef_m, float), 0.0, np.asarray(initial.R_body_from_ecef))
    tracked = np.isfinite(obs.phase_cyc)
    refs.start(obs, 0, np.flatnonzero(tracked[0]), state, mount)
    P = None
    for k in range(n_ep):
        new = np.flatnonzero(tracked[k] & (obs.arc_start[k] | ~np.isfinite(refs.offset_cyc))) if k else []
        cols = np.flatnonzero(tracked[k] & np.isfinite(refs.offset_cyc))
        cols = np.setdiff1d(cols, new)
        if len(cols) < opt.min_sats:
            sol.observability[k] = f"{len(cols)} satellites with a phase reference (need {opt.min_sats})"
            refs.start(obs, k, np.asarray(new, int), state, mount, P)
            continue
        state, P, J, w, res, delta = _epoch(obs, k, cols, state, refs, mount, opt)
        refs.delta_rad[cols] = delta
        ob = analyse(J, 1.0 / np.sqrt(w), mount.R_ant_from_body, nominal_scale(mount))
        _store(sol, k, state, P, ob, cols, res)
        refs.start(obs, k, np.asarray(new, int), state, mount, P)
        if progress is not None and k % 50 == 0:
            progress(k / n_ep)
    return sol


def _store(sol: Solution, k: int, state: ReceiverState, P, ob, cols, res) -> None:
    sol.position_ecef_m[k] = state.position_ecef_m
    sol.clock_cyc[k] = state.clock_cyc
    sol.R_body_from_ecef[k] = state.R_body_from_ecef
    sol.P[k] = P
    sol.rank[k] = ob.rank
    sol.condition[k] = ob.condition
    sol.null_rotation_body[k] = ob.null_rotation_body
    sol.observability[k] = ob.description
    sol.n_sats[k] = len(cols)
    sol.residuals_cyc[k, cols] = res
    sol.valid[k] = True
