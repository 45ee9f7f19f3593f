"""One fusion run over a pass (seed 002 Fig. 1): per GPS epoch, propagate with the gyro (ekf.propagate), test the
delayed propagators (propagators), resolve the integers and run the exclusion bank (snapshot, exclusion_bank),
then update the EKF with the chosen snapshot attitude (ekf.update). Between GPS epochs the attitude is output at
the gyro rate; without a GPS update it is the gyro's alone (source "gyro"), else "fused".
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnssatt.gnss import rotations as rot
from gnssatt.gnss.frames import R_ecef_from_gcrf, R_orbital_from_ecef
from gnssatt.gyro.ekf import FilterState, propagate, update
from gnssatt.gyro.exclusion_bank import run_bank
from gnssatt.gyro.gps_data import GpsData, epoch_phases
from gnssatt.gyro.gyro_csv import GyroLog
from gnssatt.gyro.propagators import PropagatorBank
from gnssatt.gyro.settings import FusionSettings
from gnssatt.gyro.snapshot import integer_corrected

__all__ = ["FusionRun", "run_fusion"]


@dataclass
class FusionRun:
    """Arrays of one run. Gyro rate: q_body_from_gcrf (n, 4), P_att (n, 3, 3), has (n,) bool, fused (n,) bool.
    GPS epochs: gps_q_body_from_ecef (n_ep, 4) NaN where none, gps_P (n_ep, 3, 3), n_sats, integer ratio, gps
    events (epoch, sat, antenna, J, threshold, isolated), bias (n_ep, 3) and its P, costs rows, gyro events."""

    gyro_time: object
    q_body_from_gcrf: np.ndarray
    P_att: np.ndarray
    has: np.ndarray
    fused: np.ndarray
    gps_q_body_from_ecef: np.ndarray
    gps_P: np.ndarray
    n_sats: np.ndarray
    ratio: np.ndarray
    bias: np.ndarray
    bias_P: np.ndarray
    innovation: np.ndarray
    gps_events: list = field(default_factory=list)
    costs: list = field(default_factory=list)
    gyro_events: list = field(default_factory=list)
    gyro_tests: list = field(default_factory=list)
    gyro_test_sigmas: list = field(default_factory=list)   # (epoch, propagator, sigma x, y, z rad) of gyro_tests
    integers: dict = field(default_factory=dict)      # epoch -> (reference sat, other sats, DD integers (m-1, n-1))
    P_post: np.ndarray | None = None                  # (n_ep, 9, 9) covariance after each GPS epoch
    gyro_rates: np.ndarray | None = None
    gyro_dts: np.ndarray | None = None
    update_times_s: list = field(default_factory=list)   # seconds after the first GPS epoch of each GPS update


def _init_state(fit, R_bi, s: FusionSettings) -> FilterState:
    P = np.zeros((9, 9))
    P[:3, :3] = fit.P_rad2
    P[3:6, 3:6] = np.eye(3) * s.gyro.initial_drift_sigma_rad_s ** 2
    P[6:9, 6:9] = fit.P_mp_rad2
    return FilterState(rot.dcm_to_quat(R_bi), np.zeros(3), np.zeros(3), P)


def _snapshot(gps, k, R_be_prior, P_prior, s: FusionSettings):
    ep, idx, refs = epoch_phases(gps, k, R_be_prior, s.gps)
    if len(idx) < s.gps.min_satellites:
        return None, ep, idx, float("nan")
    Z, ratio, N = integer_corrected(ep, gps.baselines_body_m, R_be_prior, P_prior, int(refs[0]))
    if Z is None:
        return None, ep, idx, ratio
    bank = run_bank(Z, ep, gps.baselines_body_m, R_be_prior, [int(r) for r in refs], s.gps_fdi.kappa,
                    s.gps_fdi.enabled, s.gps_fdi.threshold_model)
    bank.integers = (ep.sats[int(refs[0])], [ep.sats[j] for j in range(len(ep.sats)) if j != int(refs[0])], N)
    return bank, ep, idx, ratio


def run_fusion(gps: GpsData, gyro: GyroLog, s: FusionSettings, progress=None) -> FusionRun:
    """The whole pass; progress(fraction) is called every ~100 GPS epochs."""
    t_ref = gps.time[0]
    t_g = gyro.time - t_ref
    t_e = gps.time - t_ref
    rates = np.ascontiguousarray(gyro.rate_rad_s, dtype=np.float64)
    dts = np.diff(t_g, prepend=t_g[0] - (t_g[1] - t_g[0] if len(t_g) > 1 else 0.1))
    n, n_ep = len(t_g), len(t_e)
    R_ei = R_ecef_from_gcrf(gps.time)                                   # (n_ep, 3, 3)
    R_orb = R_orbital_from_ecef(gps.r_platform_ecef_m, gps.v_platform_ecef_m_s)
    if s.initial_q_body_from_ecef is not None:
        R_orb[:] = rot.quat_to_dcm(np.asarray(s.initial_q_body_from_ecef, float))
    out_q = np.full((n, 4), np.nan)
    out_P = np.full((n, 3, 3), np.nan)
    fused = np.zeros(n, bool)
    run = FusionRun(gyro.time, out_q, out_P, np.zeros(n, bool), fused, np.full((n_ep, 4), np.nan),
                    np.full((n_ep, 3, 3), np.nan), np.zeros(n_ep, int), np.full(n_ep, np.nan),
                    np.full((n_ep, 3), np.nan), np.full((n_ep, 3, 3), np.nan), np.full((n_ep, 3), np.nan))
    run.P_post = np.full((n_ep, 9, 9), np.nan)
    dt_gps = float(np.median(np.diff(t_e))) if n_ep > 1 else 5.0
    bank_g = PropagatorBank(s.gyro_fdi, dt_gps)
    arw2 = s.gyro.arw_rad_sqrt_s ** 2
    state, i_prev, gm_cov = None, 0, np.eye(3) * 1e-8
    prior_P = np.eye(3) * np.radians(s.max_prior_angle_deg / 3.0) ** 2
    for k in range(n_ep):
        if progress is not None and k % 100 == 0:
            progress(k / n_ep)
        i_k = int(np.searchsorted(t_g, t_e[k] + 1e-6, side="right"))
        Phi = Qi = None
        if state is not None:
            seg = slice(i_prev, i_k)
            q, P, Phi, Qi = propagate(state.q, state.bias, state.P, rates[seg], dts[seg], arw2,
                                      s.gyro.drift_sigma_rad_s, s.gyro.drift_tau_s, gm_cov, s.gps.multipath_tau_s,
                                      out_q[seg], out_P[seg])
            bank_g.transition(k, Phi, Qi, rates[seg], dts[seg])
            span = float(dts[seg].sum())
            state = FilterState(q, state.bias * np.exp(-span / s.gyro.drift_tau_s),
                                state.beta_theta * np.exp(-span / s.gps.multipath_tau_s), P)
            R_be_prior = rot.quat_to_dcm(state.q) @ R_ei[k].T
            P_prior = P[:3, :3]          # the predicted attitude's; multipath is in the DD noise already
        else:
            R_be_prior, P_prior = R_orb[k], prior_P
        bank, ep, idx, ratio = _snapshot(gps, k, R_be_prior, P_prior, s)
        run.ratio[k] = ratio
        _record_gps(run, k, bank, ep, gps)
        if bank is None or bank.fit is None:
            if state is not None:
                bank_g.remember(k, state.q, state.bias, state.P, i_k)
                run.P_post[k] = state.P
            i_prev = i_k
            continue
        fit = bank.fit
        R_bi_gps = fit.R_body_from_ecef @ R_ei[k]
        q_gps = rot.dcm_to_quat(R_bi_gps)
        gm_cov = fit.P_mp_rad2
        R_white = fit.P_rad2 - fit.P_mp_rad2
        R_white = 0.5 * (R_white + R_white.T) + np.eye(3) * 1e-12
        if state is None:
            state = _init_state(fit, R_bi_gps, s)
            bank_g.remember(k, state.q, state.bias, state.P, i_k, state.beta_theta)
            i_prev = i_k
            continue
        if s.gyro_fdi.reference == "gps":
            _gyro_test(bank_g, state, k, q_gps, R_white, rates, dts, i_k, s)
        elif s.gyro_fdi.reference == "independent":
            _flag(state, bank_g.test_independent(k, q_gps, R_white), s)
        state, z, S = update(state, q_gps, R_white)
        if s.gyro_fdi.reference == "filter":
            _gyro_test(bank_g, state, k, state.q, state.P, rates, dts, i_k, s)
        run.innovation[k] = z / np.sqrt(np.diag(S))
        run.bias[k], run.bias_P[k] = state.bias, state.P[3:6, 3:6]
        bank_g.remember(k, state.q, state.bias, state.P, i_k)
        run.P_post[k] = state.P
        if i_k > 0:
            out_q[i_k - 1], out_P[i_k - 1] = state.q, state.P[:3, :3]
        run.update_times_s.append(float(t_e[k]))
        i_prev = i_k
    run.has[:] = np.isfinite(out_q).all(axis=1)
    if run.update_times_s:                 # fused while the last GPS update is at most 1.5 GPS intervals old
        u = np.asarray(run.update_times_s)
        j = np.searchsorted(u, t_g + 1e-6, side="right") - 1
        fused[:] = (j >= 0) & (t_g - u[np.maximum(j, 0)] <= 1.5 * dt_gps) & run.has
    run.gyro_rates, run.gyro_dts = rates, dts
    run.gyro_events = bank_g.finish()
    run.gyro_tests = bank_g.rows
    run.gyro_test_sigmas = bank_g.sigma_rows
    return run


def _gyro_test(bank_g, state, k, q_ref, P_ref, rates, dts, i_k, s: FusionSettings) -> None:
    """The propagator bank's test of epoch k; a new gyro fault event opens the drift's uncertainty on its axis."""
    _flag(state, bank_g.test(k, q_ref, P_ref, rates, dts, i_k), s)


def _flag(state, event, s: FusionSettings) -> None:
    """A new gyro fault event opens the drift's uncertainty on its axis."""
    if event is not None:
        a = 3 + event.axis
        state.P[a, a] += s.gyro_fdi.fault_drift_sigma_rad_s ** 2


def _record_gps(run: FusionRun, k: int, bank, ep, gps: GpsData) -> None:
    if bank is None:
        return
    for ref, excl, J, dof, thr in bank.costs:
        run.costs.append((k, ep.sats[ref], ep.sats[excl] if excl >= 0 else "", J, dof, thr))
    if bank.detected:
        sat = ep.sats[bank.excluded] if bank.excluded is not None else ""
        ant = gps.antennas[bank.antenna] if bank.antenna is not None else ""
        full = bank.costs[0]
        run.gps_events.append((k, sat, ant, full[2], full[4], bank.excluded is not None))
    if bank.fit is not None:
        run.gps_q_body_from_ecef[k] = rot.dcm_to_quat(bank.fit.R_body_from_ecef)
        run.gps_P[k] = bank.fit.P_rad2
        run.n_sats[k] = len(bank.fit.subset)
        run.integers[k] = bank.integers
