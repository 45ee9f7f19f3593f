"""gnssatt.attitude.qc_kernels (numba) against the library's readable reference (gnssatt.attitude.reference_qc,
reference_noise, reference_propagate, reference_records, reference_states): each test runs the reference and the
kernel (through tests/attitude/_kernel_calls.py) on random epochs with events (clock jumps, slips, half cycles,
gaps, missing data) and compares every output: flags, reasons and counts exactly, floats within tolerances stated
in physical units (the reason beside each)."""
from __future__ import annotations

import numpy as np

from gnssatt.attitude import reference_propagate as RP, reference_qc as RQ, reference_records as RR
from gnssatt.attitude.reference_noise import (NoiseEstimates, NoiseSettings, cn0_variance_factor, cn0_weights,
                                              update_cn0_growth, update_white_noise)
from gnssatt.attitude.reference_states import AmbiguityStates
from gnssatt.attitude.reference_update import UsedRows
from tests.attitude._kernel_calls import (call_clip_pair, call_epoch_geometry, call_grow_square, call_growth_weights,
                                          call_propagate_dynamic, call_propagate_kinematic, call_qc_epoch,
                                          call_record_epoch, call_reset_white_clocks, call_take_square,
                                          call_td_checks, close, same)

DEG = np.pi / 180.0
LAM = np.array([0.19029, 0.24421])
LIMITS = RQ.QcLimits(el_mask_ant_rad=5.0 * DEG, clock_jump_m=0.5e-3 * 299792458.0 * 0.5, td_max_dt_s=3.0,
                     td_code_m=5.0, td_phase_cyc=0.5, max_gap_s=10.0, wavelength_m=LAM)
NOISE = NoiseSettings(memory_epochs=300.0, min_epochs=10, min_var_ln_factor=0.05)
# Tolerances. Both sides do the same arithmetic in a different order / with different libraries (BLAS, SIMD
# loops): results agree to a few ulps of the magnitudes involved, and these bounds are far below what matters.
SD_M = 1e-9            # SDs and TDs (m): the phase residual scale, plus the rounding of the magnitudes (_sd_tol)
ANGLE_RAD = 1e-12      # elevations / azimuths (selections and copies; 1e-12 rad = 6e-11 deg)
REL = 1e-12            # relative, for covariances and moments from a few dozen operations of O(1) conditioning


def _spd(rng, n):
    A = rng.normal(size=(n, n))
    return A @ A.T + n * np.eye(n)


def _cov_err(P_k, P_ref):
    """max |P_k - P_ref| / (sigma_i sigma_j): the covariance error in units of the reference's sigmas."""
    d = np.sqrt(np.abs(np.diag(P_ref)))
    return np.max(np.abs(P_k - P_ref) / np.outer(d, d))


def test_propagation_equals_the_former_calls():
    """Dynamic, kinematic and clock-reset propagation against reference_propagate: states within 1e-12 of their
    magnitude (m, rad/s), P within 1e-12 of the sigmas (RK4 over a few sub-steps, O(1) conditioning)."""
    rng = np.random.default_rng(3)
    for _ in range(50):
        n_bl = int(rng.integers(1, 4))
        blk = 5
        n = 3 + blk * n_bl + int(rng.integers(0, 20))
        b_idx = 3 + blk * np.arange(n_bl)[:, None] + np.arange(3)[None, :]
        white = np.unique(np.concatenate([b_idx[:, 2] + 1, b_idx[:, 2] + 2]))
        x, P = rng.normal(size=n), _spd(rng, n)
        Qw, dt, var = _spd(rng, 3) * 1e-6, float(rng.uniform(0.1, 3.0)), float(rng.uniform(1, 1e6))
        x0, P0, Pbb, Pbw = RP.propagate_dynamic(x, P, b_idx, Qw, dt, 1.0, white, var)
        x1, P1, Pbb1, Pbw1 = call_propagate_dynamic(x, P, b_idx, Qw, dt, 1.0, white, var)
        close(x1, x0, rtol=REL, atol=REL * np.abs(x).max(), what="x dynamic")
        assert _cov_err(P1, P0) < REL
        close(np.broadcast_to(Pbb1, Pbb.shape), Pbb, atol=REL, what="Phi_bb")      # dimensionless, ~identity
        close(Pbw1, Pbw, atol=REL * dt, what="Phi_bw")                             # s, ~dt
        all_b = b_idx.ravel()
        x0, P0 = RP.propagate_kinematic(x, P, all_b, 1e-4 * dt, white, var)
        x1, P1 = call_propagate_kinematic(x, P, all_b, 1e-4 * dt, white, var)
        close(x1, x0, atol=REL, what="x kinematic")
        assert _cov_err(P1, P0) < REL
        assert np.abs(P0 - P).max() > 1e-6                     # something happened
        x2, P2 = call_reset_white_clocks(x, P, white, var)
        x3, P3 = RP.reset_white_clocks(x, P, white, var)
        close(x2, x3, atol=REL, what="x reset")
        assert _cov_err(P2, P3) < REL
        close(x2[white], 0.0, atol=1e-300, what="reset clocks")
        close(P2[np.ix_(white, white)], var * np.eye(white.size), rtol=REL, atol=REL * var, what="reset P")


def test_clip_pair_is_np_clip():
    rng = np.random.default_rng(4)
    a, b = rng.normal(size=(7, 3)) * 2, rng.normal(size=(7, 3)) * 2
    a[0, 0] = np.nan
    out = call_clip_pair(a, b)
    # clipped direction cosines: a clip selects, so any error would be a wrong branch (far above 1e-15)
    close(out[0], np.clip(a, -1, 1), atol=1e-15, what="a")
    close(out[1], np.clip(b, -1, 1), atol=1e-15, what="b")
    assert np.isnan(out[0, 0, 0])


def test_epoch_geometry_equals_the_numpy_products():
    """Lines of sight in the body frame and the predicted SD geometry b.u against numpy's products: direction
    cosines within 1e-13 (3-term dot products of unit vectors, 1e-13 rad), b.u within 1e-12 of |b| (m)."""
    rng = np.random.default_rng(11)
    for _ in range(3000):
        n_sat, n_bl = int(rng.integers(0, 100)), int(rng.integers(1, 4))
        u = rng.normal(size=(n_sat, 3))
        R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        bs = rng.normal(size=(n_bl + 1, 3))
        ia, ib = np.zeros(n_bl, int), np.arange(1, n_bl + 1)
        bs_a_T, bs_b_T = bs[ia].T, bs[ib].T            # Fortran order, as run_filter passes them
        x = rng.normal(size=5 + 6 * n_bl)
        b_idx = 3 + 6 * np.arange(n_bl)[:, None] + np.arange(3)[None, :]
        los, ub, asn = call_epoch_geometry(u, R, bs_a_T, bs_b_T, x, b_idx)
        scale = max(1.0, float(np.abs(u).max(initial=0.0)))
        los_ref = u @ R.T
        close(los, los_ref, atol=1e-13 * scale, what="los")
        close(ub, x[b_idx.ravel()].reshape(n_bl, 3) @ u.T, atol=1e-12 * scale * np.abs(x).max(), what="ub")
        close(asn[0], np.clip(los_ref @ bs[ia].T, -1, 1), atol=1e-13 * scale * np.abs(bs).max(), what="asn a")
        close(asn[1], np.clip(los_ref @ bs[ib].T, -1, 1), atol=1e-13 * scale * np.abs(bs).max(), what="asn b")


def _epoch(rng, n_bl, n_sat, n_sig, clk_true, amb_m, ub):
    """Random observations of one epoch (the SdBlock slice and the state inputs of the QC)."""
    sh = (n_bl, n_sat, n_sig)
    pa = rng.random(n_bl) < 0.95
    gv = rng.random(n_sat) < 0.9
    cfac = 1.0 - rng.uniform(-800, 800, n_sat) / 299792458.0
    geo = -ub                                   # SD = -u.b + clock + noise (+ ambiguity)
    sdc = geo[:, :, None] + cfac[None, :, None] * clk_true[:, None, None] + rng.normal(size=sh) * 0.3
    sdp = geo[:, :, None] + cfac[None, :, None] * clk_true[:, None, None] + rng.normal(size=sh) * 0.003 \
        + amb_m
    sdc[rng.random(sh) < 0.08] = np.nan
    sdp[rng.random(sh) < 0.08] = np.nan
    avail_c = np.isfinite(sdc) & pa[:, None, None] & gv[None, :, None]
    avail_p = np.isfinite(sdp) & avail_c
    reason0 = np.where(avail_c, 0, 8)
    reason0 = np.where((reason0 == 0) & (rng.random((1, n_sat, 1)) < 0.1), 1, reason0)
    lli = np.where(rng.random(sh) < 0.04, rng.integers(1, 4, sh), 0).astype(np.int8)
    cn0 = rng.uniform(28, 52, sh)
    sd = RQ.SdEpoch(sdc, sdp, avail_p, lli, rng.random(sh) < 0.1, rng.random(sh) < 0.1, reason0, cfac, pa)
    return sd, avail_c, cn0


def _events(rng, sd, amb_m):
    """Slips without LLI, a clock jump applied to code only, code outliers."""
    n_bl, n_sat, n_sig = sd.sdc_m.shape
    if rng.random() < 0.1:
        sd.sdp_m[rng.integers(n_bl), rng.integers(n_sat), rng.integers(n_sig)] += 0.37
    if rng.random() < 0.02:
        amb_m[int(rng.integers(n_bl)), :, 0] += 10000 * LAM[0]
    if rng.random() < 0.1:
        sd.sdc_m[rng.integers(n_bl), rng.integers(n_sat), rng.integers(n_sig)] += 20.0


def _sd_tol(*arrays) -> float:
    """SD_M plus 16 ulps of the largest magnitude involved (SDs carry the receiver clock, up to ~1e6 m here after
    the simulated clock jumps: 1 ulp ~ 1e-10 m)."""
    big = max(float(np.nanmax(np.abs(a), initial=0.0)) for a in arrays)
    return SD_M + 16 * np.finfo(float).eps * big


def _compare_qc(qc_k, chk, ref: RQ.QcEpoch, do_td):
    """Kernel outputs against the reference epoch: flags / reasons / counts exactly, floats within tolerance."""
    close(qc_k["el_w_rad"], ref.el_w_rad, atol=ANGLE_RAD, what="el_w")
    close(qc_k["el_ant_rad"], ref.el_ant_rad, atol=ANGLE_RAD, what="el_ant")
    close(qc_k["az_ant_rad"], ref.az_ant_rad, atol=ANGLE_RAD, what="az_ant")
    for name in ("reason", "use_c", "use_p", "slip"):
        same(qc_k[name], getattr(ref, name), name)
    tol = _sd_tol(ref.sdc_c_m, ref.sdp_c_m, ref.clock.clock_m, ref.clock.predicted_m)
    close(qc_k["sdc_c_m"], ref.sdc_c_m, atol=tol, what="sdc_c")
    close(qc_k["sdp_c_m"], ref.sdp_c_m, atol=tol, what="sdp_c")
    close(qc_k["td"].phase_m, ref.td.phase_m, atol=tol, what="td_p")
    close(qc_k["clock_m"], ref.clock.clock_m, atol=tol, what="clock")
    close(qc_k["predicted_m"], ref.clock.predicted_m, atol=tol, what="clock prediction")
    same(qc_k["jump"], ref.clock.jump, "jump")
    assert qc_k["n_jump"] == ref.clock.jump.sum()
    if do_td:
        close(qc_k["td"].code_m, ref.td.code_m, atol=tol, what="td_c")
        same(qc_k["td"].code_ok, ref.td.code_ok, "td_c_ok")
        same(qc_k["td"].phase_ok, ref.td.phase_ok, "td_p_ok")
        close(qc_k["td"].median_code_m, ref.td.median_code_m, atol=tol, what="median td_c")
        close(qc_k["td"].median_phase_m, ref.td.median_phase_m, atol=tol, what="median td_p")
        assert qc_k["n_common_jumps"] == ref.n_common_jumps
    for name in ("ev_td", "ev_lli", "drop", "need"):
        same(chk[name], getattr(ref, name), name)
    assert chk["n_gap"] == ref.n_gap
    assert (chk["n_td"], chk["n_lli"], chk["n_drop"], chk["n_need"]) == (
        ref.ev_td.sum(), ref.ev_lli.sum(), ref.drop.sum(), ref.need.sum())


def _compare_noise(est_k: NoiseEstimates, est_ref: NoiseEstimates):
    """The estimators' states: exponential means of O(1) samples (relative 1e-12 after 400 epochs: the means
    forget errors at the rate of their memory), gamma (dimensionless exponent) within 1e-9, variances relative."""
    close(est_k.moments, est_ref.moments, rtol=REL, atol=REL, what="moments")
    close(est_k.gamma, est_ref.gamma, atol=1e-9, what="gamma")
    close(est_k.var_code_m2, est_ref.var_code_m2, rtol=1e-9, what="white code variance (m^2)")
    close(est_k.var_phase_m2, est_ref.var_phase_m2, rtol=1e-9, what="white phase variance (m^2)")
    same(est_k.n_growth.astype(np.int64), est_ref.n_growth.astype(np.int64), "n_growth")
    same(est_k.n_white.astype(np.int64), est_ref.n_white.astype(np.int64), "n_white")


def _count(seen, qc_k, chk):
    for key, val in (("jump", qc_k["n_jump"]), ("common", qc_k["n_common_jumps"]), ("ev_td", chk["n_td"]),
                     ("ev_lli", chk["n_lli"]), ("gap", chk["n_gap"]), ("drop", chk["n_drop"]),
                     ("need", chk["n_need"])):
        seen[key] += val
    for code, key in ((6, "half"), (2, "reason2"), (4, "reason4"), (10, "reason10")):
        seen[key] += int(np.sum(qc_k["reason"] == code))


def test_qc_epoch_and_td_checks_equal_the_numpy_qc_over_many_epochs():
    """400 epochs of qc_epoch + growth_weights + td_checks against reference_qc.qc_epoch and reference_noise,
    each side carrying its own clock and noise state from epoch to epoch."""
    rng = np.random.default_rng(5)
    n_bl, n_sig, n_sat = 2, 2, 12
    est_ref = NoiseEstimates.initial(n_sig, 0.09, 1e-5)
    est_k = est_ref.copy()
    clk_ref = RQ.ClockState(np.full(n_bl, np.nan), np.zeros(n_bl), np.zeros(n_bl))
    clk_k = clk_ref
    seen = dict(common=0, jump=0, ev_td=0, ev_lli=0, gap=0, drop=0, need=0, half=0, reason2=0, reason4=0, reason10=0)
    prev_sdc = np.full((n_bl, n_sat, n_sig), np.nan)
    prev_sdp = prev_sdc.copy()
    prev_ub = rng.normal(size=(n_bl, n_sat))
    clk_true = rng.normal(size=n_bl) * 1e3
    amb_m = rng.integers(-50, 50, (n_bl, n_sat, n_sig)) * LAM
    t = 0.0
    for k in range(400):
        dt = 1.0 if rng.random() < 0.95 else float(rng.choice([0.5, 5.0]))
        t += dt
        clk_true = clk_true + rng.normal(size=n_bl) * 3.0
        if rng.random() < 0.03:
            clk_true[int(rng.integers(n_bl))] += 1e5                    # a clock jump
        ub = prev_ub + rng.normal(size=(n_bl, n_sat)) * 0.01
        sd, avail_c, cn0 = _epoch(rng, n_bl, n_sat, n_sig, clk_true, amb_m, ub)
        _events(rng, sd, amb_m)
        asn = np.arcsin(np.clip(rng.normal(size=(2, n_sat, n_bl)), -1, 1))
        asn[0, 0, 0] = np.nan
        view = RQ.AntennaView(asn[0], asn[1], rng.uniform(-np.pi, np.pi, n_sat), bool(rng.random() < 0.7),
                              rng.random(n_bl) < 0.6, bool(rng.random() < 0.3))
        consecutive = k > 0 and dt <= LIMITS.td_max_dt_s
        prev = RQ.PreviousEpoch(prev_sdc, prev_sdp, prev_ub, consecutive, consecutive)
        amb_index = np.where(rng.random((n_bl, n_sat, n_sig)) < 0.6, 20 + np.arange(n_bl * n_sat * n_sig).reshape(
            n_bl, n_sat, n_sig), -1)
        book = RQ.AmbiguityBook(amb_index, t - rng.uniform(0, 15, n_bl * n_sat * n_sig), 20)
        lw = np.log(cn0_variance_factor(cn0))
        # the reference: QC, with the noise estimators on its triple differences
        ref = RQ.qc_epoch(sd, view, ub, prev, clk_ref, book, t, LIMITS)
        clk_ref = ref.clock_state
        if prev.do_td:
            update_cn0_growth(ref.td, lw, LAM, est_ref, NOISE)
            update_white_noise(ref.td, cn0_weights(est_ref.gamma, lw), est_ref, NOISE)
        # the kernels, as run_filter calls them
        qc_k = call_qc_epoch(sd, view, ub, prev, clk_k, t, LIMITS)
        clk_k = qc_k["clock_state"]
        wfac = call_growth_weights(prev.do_td, qc_k["td"], lw, LAM, est_k, NOISE)
        chk = call_td_checks(qc_k, wfac, est_k, NOISE, sd, prev, book, t, LIMITS, noise_on=True)
        _compare_qc(qc_k, chk, ref, prev.do_td)
        close(clk_k.as_array(), clk_ref.as_array(), atol=_sd_tol(clk_ref.clock_m), what="clock state (m, s, m/s)")
        if prev.do_td:
            # C/N0 weights exp(gamma ln factor): relative, as gamma (1e-9) x ln factor (<= 2.8)
            close(wfac, cn0_weights(est_ref.gamma, lw), rtol=3e-9, what="C/N0 weights")
        _compare_noise(est_k, est_ref)
        _count(seen, qc_k, chk)
        prev_sdc = np.where(avail_c, qc_k["sdc_c_m"], np.nan)
        prev_sdp = np.where(sd.avail_p, qc_k["sdp_c_m"], np.nan)
        prev_ub = ub
    assert all(v > 0 for v in seen.values()), str(seen)                     # every branch was exercised
    assert np.all(est_k.n_growth > NOISE.min_epochs)                       # the noise estimators ran
    assert np.any(np.abs(est_k.gamma - 1.0) > 1e-3)


def test_record_epoch_equals_the_former_records():
    """residuals.csv rows of record_epoch against reference_records: indices, kinds and reasons exactly; angles in
    deg within 1e-9 deg (a conversion), C/N0 and residuals (copies) within 1e-12 of their unit."""
    rng = np.random.default_rng(6)
    n_bl, n_sat, n_sig = 2, 9, 2
    sh = (n_bl, n_sat, n_sig)
    blocks = []
    buf = dict(ibuf=np.zeros((6, 4000), np.int64), fbuf=np.zeros((4, 4000)), pos=0, lookup=np.zeros((2,) + sh),
               prev_sdc=np.zeros(sh), prev_sdp=np.zeros(sh), prev_ub=np.zeros((n_bl, n_sat)))
    for k in range(60):
        avail_c = rng.random(sh) < 0.8
        avail_p = avail_c & (rng.random(sh) < 0.9)
        reason = np.where(rng.random(sh) < 0.7, 0, rng.integers(1, 11, sh))
        use_c = (reason == 0) & (rng.random(sh) < 0.9) & avail_c
        use_p = use_c & avail_p & (rng.random(sh) < 0.9)
        flags = RR.EpochFlags(avail_c, avail_p, use_c, use_p, reason)
        el_ant = rng.uniform(-1, 1.5, (n_bl, n_sat))
        az_ant = rng.uniform(-np.pi, np.pi, (n_bl, n_sat))
        if k % 5 == 0:
            el_ant[:], az_ant[:] = np.nan, np.nan
        cn0 = rng.uniform(25, 50, sh)
        sdc_c, sdp_c = rng.normal(size=sh), rng.normal(size=sh)
        b_out, u = rng.normal(size=(n_bl, 3)), rng.normal(size=(n_sat, 3))
        rows = UsedRows.from_masks(use_c, use_p)
        m = rows.n_code + rows.jp.size
        post = rng.normal(size=m) if m and k % 7 else np.zeros(0)
        block = RR.epoch_residual_rows(k, flags, el_ant, az_ant, cn0, post, rows)
        if block is not None:
            blocks.append(block)
        call_record_epoch(k, flags, el_ant, az_ant, cn0, post, rows, buf, sdc_c, sdp_c, b_out, u)
        prev_sdc, prev_sdp, prev_ub = RR.triple_difference_memory(sdc_c, sdp_c, flags, b_out, u)
        close(buf["prev_ub"], prev_ub, atol=1e-12 * np.abs(b_out).max() * np.abs(u).max(), what="prev_ub (m)")
        close(buf["prev_sdc"], prev_sdc, atol=1e-12, what="prev_sdc (m)")
        close(buf["prev_sdp"], prev_sdp, atol=1e-12, what="prev_sdp (m)")
    ref = RR.residual_table(blocks)
    pos, ib, fb = buf["pos"], buf["ibuf"], buf["fbuf"]
    got = {"epoch": ib[0, :pos], "bl": ib[1, :pos], "sat": ib[2, :pos], "sig": ib[3, :pos],
           "el_ant_deg": fb[0, :pos], "az_ant_deg": fb[1, :pos], "cn0_dbhz": fb[2, :pos],
           "kind": ib[4, :pos], "residual_m": fb[3, :pos], "reason": ib[5, :pos]}
    assert pos == ref["epoch"].size > 1000
    for key in ("epoch", "bl", "sat", "sig", "kind", "reason"):
        same(got[key], ref[key], key)
    close(got["el_ant_deg"], ref["el_ant_deg"], atol=1e-9, what="el_ant_deg")
    close(got["az_ant_deg"], ref["az_ant_deg"], atol=1e-9, what="az_ant_deg")
    close(got["cn0_dbhz"], ref["cn0_dbhz"], atol=1e-12, what="cn0_dbhz")
    close(got["residual_m"], ref["residual_m"], atol=1e-12, what="residual_m")
    assert np.isfinite(got["residual_m"]).sum() > 100


def test_take_and_grow_square_are_the_numpy_indexing():
    rng = np.random.default_rng(10)
    for n in (1, 5, 40):
        P = rng.normal(size=(n, n))
        keep = rng.random(n) < 0.6
        # copies of elements: within 1e-15 relative (any error would be a wrong element, O(1) off)
        close(call_take_square(P, np.flatnonzero(keep)), P[np.ix_(keep, keep)], rtol=1e-15, what="take")
        ref = np.zeros((n + 3, n + 3))
        ref[:n, :n] = P
        ref[np.arange(n, n + 3), np.arange(n, n + 3)] = 0.25
        close(call_grow_square(P, 3, 0.25), ref, rtol=1e-15, what="grow")


def _new_filter_state(n_bl, n_sat, n_sig):
    """The filter's state object (gnssatt.attitude.filter, which calls add_states / drop_states)."""
    from gnssatt.attitude.filter import _State
    return _State(n_bl, n_sat, n_sig, True, False)


def test_state_add_and_remove_equal_the_numpy_bookkeeping():
    """The filter's state (add_states / drop_states kernels) against reference_states.AmbiguityStates: index maps
    and keys exactly, x and P (copies of elements) within 1e-15 relative."""
    rng = np.random.default_rng(12)
    st = _new_filter_state(2, 9, 2)
    n0 = st.n
    A = rng.normal(size=(n0, n0))
    st.x, st.P = rng.normal(size=n0), A @ A.T
    ref = AmbiguityStates(st.x.copy(), st.P.copy(), st.n_fixed_part, (2, 9, 2))
    n_add = n_rm = 0
    for epoch in range(200):
        free = np.argwhere(st.amb_index < 0)
        if free.size and rng.random() < 0.6:
            keys = free[rng.random(len(free)) < 0.3].astype(np.int64)
            if keys.size:
                vals = rng.normal(size=len(keys)) * 100
                st.add_ambiguities(keys, vals, 30.0, float(epoch))
                ref.add(keys, vals, 30.0, float(epoch))
                n_add += 1
        if st.amb_key.shape[0] and rng.random() < 0.5:
            drop = st.n_fixed_part + np.flatnonzero(rng.random(st.amb_key.shape[0]) < 0.3)
            st.remove_ambiguities(drop, epoch)
            ref.remove(drop)
            n_rm += 1
        st.amb_fixed |= rng.random(st.amb_fixed.size) < 0.1
        ref.amb_fixed = st.amb_fixed.copy()
        for nm in ("amb_index", "amb_key", "amb_fixed", "amb_arc"):
            assert getattr(st, nm).dtype == getattr(ref, nm).dtype, nm
            same(getattr(st, nm), getattr(ref, nm), nm)
        for nm in ("x", "P", "amb_last_t"):
            assert getattr(st, nm).shape == getattr(ref, nm).shape, nm
            close(getattr(st, nm), getattr(ref, nm), rtol=1e-15, atol=1e-300, what=nm)
        assert [a[:3] for a in st.arcs] == [a[:3] for a in ref.arcs]
    assert n_add > 20 and n_rm > 20
