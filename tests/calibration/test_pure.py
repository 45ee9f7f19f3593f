"""Synthetic-data tests of the calibration's pure pieces: reference interpolation, body-frame averaging with an
honest sigma, generic binning, the linear PCV iteration, integer fixing and epoch-wise least squares."""
from __future__ import annotations

import numpy as np
import pytest

from gnssatt.calibration.baselines import (BatchSums, BaselineRow, baselines_document, baselines_table_csv,
                                          batch_sums, body_from_ecef, combine, gate_epochs)
from gnssatt.calibration.binning import BinSums, Grid2D, accumulate, finalize
from gnssatt.calibration.kinematic import epoch_lsq, fix_integers
from gnssatt.calibration.pcv import (FixedPhases, iterate_map, map_change_rms_mm, map_lookup, map_normal,
                                    residuals_m)
from gnssatt.calibration.reference import reference_at_epochs, slerp, uncovered_spans
from gnssatt.gnss.frames import R_gcrf_from_ecef
from gnssatt.gnss.io.reference_attitude import ReferenceAttitude
from gnssatt.gnss.rotations import (attitude_error_deg, dcm_to_quat, quat_from_rotvec, quat_multiply, quat_to_dcm)
from gnssatt.gnss.time import GpsTime

T0 = GpsTime.from_iso("2018-06-06T12:20:00")


# --- reference attitude -----------------------------------------------------------------------------

def _constant_rate(t_s, axis=(0.3, -0.5, 0.8), rate_rad_s=1e-3, q0=(0.9, 0.1, -0.3, 0.3)):
    q0 = np.asarray(q0) / np.linalg.norm(q0)
    e = np.asarray(axis) / np.linalg.norm(axis)
    return quat_multiply(quat_from_rotvec(np.outer(t_s * rate_rad_s, e)), np.broadcast_to(q0, (len(t_s), 4)))


def test_slerp_is_exact_for_a_constant_rate_and_takes_the_short_arc():
    t = np.array([0.0, 1.0])
    q = _constant_rate(t, rate_rad_s=0.2)
    mid = slerp(q[0], -q[1], 0.37)  # the sign of q1 must not matter
    truth = _constant_rate(np.array([0.37]), rate_rad_s=0.2)[0]
    assert attitude_error_deg(mid, truth) < 1e-10


def test_reference_interpolation_ecef_rows_and_gap_refusal():
    t_ref = np.arange(0.0, 100.0, 1.0)
    keep = (t_ref < 40) | (t_ref > 60)  # a 21 s gap
    q = _constant_rate(t_ref)
    ref = ReferenceAttitude(T0 + t_ref[keep], np.array(["ECEF"] * keep.sum()), q[keep], np.full(keep.sum(), np.nan))
    t = T0 + np.array([-0.5, 0.25, 10.5, 50.0, 70.75, 99.0, 99.5])
    out = reference_at_epochs(ref, t, max_gap_s=10.0)
    assert out.ok.tolist() == [False, True, True, False, True, True, False]
    truth = _constant_rate(np.array([0.25, 10.5, 70.75, 99.0]))
    assert np.all(attitude_error_deg(out.q_body_from_ecef[out.ok], truth) < 1e-9)
    assert np.all(np.isnan(out.q_body_from_ecef[~out.ok]))
    # a longer allowed gap bridges it
    assert reference_at_epochs(ref, t, max_gap_s=30.0).ok[3]
    assert uncovered_spans(t, out.ok)[0][0] == t[0].iso()


def test_reference_gcrf_rows_give_ecef_attitude_at_the_gnss_epochs():
    t_ref = np.arange(0.0, 30.0, 2.0)
    q_b_e = _constant_rate(t_ref)  # truth: ECEF -> body
    R_g_e = R_gcrf_from_ecef(T0 + t_ref)
    q_b_g = quat_multiply(q_b_e, dcm_to_quat(np.swapaxes(R_g_e, -1, -2)))  # body <- GCRF
    ref = ReferenceAttitude(T0 + t_ref, np.array(["GCRF"] * len(t_ref)), q_b_g, np.full(len(t_ref), np.nan))
    t = T0 + np.array([3.0, 17.5])
    out = reference_at_epochs(ref, t)
    truth = _constant_rate(np.array([3.0, 17.5]))
    # slerp in GCRF of a motion that is not a constant rate there (body rate + Earth rate about other axes):
    # alpha h^2 / 8 ~ 1e-6 deg for 2 s rows; 1e-5 deg = 0.04 arcsec, far below a star tracker's noise
    assert np.all(attitude_error_deg(out.q_body_from_ecef, truth) < 1e-5)
    assert np.allclose(out.R_body_from_ecef, quat_to_dcm(out.q_body_from_ecef))


# --- baselines --------------------------------------------------------------------------------------

def test_body_from_ecef_rotates_vectors_and_covariances():
    rng = np.random.default_rng(1)
    R = quat_to_dcm(quat_from_rotvec(rng.normal(size=(5, 3))))
    b_body = np.array([1.0, -0.07, 0.01])
    b_ecef = np.einsum("eji,j->ei", R, b_body)
    C = np.diag([1e-6, 4e-6, 9e-6])
    cov_ecef = np.einsum("eji,jk,ekl->eil", R, C, R)  # R^T C R
    got, cov = body_from_ecef(b_ecef, cov_ecef, R)
    assert np.allclose(got, b_body, atol=1e-15)
    assert np.allclose(cov, C, atol=1e-18)


def test_batch_means_sigma_is_honest_for_correlated_epochs():
    """AR(1) errors with a 60 s correlation time: the formal sigma is ~8x too small, batch means is right."""
    rng = np.random.default_rng(2)
    truth = np.array([1.04863, -0.07977, -0.00568])
    errs = []
    sig_batch, sig_formal = [], []
    for trial in range(40):
        sums = []
        for s in range(5):  # five sets of 1800 s
            n = 1800
            phi = np.exp(-1.0 / 60.0)
            e = np.zeros((n, 3))
            white = rng.normal(size=(n, 3)) * 0.004 * np.sqrt(1 - phi ** 2)
            e[0] = rng.normal(size=3) * 0.004
            for k in range(1, n):
                e[k] = phi * e[k - 1] + white[k]
            sums.append(batch_sums(np.arange(n, dtype=float), truth + e, np.full((n, 3), 0.004), 300.0))
        est = combine(BatchSums.concatenate(sums))
        errs.append(est.mean_m - truth)
        sig_batch.append(est.sigma_m)
        sig_formal.append(est.sigma_formal_m)
    actual = np.std(np.asarray(errs), axis=0)
    assert np.all(np.mean(sig_formal, axis=0) < actual / 4)  # the formal value is far too small
    ratio = np.mean(sig_batch, axis=0) / actual
    assert np.all((ratio > 0.7) & (ratio < 1.4)), ratio


def test_weighted_mean_and_sum_order_determinism():
    rng = np.random.default_rng(3)
    x = rng.normal(size=(100, 3))
    s = rng.uniform(0.5, 2.0, size=(100, 3))
    est = combine(batch_sums(np.arange(100.0), x, s, 10.0))
    w = 1 / s ** 2
    assert np.allclose(est.mean_m, (w * x).sum(0) / w.sum(0), rtol=1e-12)
    assert np.allclose(est.sigma_formal_m, 1 / np.sqrt(w.sum(0)))
    a = combine(BatchSums.concatenate([batch_sums(np.arange(50.0), x[:50], s[:50]),
                                       batch_sums(np.arange(50.0), x[50:], s[50:])]))
    b = combine(BatchSums.concatenate([batch_sums(np.arange(50.0), x[:50], s[:50]),
                                       batch_sums(np.arange(50.0), x[50:], s[50:])]))
    assert np.array_equal(a.mean_m, b.mean_m) and np.array_equal(a.sigma_m, b.sigma_m)


def test_gate_and_table3_products():
    ap = np.array([1.04653, -0.07191, 0.0])
    x = np.array([ap + [0.002, -0.008, -0.006], ap + [0.0, 0.06, 0.0], [np.nan] * 3])
    assert gate_epochs(x, ap).tolist() == [True, False, False]
    est = combine(batch_sums(np.arange(3.0), np.array([ap, ap + 0.001, ap + 0.002]), np.full((3, 3), 0.001), 1.0))
    row = BaselineRow("GPS-2", "GPS-0", ap, est, n_sets=1)
    doc = baselines_document("CASSIOPE-like", [row])
    b = doc["baselines"][0]
    assert doc["frames"] == "body" and b["from"] == "GPS-2" and b["to"] == "GPS-0" and b["n_epochs"] == 3
    assert np.allclose(b["calibrated_m"], ap + 0.001)
    csv = baselines_table_csv([row]).splitlines()
    assert csv[0] == "row,GPS-2>GPS-0_x_mm,GPS-2>GPS-0_y_mm,GPS-2>GPS-0_z_mm"
    assert csv[1] == "a_priori,1046.530,-71.910,0.000"
    assert csv[3].startswith("difference,1.000,1.000,1.000")


# --- binning ----------------------------------------------------------------------------------------

def test_grid_index_edges_wrap_and_outside():
    g = Grid2D.regular()
    assert g.shape == (90, 144) and g.x_centres_deg[0] == 1.25 and g.y_centres_deg[-1] == 89.5
    idx = g.index([0.0, 359.99, 360.0, -1.0, 10.0, 10.0, np.nan], [0.0, 89.9, 90.0, 5.5, -0.1, 90.1, 3.0])
    assert idx.tolist() == [0, 89 * 144 + 143, 89 * 144 + 0, 5 * 144 + 143, -1, -1, -1]
    with pytest.raises(ValueError):
        Grid2D.regular(x_step_deg=7.0)
    # an off-boresight grid for the seed 004 case: 0-20 deg in 1 deg, azimuth 10 deg
    g4 = Grid2D.regular(10.0, 1.0, y_range_deg=(0.0, 20.0))
    assert g4.shape == (20, 36)


def test_binning_values_counts_min_count_and_cluster_sigma():
    g = Grid2D.regular(90.0, 45.0)  # 2 x 4 bins
    rng = np.random.default_rng(4)
    n = 4000
    az = rng.uniform(0, 360, n)
    el = rng.uniform(0, 45, n)  # only the lower row
    cluster = rng.integers(0, 40, n)
    offset = rng.normal(0, 2.0, 40)  # a per-cluster (per-satellite-track) error
    v = 10.0 + offset[cluster] + rng.normal(0, 0.5, n)
    sums = accumulate(g, az, el, v, cluster=cluster)
    m = finalize(g, sums, min_count=30)
    assert np.all(np.isnan(m.value[1])) and np.all(m.count[1] == 0)
    assert m.count[0].sum() == n
    assert np.all(np.abs(m.value[0] - 10.0) < 1.5)
    # the cluster-robust sigma sees the 2.0 track errors (~2/sqrt(40)), not the 0.5 white noise/sqrt(1000)
    assert np.all(m.sigma[0] > 0.2) and np.all(m.sigma[0] < 0.6)
    naive = finalize(g, accumulate(g, az, el, v), min_count=30)
    assert np.all(naive.sigma[0] < 0.1)
    # min_count empties a bin but keeps its count
    few = finalize(g, accumulate(g, az[:10], el[:10], v[:10]), min_count=30)
    assert np.all(np.isnan(few.value)) and few.count.sum() == 10


def test_bin_sums_are_additive_and_order_independent_in_total():
    g = Grid2D.regular(30.0, 10.0)
    rng = np.random.default_rng(5)
    parts = []
    for _ in range(3):
        az, el, v = rng.uniform(0, 360, 500), rng.uniform(0, 90, 500), rng.normal(size=500)
        parts.append(accumulate(g, az, el, v, cluster=rng.integers(0, 5, 500)))
    a = finalize(g, BinSums.total(parts, g.n_bins), 1)
    b = finalize(g, BinSums.total(parts, g.n_bins), 1)
    assert np.array_equal(a.value, b.value, equal_nan=True) and np.array_equal(a.sigma, b.sigma, equal_nan=True)


# --- PCV iteration ----------------------------------------------------------------------------------

def _synthetic_pcv_set(rng, n_ep=600, n_sat=9, b_body=(1.0, 0.05, 0.0), pcv=None, noise_m=0.002):
    """Samples y = -g.b + clock + PCV + noise over a hemisphere of moving lines of sight."""
    az0 = rng.uniform(0, 360, n_sat)
    el0 = rng.uniform(5, 85, n_sat)
    t = np.arange(n_ep)
    az = np.mod(az0[None, :] + 0.05 * t[:, None], 360.0)
    el = np.clip(el0[None, :] + 0.02 * t[:, None] * np.where(rng.random(n_sat) < 0.5, -1, 1)[None, :], 0.5, 89.5)
    g = np.stack([np.cos(np.radians(el)) * np.cos(np.radians(az)), np.cos(np.radians(el)) * np.sin(np.radians(az)),
                  np.sin(np.radians(el))], axis=-1)  # antenna frame == body frame here
    clock = rng.normal(0, 50.0, n_ep)[:, None]
    p = np.zeros_like(az) if pcv is None else pcv(az, el)
    y = -(g @ np.asarray(b_body)) + clock + p + rng.normal(0, noise_m, az.shape)
    ep = np.broadcast_to(t[:, None], az.shape)
    sat = np.broadcast_to(np.arange(n_sat)[None, :], az.shape)
    return FixedPhases(ep.ravel(), sat.ravel(), y.ravel(), g.reshape(-1, 3), az.ravel(), el.ravel(),
                       np.full(az.size, 1.0 / noise_m ** 2))


def _pattern(az, el):
    return 0.012 * np.cos(np.radians(el)) ** 2 * np.cos(np.radians(2 * az)) + 0.006 * np.cos(np.radians(el)) ** 3


def test_map_normal_matches_brute_force_residuals():
    rng = np.random.default_rng(6)
    g = Grid2D.regular(30.0, 15.0)
    fp = _synthetic_pcv_set(rng, n_ep=200, pcv=_pattern)
    b = np.array([1.0, 0.05, 0.0])
    normal = map_normal(g, fp)
    m = rng.normal(0, 0.005, g.n_bins)
    r = residuals_m(fp, b, map_lookup(g, m, fp.az_deg, fp.el_deg))
    idx = g.index(fp.az_deg, fp.el_deg)
    brute = np.bincount(idx, weights=fp.weight * r, minlength=g.n_bins)
    W = np.bincount(idx, weights=fp.weight, minlength=g.n_bins)
    want = np.where(W > 0, brute / np.where(W > 0, W, 1), np.nan)
    got = normal.mean_residual_m(b, m)
    assert np.allclose(got, want, equal_nan=True, atol=1e-12)


def test_iteration_recovers_an_injected_pattern_up_to_a_constant():
    rng = np.random.default_rng(7)
    g = Grid2D.regular(15.0, 5.0)
    b = np.array([1.0, 0.05, 0.0])
    normals = [map_normal(g, _synthetic_pcv_set(rng, pcv=_pattern)) for _ in range(6)]
    total = normals[0]
    for nm in normals[1:]:
        total = total + nm
    active = total.count >= 30
    it = iterate_map(total, b, active, tolerance_mm=0.01, max_iterations=50)
    assert it.converged and it.changes_mm[0] > it.changes_mm[-1]
    centres_az, centres_el = np.meshgrid(g.x_centres_deg, g.y_centres_deg)
    truth = _pattern(centres_az, centres_el).ravel()
    d = (it.map_m - truth)[active]
    d = d - np.average(d, weights=total.W[active])
    assert np.sqrt(np.mean(d ** 2)) * 1e3 < 1.0  # mm, bins 15 x 5 deg against a point value at the centre
    assert np.all(np.isnan(it.map_m[~active]))
    # one step from the converged map changes it by less than the tolerance
    again = iterate_map(total, b, active, tolerance_mm=0.01, max_iterations=1, initial_m=it.map_m)
    assert again.changes_mm[0] < 0.01
    assert map_change_rms_mm(it.map_m, again.map_m) < 0.01


def test_iteration_stops_after_max_iterations():
    rng = np.random.default_rng(8)
    g = Grid2D.regular(30.0, 10.0)
    normal = map_normal(g, _synthetic_pcv_set(rng, pcv=_pattern))
    it = iterate_map(normal, np.array([1.0, 0.05, 0.0]), normal.count > 0, tolerance_mm=1e-9, max_iterations=3)
    assert len(it.changes_mm) == 3 and not it.converged


# --- integer fixing and epoch-wise least squares ------------------------------------------------------

def test_fix_integers_recovers_differences_and_wraps():
    rng = np.random.default_rng(9)
    N = rng.integers(-50, 50, size=(20, 8)).astype(float)
    common = rng.uniform(-3, 3, size=(20, 1))  # clock + fractional bias, any size
    z = N + common + rng.normal(0, 0.05, size=N.shape)
    n = fix_integers(z, np.ones_like(z))
    d = n - N
    assert np.all(d == d[:, :1])  # right up to one integer per epoch
    z[3, 2] = np.nan
    assert np.isnan(fix_integers(z, np.ones_like(z))[3, 2])


def _epoch_geometry(rng, n_ep: int, n_obs: int) -> tuple[np.ndarray, np.ndarray]:
    """(H (n_ep, n_obs, 4), x_true (4,)) of the epoch-wise least squares: random unit lines of sight and a clock,
    a 1 m baseline state."""
    e = rng.normal(size=(n_ep, n_obs, 3))
    e /= np.linalg.norm(e, axis=-1, keepdims=True)
    return np.concatenate([-e, np.ones((n_ep, n_obs, 1))], axis=-1), np.array([1.0, -0.07, 0.005, 12.0])


def test_epoch_lsq_solves_and_rejects_a_wrong_integer():
    rng = np.random.default_rng(10)
    n_ep, n_obs = 50, 10
    H, x_true = _epoch_geometry(rng, n_ep, n_obs)
    y = H @ x_true + rng.normal(0, 0.003, (n_ep, n_obs))
    y[7, 4] += 0.19  # one L1 cycle
    sol = epoch_lsq(y, H, np.full((n_ep, n_obs), 1 / 0.003 ** 2), gate=0.05)
    assert sol.ok.all()
    assert not sol.used[7, 4] and sol.used.sum() == n_ep * n_obs - 1
    assert np.all(np.abs(sol.x[:, :3] - x_true[:3]) < 0.02)
    assert np.all(np.abs(sol.residual[sol.used]) < 0.02)


def test_default_epoch_lsq_gate_keeps_the_uncalibrated_l2_tails_unbiased():
    """The default gate (10 cm) screens gross errors only: a satellite seen through +40 mm of uncalibrated PCV
    with 25 mm of L2 noise (the bench campaign's antenna horizon) keeps its samples, so their mean stays at the
    injected 40 mm; a 5 cm gate clips that tail about the map-less model and pulls the mean towards 0 (the
    +0.5 mm baseline bias of docs/BENCHMARKS.md "Calibration"). A one-cycle L1 error is still rejected."""
    from gnssatt.calibration.kinematic import DEFAULT_GATE_M

    rng = np.random.default_rng(11)
    n_ep, n_obs = 4000, 10
    H, x_true = _epoch_geometry(rng, n_ep, n_obs)
    err = rng.normal(0, 0.003, (n_ep, n_obs))
    err[:, 0] = 0.040 + rng.normal(0, 0.025, n_ep)   # PCV + L2 noise at the horizon
    err[7, 4] += 0.19                                 # one L1 cycle
    y = H @ x_true + err
    w = np.full((n_ep, n_obs), 1 / 0.003 ** 2)
    w[:, 0] = 1 / 0.025 ** 2

    def kept_mean_mm(gate):
        sol = epoch_lsq(y, H, w, gate=gate)
        return 1e3 * err[:, 0][sol.used[:, 0]].mean(), sol

    mean_default, sol = kept_mean_mm(DEFAULT_GATE_M)
    assert not sol.used[7, 4]
    # 25 mm / sqrt(4000) = 0.4 mm standard error of the mean: 1.6 mm is 4 of them
    assert abs(mean_default - 40.0) < 1.6
    mean_5cm, _ = kept_mean_mm(0.05)
    assert mean_5cm < 40.0 - 5.0   # the mechanism the default avoids (measured 26.7 mm: a third of them cut)
