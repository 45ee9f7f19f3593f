"""One extended Kalman filter of position, clock and three-axis attitude from one antenna's carrier phase (seed 003
eq. 35, 44-45), from a known initial state; `gnssatt.vector_phase.ekf.ekf_solve` runs it alone or as a bank of
start hypotheses (gnssatt.vector_phase.rate_bank).

State (error state, 10 + n_sv): position_ecef_m (3, moved by the set's velocity where one is given, plus a random
walk q_position), clock_cyc (1, white: re-estimated
every epoch, the datum b(t0) = 0 of eq. 41), body rotation eps (3) and body angular rate omega (3, rad/s, a
random walk q_rate: white angular acceleration), and one float phase offset N_s per satellite column (constant
over an arc; reset at a new arc). The nominal attitude is propagated by omega dt and corrected by eps after each
update; the body-frame error eps turns with the body, eps(t + dt) = A(omega dt)^T eps(t) + omega_error dt. With the initial state known (its sigmas tiny) the first update gives every N_s to the phase noise: the
filter's form of referencing the phase changes of eq. 44 to t0. The update is iterated (Gauss-Newton, Bell and
Cathey 1993) because delta_s is strongly non-linear in the attitude.
Per-epoch observability is that of the epoch's snapshot (observability.analyse): the filter keeps a finite
variance in an unobservable direction (it grows with q_rate), but the products report its angles undetermined.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.vector_phase.batch import ArcReferences, epoch_geometry
from gnssatt.vector_phase.observability import analyse
from gnssatt.vector_phase.phase_model import AntennaMount, ReceiverState, jacobian, model_cycles, nominal_scale
from gnssatt.vector_phase.rotation import error_rotvec_body, perturb_body, rotation_matrix
from gnssatt.vector_phase.solution import Solution

__all__ = ["EkfOptions", "run_single"]

N_CORE = 10


@dataclass(frozen=True)
class EkfOptions:
    """Noise model. sigma_position0_m / sigma_attitude0_deg / sigma_rate0_deg_s: the initial state's sigmas;
    q_position_m2_s: position random walk (default 0.0: a static antenna; a random walk on a static antenna makes
    the filter optimistic, docs/vector_phase.md "Consistency"); sigma_clock_cyc: per-epoch clock sigma
    (white); q_rate_rad2_s3: angular-rate random walk (white angular acceleration); iterations: Gauss-Newton
    steps per update; min_sats: fewer satellites with an established offset skip the update.
    Start hypotheses (gnssatt.vector_phase.rate_bank): rate_hypotheses_step_deg_s > 0 runs a bank of filters from
    the initial rates {-step, 0, +step}^3 (body axes, each with sigma step / 2) beside the one from zero rate;
    hypothesis_prune_cost: a member whose accumulated cost (-2 log likelihood) exceeds the best's by more is
    dropped; hypothesis_merge_sigma: a member within this Mahalanobis distance (attitude and rate) of a better one
    or of the single filter is dropped; hypothesis_max_epochs: the bank's longest run before the best member is kept
    (ambiguous); hypothesis_mixture_covariance: while several members live, report the Gaussian sum's covariance
    about the kept member (weighted member covariances plus the spread of their states) instead of its own."""

    sigma_position0_m: float = 1e-3
    sigma_attitude0_deg: float = 0.01
    sigma_rate0_deg_s: float = 1.0
    q_position_m2_s: float = 0.0
    sigma_clock_cyc: float = 1e4
    q_rate_rad2_s3: float = 1e-5
    iterations: int = 4
    min_sats: int = 7
    sigma_offset0_cyc: float = 1e4
    rate_hypotheses_step_deg_s: float = 1.0
    hypothesis_prune_cost: float = 13.8
    hypothesis_merge_sigma: float = 1.0
    hypothesis_max_epochs: int = 300
    hypothesis_mixture_covariance: bool = True


class _Filter:
    def __init__(self, n_sv: int, initial: ReceiverState, opt: EkfOptions):
        self.n = N_CORE + n_sv
        self.r = np.asarray(initial.position_ecef_m, float).copy()
        self.b = 0.0
        self.R = np.asarray(initial.R_body_from_ecef, float).copy()
        self.w = np.zeros(3)
        self.N = np.zeros(n_sv)
        d = np.r_[[opt.sigma_position0_m ** 2] * 3, 0.0, [np.radians(opt.sigma_attitude0_deg) ** 2] * 3,
                  [np.radians(opt.sigma_rate0_deg_s) ** 2] * 3, [opt.sigma_offset0_cyc ** 2] * n_sv]
        self.P = np.diag(d)
        self.opt = opt
        self.cost = 0.0            # -2 log likelihood of the phases so far (innovations), for rate_bank

    def predict(self, dt: float, new_arcs: np.ndarray, velocity_ecef_m_s=None) -> None:
        """x(t + dt): attitude turned by omega dt; position moved by the known velocity (if any); clock
        re-initialised; new arcs' offsets unknown."""
        o = self.opt
        self.R = perturb_body(self.R, self.w * dt)
        if velocity_ecef_m_s is not None and np.all(np.isfinite(velocity_ecef_m_s)):
            self.r = self.r + np.asarray(velocity_ecef_m_s, float) * dt
        F = np.eye(self.n)
        F[4:7, 4:7] = rotation_matrix(self.w * dt).T              # body-frame error turns with the body
        F[4:7, 7:10] = np.eye(3) * dt
        Q = np.zeros((self.n, self.n))
        Q[:3, :3] = np.eye(3) * o.q_position_m2_s * dt
        Q[4:7, 4:7] = np.eye(3) * o.q_rate_rad2_s3 * dt ** 3 / 3
        Q[4:7, 7:10] = Q[7:10, 4:7] = np.eye(3) * o.q_rate_rad2_s3 * dt ** 2 / 2
        Q[7:10, 7:10] = np.eye(3) * o.q_rate_rad2_s3 * dt
        self.P = F @ self.P @ F.T + Q
        self.P[3, :] = self.P[:, 3] = 0.0
        self.P[3, 3] = o.sigma_clock_cyc ** 2
        for c in new_arcs:
            i = N_CORE + c
            self.P[i, :] = self.P[:, i] = 0.0
            self.P[i, i] = o.sigma_offset0_cyc ** 2

    def state(self) -> ReceiverState:
        return ReceiverState(self.r, self.b, self.R)

    def update(self, obs, k: int, cols: np.ndarray, mount: AntennaMount, refs: ArcReferences):
        """Iterated measurement update with the phases of epoch k (columns cols): (J of the core, residuals)."""
        geom = epoch_geometry(obs, k, cols)
        z = obs.phase_cyc[k, cols]
        Rm = np.eye(len(cols)) * obs.sigma_phase_cyc ** 2
        prior = (self.r.copy(), self.b, self.R.copy(), self.w.copy(), self.N.copy())
        P0 = self.P
        idx = N_CORE + cols
        for _ in range(self.opt.iterations):
            model, delta = model_cycles(self.state(), geom, mount, refs.delta_rad[cols])
            J = jacobian(self.state(), geom, mount)
            H = np.zeros((len(cols), self.n))
            H[:, :7] = J
            H[np.arange(len(cols)), idx] = 1.0
            dx_prior = np.r_[prior[0] - self.r, prior[1] - self.b, error_rotvec_body(prior[2], self.R),
                             prior[3] - self.w, prior[4] - self.N]
            S = H @ P0 @ H.T + Rm
            K = np.linalg.solve(S, H @ P0).T
            nu = z - model - self.N[cols] - H @ dx_prior              # innovation, linearised at the iterate
            dx = dx_prior + K @ nu
            self.r, self.b = self.r + dx[:3], self.b + dx[3]
            self.R = perturb_body(self.R, dx[4:7])
            self.w, self.N = self.w + dx[7:10], self.N + dx[N_CORE:]
        model, delta = model_cycles(self.state(), geom, mount, refs.delta_rad[cols])
        refs.delta_rad[cols] = delta
        self.cost += float(nu @ np.linalg.solve(S, nu)) + float(np.linalg.slogdet(S)[1])
        IKH = np.eye(self.n) - K @ H
        self.P = IKH @ P0 @ IKH.T + K @ Rm @ K.T                       # Joseph form
        return jacobian(self.state(), geom, mount), z - model - self.N[cols]


class _Run:
    """One filter over PhaseObservations obs: its arc references and the Solution rows it writes (row k - row0 of
    sol for epoch k; rate_bank gives each start hypothesis rows for its window only)."""

    def __init__(self, obs, mount: AntennaMount, initial: ReceiverState, opt: EkfOptions, sol: Solution,
                 rate0_rad_s=None):
        self.obs, self.mount, self.opt, self.sol, self.row0, self.label = obs, mount, opt, sol, 0, ""
        self.f = _Filter(obs.phase_cyc.shape[1], initial, opt)
        if rate0_rad_s is not None:
            self.f.w = np.asarray(rate0_rad_s, float).copy()
        self.refs = ArcReferences(obs.phase_cyc.shape[1])
        self.tracked = np.isfinite(obs.phase_cyc)
        self.established = np.zeros(obs.phase_cyc.shape[1], bool)

    def step(self, k: int) -> None:
        """Predict to epoch k (k > 0), update with its phases, store row k."""
        obs, f, opt, tracked = self.obs, self.f, self.opt, self.tracked
        new = tracked[k] & (obs.arc_start[k] | ~self.established) if k else tracked[k]
        if k:
            vel = obs.velocity_ecef_m_s
            v = None if vel is None else 0.5 * (vel[k - 1] + vel[k])          # trapezoid over the interval
            f.predict(obs.t_gps_s[k] - obs.t_gps_s[k - 1], np.flatnonzero(new), v)
        cols, newc = np.flatnonzero(tracked[k]), np.flatnonzero(new)
        if len(newc):
            self.refs.start(obs, k, newc, f.state(), self.mount)
        self.established |= tracked[k]
        n_known = int(np.sum(tracked[k] & ~new)) if k else len(cols)
        i, sol = k - self.row0, self.sol
        if n_known < opt.min_sats:
            sol.observability[i] = f"{n_known} satellites with an established offset (need {opt.min_sats})"
            if len(cols):
                f.update(obs, k, cols, self.mount, self.refs)
            return
        J, res = f.update(obs, k, cols, self.mount, self.refs)
        ob = analyse(J, np.full(len(cols), obs.sigma_phase_cyc), self.mount.R_ant_from_body,
                     nominal_scale(self.mount))
        sol.position_ecef_m[i], sol.clock_cyc[i], sol.R_body_from_ecef[i] = f.r, f.b, f.R
        sol.P[i] = f.P[:7, :7]
        sol.rank[i], sol.condition[i], sol.null_rotation_body[i] = ob.rank, ob.condition, ob.null_rotation_body
        sol.observability[i], sol.n_sats[i], sol.valid[i] = ob.description, len(cols), True
        sol.residuals_cyc[i, cols] = res


def run_single(obs, mount: AntennaMount, initial: ReceiverState, opt: EkfOptions, progress=None) -> Solution:
    """Solution of one filter over PhaseObservations obs from the known initial state (clock datum 0 at t0)."""
    run = _Run(obs, mount, initial, opt, Solution.empty(obs.t_gps_s, obs.sats, "ekf"))
    for k in range(len(obs.t_gps_s)):
        run.step(k)
        if progress is not None and k % 50 == 0:
            progress(k / len(obs.t_gps_s))
    return run.sol
