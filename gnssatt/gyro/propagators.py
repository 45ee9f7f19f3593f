"""Gyro fault detection by a bank of delayed attitude propagators (seed 002 sec. 3.2, Fig. 1 part a).

`GyroFdi.reference` chooses the propagators and what their residual is compared with:
- "independent" (the abstract's "bank of extended Kalman filters with different time delays"):
  propagator j (j = 1..N) is its own EKF (`IndependentFilters`), started once from the main filter; it
  integrates the gyro with its own drift estimate (eq. 9) and carries its own covariance, and takes a snapshot
  update only when D_j = j * delay_step_s has run since its last one. Every GPS epoch, before the main update,
  r_j = rotvec(q_gps (x) q_j^-1) - beta_theta_j is tested against S_j = H P_j H' + R (R: the snapshot's white
  covariance). Nothing of the main filter's later posteriors enters it, so a slow fault the main filter has
  absorbed is still in its residual.
- "filter" (default): propagator j starts from the main filter's posterior of D_j earlier, propagates with the
  gyro alone (drift estimate of that time) to now, with P_j that posterior carried through the filter's transitions and
  process noise, and is compared with the filter's posterior q_k|k of now: two estimates of one state from
  nested data, S_j = P_j - P_k|k (attitude block).
- "gps": the same delayed posteriors, compared with the snapshot q_gps, S_j = H P_j H' + R.

The gyro is flagged when |r_j| exceeds `threshold_sigma` sqrt(diag S_j) on some axis in
`persistence` consecutive epochs (the residues "grow above a tolerance level proportional to its theoretical
standard deviation"); the axis is the one of the largest normalised residual. In seed 002 Table 2 a longer
delay detects sooner; docs/BENCHMARKS.md ("GPS + gyro fusion") gives this bank's delays next to the paper's
and why they do not fall with the delay here.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnssatt.gyro.ekf import H_GPS, propagate_attitude, propagate_covariance, rotvec_of
from gnssatt.gyro.settings import GyroFdi

__all__ = ["PropagatorBank", "GyroEvent"]


@dataclass
class GyroEvent:
    """A gyro fault event: axis index, first/last flagged GPS epoch index, detecting propagator, statistic."""

    axis: int
    start: int
    end: int
    propagator: int
    statistic: float
    threshold: float
    first_by_propagator: dict = field(default_factory=dict)    # propagator j -> first epoch index it flagged


class PropagatorBank:
    """The bank over a run: keeps the posteriors, tests each epoch, collects events."""

    def __init__(self, settings: GyroFdi, gps_interval_s: float):
        self.s = settings
        self.step = max(1, int(round(settings.delay_step_s / gps_interval_s)))
        self.delays = [self.step * (j + 1) for j in range(settings.n_propagators)]
        self.post: dict = {}          # epoch index -> (q, bias, P, gyro sample index)
        self.trans: dict = {}         # epoch index -> (Phi, Q) of the interval ending at it
        self.counts = np.zeros(settings.n_propagators, int)
        self.clear = 0
        self.events: list[GyroEvent] = []
        self.open: GyroEvent | None = None
        self.rows: list = []          # (epoch, propagator, r/sigma x, y, z)
        self.sigma_rows: list = []    # (epoch, propagator, theoretical sigma x, y, z rad) of the same tests
        self.own = IndependentFilters(self.delays) if settings.reference == "independent" else None

    def transition(self, k: int, Phi, Q, rates=None, dts=None) -> None:
        """The filter's transition matrix and process noise of the interval ending at epoch k (and that interval's
        gyro samples, which the independent propagators integrate)."""
        self.trans[k] = (Phi, Q)
        if self.own is not None and rates is not None:
            self.own.advance(Phi, Q, rates, dts)

    def remember(self, k: int, q, bias, P, i_gyro: int, beta_theta=None) -> None:
        """The filter's posterior at epoch k (its prior when epoch k had no GPS update); the independent
        propagators start from the first one."""
        if self.own is not None:
            if not self.own.started:
                self.own.start(k, q, bias, np.zeros(3) if beta_theta is None else beta_theta, P)
            return
        self.post[k] = (q.copy(), bias.copy(), P.copy(), i_gyro)
        for old in [e for e in self.post if e < k - self.delays[-1] - 1]:
            self.post.pop(old, None)
            self.trans.pop(old, None)

    def test(self, k: int, q_ref, P_ref, rates, dts, i_gyro: int):
        """Test epoch k against q_ref: the filter's posterior (P_ref its 9x9 covariance) or the GPS snapshot (P_ref
        the snapshot's white 3x3 covariance), after `reference`; returns the new event or None."""
        z_max = np.full(len(self.delays), np.nan)
        flagged_axes = []
        for j, d in enumerate(self.delays):
            k0 = k - d
            if k0 not in self.post or any((e not in self.trans) for e in range(k0 + 1, k + 1)):
                self.counts[j] = 0
                continue
            q0, b0, P0, i0 = self.post[k0]
            qj = propagate_attitude(q0, b0, rates[i0:i_gyro], dts[i0:i_gyro])
            Phis = np.array([self.trans[e][0] for e in range(k0 + 1, k + 1)])
            Qs = np.array([self.trans[e][1] for e in range(k0 + 1, k + 1)])
            Pj = propagate_covariance(P0, Phis, Qs)
            r = rotvec_of(q_ref, qj)
            sig = np.sqrt(self._variance(Pj, P_ref))
            self._record(k, j, np.abs(r) / sig, sig, z_max, flagged_axes)
        return self._events(k, z_max, flagged_axes)

    def test_independent(self, k: int, q_gps, R_white):
        """Test epoch k's snapshot attitude q_gps (white covariance R_white) against every independent propagator's
        prediction, then update the propagators whose delay has run since their last update; new event or None."""
        zs, sigmas = self.own.normalised_residuals(q_gps, R_white)
        z_max = np.full(len(self.delays), np.nan)
        flagged_axes = []
        for j, zn in enumerate(zs):
            self._record(k, j, zn, sigmas[j], z_max, flagged_axes)
        self.own.update_due(k, q_gps, R_white)
        return self._events(k, z_max, flagged_axes)

    def _record(self, k: int, j: int, zn, sig, z_max, flagged_axes) -> None:
        """Propagator j's normalised residual zn (3,) and sigma at epoch k: rows, its largest axis into z_max, and
        its run of epochs over the threshold (counts; flagged_axes gets (z, axis, j) when over)."""
        self.rows.append((k, j + 1, *zn))
        self.sigma_rows.append((k, j + 1, *sig))
        z_max[j] = zn.max()
        if zn.max() > self.s.threshold_sigma:
            self.counts[j] += 1
            flagged_axes.append((zn.max(), int(np.argmax(zn)), j))
        else:
            self.counts[j] = 0

    def _variance(self, Pj, P_ref):
        """Per-axis variance of the residual without a fault (module docstring); floored at (1 urad)^2."""
        if self.s.reference == "gps":
            return np.diag(H_GPS @ Pj @ H_GPS.T + P_ref)
        return np.maximum(np.diag(Pj)[:3] - np.diag(P_ref)[:3], 1e-12)

    def _events(self, k, z_max, flagged_axes):
        detecting = [j for j in range(len(self.delays)) if self.counts[j] >= self.s.persistence]
        new = None
        if self.open is not None:
            for j in detecting:
                self.open.first_by_propagator.setdefault(j + 1, k)
            if detecting or (self.counts > 0).any():
                self.open.end = k
                self.clear = 0
            else:
                self.clear += 1
                if self.clear >= self.s.clear_after:
                    self.events.append(self.open)
                    self.open = None
        elif detecting:
            stat, axis, j = max(f for f in flagged_axes if f[2] in detecting)
            new = GyroEvent(axis, k, k, j + 1, float(stat), self.s.threshold_sigma,
                            {jj + 1: k for jj in detecting})
            self.open = new
            self.clear = 0
        return new

    def finish(self) -> list[GyroEvent]:
        if self.open is not None:
            self.events.append(self.open)
            self.open = None
        return self.events


class IndependentFilters:
    """Propagator j as its own EKF (seed 002 abstract: "a bank of extended Kalman filters with different time
    delays"): started once from the main filter, it integrates the gyro (eq. 9, its own drift estimate removed) and
    carries its own 9x9 covariance through the filter's transitions and process noise; it takes a GPS snapshot
    update (ekf.update) only when delay_j has run since its last one, so between its updates it is a pure gyro
    propagation of the state of up to delay_j ago, never reset from the main filter's posterior. Every GPS epoch
    its residual rotvec(q_gps (x) q_j^-1) - beta_theta_j is compared with sqrt(diag(H P_j H' + R))."""

    def __init__(self, delays_epochs: list[int]):
        self.delays = delays_epochs
        self.started = False
        self.q = self.bias = self.beta = self.P = None
        self.last: list[int] = []

    def start(self, k: int, q, bias, beta_theta, P) -> None:
        n = len(self.delays)
        self.q = [q.copy() for _ in range(n)]
        self.bias = [bias.copy() for _ in range(n)]
        self.beta = [beta_theta.copy() for _ in range(n)]
        self.P = [P.copy() for _ in range(n)]
        self.last = [k] * n
        self.started = True

    def advance(self, Phi, Q, rates, dts) -> None:
        """One GPS interval of gyro samples: attitude by eq. 9, P <- Phi P Phi' + Q (the main filter's Phi and Q:
        Phi depends on the drift estimate only through omega dt, < 1e-5 rad here), Gauss-Markov decays."""
        if not self.started:
            return
        f_w, f_t = Phi[3, 3], Phi[6, 6]          # exp(-span / tau) of the drift and of beta_theta
        for j in range(len(self.delays)):
            self.q[j] = propagate_attitude(self.q[j], self.bias[j], rates, dts)
            self.P[j] = Phi @ self.P[j] @ Phi.T + Q
            self.bias[j] = self.bias[j] * f_w
            self.beta[j] = self.beta[j] * f_t

    def normalised_residuals(self, q_gps, R_white) -> tuple[list, list]:
        """(|r_j| / sigma_j per propagator, sigma_j (3,) rad per propagator)."""
        out, sig = [], []
        for j in range(len(self.delays)):
            r = rotvec_of(q_gps, self.q[j]) - self.beta[j]
            sig.append(np.sqrt(np.diag(H_GPS @ self.P[j] @ H_GPS.T + R_white)))
            out.append(np.abs(r) / sig[-1])
        return out, sig

    def update_due(self, k: int, q_gps, R_white) -> None:
        from gnssatt.gyro.ekf import FilterState, update

        for j, d in enumerate(self.delays):
            if k - self.last[j] >= d:
                st, _, _ = update(FilterState(self.q[j], self.bias[j], self.beta[j], self.P[j]), q_gps, R_white)
                self.q[j], self.bias[j], self.beta[j], self.P[j] = st.q, st.bias, st.beta_theta, st.P
                self.last[j] = k
