"""Fig. 2 box "propagation": the time update of the state and covariance from the previous epoch.

Implements: seed 000 sec. 2 eq. 2 (b' = omega x b by fixed-step RK4, omega a random walk, Table 1 sigma 0.03 deg/s
per tau 1 s; the differential clocks white noise, reset to 1 us each epoch); kinematic mode: the baselines a random
walk (sec. 4.1). P <- Phi P Phi^T + Q (standard EKF time update). With angular_acceleration_state, omega += alpha dt
first (gnssatt.attitude.angular_acceleration).
"""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.angular_acceleration import propagate_acceleration, sub_transition
from gnssatt.attitude.filter_state import EpochData, FilterRun
from gnssatt.attitude.qc_kernels import propagate_dynamic, propagate_kinematic, reset_white_clocks


def propagate(run: FilterRun, ep: EpochData) -> None:
    """x, P from the previous epoch to ep.t in place (first epoch: only the white-noise clock reset); dynamic mode
    with the smoother: the prior sub-state (omega, baselines) and the transition matrix are recorded."""
    st, k = run.st, ep.k
    if ep.prev_t is None:
        reset_white_clocks(st.x, st.P, st.white, run.var_clk)        # white-noise clocks: reset every epoch
        return
    dt = ep.t - ep.prev_t
    if not run.dynamic:
        propagate_kinematic(st.x, st.P, run.all_b_idx, run.q_b * dt, st.white, run.var_clk)
        return
    # b by RK4 rotation; P <- Phi P Phi^T + Q: the omega random walk's discrete noise and its effect on b over dt;
    # then the white-noise clocks are reset (gnssatt.attitude.qc_kernels)
    Qw = run.q_omega[k] if run.q_omega is not None else (run.adapter.q_rate(dt) if run.adapter is not None
                                                          else run.Qw_iso)       # (3, 3) rad^2/s^3
    if run.accel:        # omega += alpha dt first (gnssatt.attitude.angular_acceleration)
        propagate_acceleration(st.x, st.P, run.q_alpha if run.q_alpha_k is None else float(run.q_alpha_k[k]),
                               float(dt))
    Pbb, Pbw = propagate_dynamic(st.x, st.P, run.w_idx3, run.b_idx, Qw, float(dt), run.s.rk4_step_s, st.white,
                                 run.var_clk)
    if run.record:
        Phi = np.eye(run.n_sub)
        r0 = run.n_sub - 3 * run.n_bl
        for j in range(run.n_bl):
            Phi[r0 + 3 * j:r0 + 3 + 3 * j, r0 + 3 * j:r0 + 3 + 3 * j] = Pbb
            Phi[r0 + 3 * j:r0 + 3 + 3 * j, 0:3] = Pbw[j]
        run.sm_Phi[k] = sub_transition(Phi, float(dt)) if run.accel else Phi
        run.sm_xp[k], run.sm_Pp[k], run.sm_start[k], run.sm_dt[k] = st.x[run.sub_w_b], st.P[run.ix_sub], False, dt
