"""The lag-1 variance component of the time-correlated phase error (gnssatt.attitude.multipath_vce) against truth:
SD phase errors simulated here (white noise of known sigma plus a first-order Gauss-Markov multipath of known
variance and correlation time, not the filter's own noise model), residuals from an epoch-by-epoch weighted
least-squares fit of a baseline and a phase clock with weights that may be wrong."""
from __future__ import annotations

import numpy as np
import pytest

from gnssatt.attitude.multipath_vce import MultipathVce, lag1_sums, lag_epoch, residual_maker
from gnssatt.attitude.reference_update import multipath_scale_sums

N_EP, N_SAT, DT_S, TAU_S = 3000, 10, 1.0, 60.0
SIGMA_W_M = 0.004          # white SD phase noise
SIGMA_CFG_M = 0.003        # the configured multipath sigma (v_mp); the truth scale is var(GM) / this^2


def _los(rng):
    """(N_EP, N_SAT, 3) unit lines of sight drifting slowly (a few degrees over the run)."""
    u0 = rng.standard_normal((N_SAT, 3))
    u0[:, 2] = np.abs(u0[:, 2]) + 0.3
    drift = 0.02 * rng.standard_normal((N_SAT, 3))
    u = u0[None] + np.linspace(0, 1, N_EP)[:, None, None] * drift[None]
    return u / np.linalg.norm(u, axis=2, keepdims=True)


def _gauss_markov(rng, sigma_m):
    """(N_EP, N_SAT) first-order Gauss-Markov series of stationary sigma sigma_m and correlation time TAU_S."""
    phi = np.exp(-DT_S / TAU_S)
    x = np.empty((N_EP, N_SAT))
    x[0] = sigma_m * rng.standard_normal(N_SAT)
    q = sigma_m * np.sqrt(1 - phi ** 2)
    for k in range(1, N_EP):
        x[k] = phi * x[k - 1] + q * rng.standard_normal(N_SAT)
    return x


def _run(seed: int, sigma_gm_m: float, var_assumed_factor: np.ndarray, vce_out: list | None = None):
    """(VCE scale unclipped, leverage-formula scale): residuals of the WLS fit (weights 1 / (var_assumed_factor x
    the true variance)) of e = white + GM, fed to both estimators; the leverage formula gets the assumed white
    variance (as the filter would use a wrong R)."""
    rng = np.random.default_rng(seed)
    u = _los(rng)
    e = SIGMA_W_M * rng.standard_normal((N_EP, N_SAT)) + _gauss_markov(rng, sigma_gm_m)
    v_mp = np.full(N_SAT, SIGMA_CFG_M ** 2)
    v_white_true = np.full(N_SAT, SIGMA_W_M ** 2)
    var = var_assumed_factor * (v_white_true + sigma_gm_m ** 2)       # the weights' (wrong) variances
    v_white_assumed = var_assumed_factor * v_white_true
    vce = MultipathVce(memory_epochs=1e12, s_min=-np.inf, s_max=np.inf, max_dt_s=1.5)
    lev_num = lev_den = 0.0
    cols = np.tile(np.array([0, 1, 2, 3, 4 + np.arange(N_SAT)[0]]), (N_SAT, 1))
    cols[:, 4] = 4 + np.arange(N_SAT)
    for k in range(N_EP):
        coef = np.column_stack([-u[k], np.ones(N_SAT), np.full(N_SAT, 0.19)])
        A = coef[:, :4]
        post = residual_maker(A, var) @ e[k]
        vce.add(lag_epoch(k * DT_S, np.arange(N_SAT), cols, coef, var, v_mp, post, np.ones(N_SAT, bool),
                          float(np.mean(var_assumed_factor)) * sigma_gm_m ** 2 / SIGMA_CFG_M ** 2))
        P_post = np.linalg.inv(A.T @ (A / var[:, None]))
        n, d, _ = multipath_scale_sums(A, P_post, var, v_white_assumed, v_mp, post, np.ones(N_SAT, bool))
        lev_num, lev_den = lev_num + n, lev_den + d
    if vce_out is not None:
        vce_out.append(vce)
    return vce.num / vce.den, lev_num / lev_den


def test_white_noise_only_gives_a_zero_scale():
    """No multipath: the lag-1 products hold no white noise. Sampling std of the scale here ~0.015 (the mean of
    3000 x 10 products of 4 mm white residuals over ~6e-6 m^2 expected per unit scale); 0.06 = 4 sigma."""
    s, _ = _run(1, 0.0, np.ones(N_SAT))
    assert abs(s) < 0.06, s


def test_gauss_markov_variance_is_recovered():
    """GM of sigma 6 mm (tau 60 s) on 3 mm configured: truth 4.0 x rho(1) = 3.93. Sampling error of a lag-1 mean
    over 3000 s x 10 arcs of a 60-s process: ~6 % (sqrt(2 tau / T / arcs)); 20 % = ~3 sigma."""
    s, _ = _run(2, 0.006, np.ones(N_SAT))
    truth = (0.006 / SIGMA_CFG_M) ** 2 * np.exp(-DT_S / TAU_S)
    assert abs(s / truth - 1) < 0.2, (s, truth)


def test_a_misspecified_r_does_not_bias_the_scale_but_biases_the_leverage_formula():
    """Weights from variances wrong by factors 0.3-4 per satellite (and the white variance the leverage formula
    subtracts wrong by the same, mean factor 2.4): the VCE stays within its sampling error of the truth; the leverage
    formula (E[r^2] = R (1 - h), R the assumed) does not (measured: 2.65 for 3.93 with multipath, -2.48 for 0
    without; 3.63 and -0.02 with the right R)."""
    wrong = np.random.default_rng(7).uniform(0.3, 4.0, N_SAT)
    s, s_lev = _run(3, 0.006, wrong)
    truth = (0.006 / SIGMA_CFG_M) ** 2 * np.exp(-DT_S / TAU_S)
    assert abs(s / truth - 1) < 0.2, (s, truth)
    assert abs(s_lev / truth - 1) > 0.25, (s_lev, truth)
    s0, s0_lev = _run(4, 0.0, wrong)
    assert abs(s0) < 0.06, s0
    assert abs(s0_lev) > 1.0, s0_lev


def test_white_scale_from_the_lag0_sums():
    """The white variance over the filter's: 1 with the right white variance, 0.5 where the filter assumes twice
    it (uniform factor: the white part of the assumed variance is 2 x the true one). Measured 1.051 / 0.526: the
    lag-1 scale is low by rho(1) = 0.983 of the GM's 36 mm^2, which leaves 0.6 of the white 16 mm^2 (+3.8 %); the
    lag-0 and lag-1 sums share the GM realisation, so the sampling part is small; 10 % covers both."""
    for factor, want in ((1.0, 1.0), (2.0, 0.5)):
        out = []
        _run(5, 0.006, np.full(N_SAT, factor), out)
        assert abs(out[0].white_scale() / want - 1) < 0.1, (factor, out[0].white_scale())


def test_lag1_sums_pair_only_the_common_arcs():
    """Arcs present at one epoch only add nothing; the expectation sums M_k M_k-1 v_mp over the common rows."""
    from gnssatt.attitude.multipath_vce import LagEpoch
    M = np.eye(3)
    a = LagEpoch(0.0, np.array([1, 2, 3]), np.array([1.0, 2.0, 3.0]), np.ones(3), M)
    b = LagEpoch(1.0, np.array([2, 3, 9]), np.array([5.0, 7.0, 100.0]), np.ones(3), M)
    num, den, n = lag1_sums(a, b)
    assert (num, den, n) == (2.0 * 5.0 + 3.0 * 7.0, 2.0, 2)


# ------------------------------------------------------------------------------------------------ in the filter
#: the simulator's phase multipath per receiver (earth-pointing preset: zenith 0.5 mm, horizon 4 mm, Gauss-Markov
#: tau 60 s, the same quadratic growth with the off-boresight angle as the filter's model); configured per SD as
#: sqrt(2) x that, the truth scale is 1 (x rho(1) = 0.983)
SIM_MP_SD_M = (0.0005 * 2 ** 0.5, 0.004 * 2 ** 0.5)


@pytest.fixture(scope="module")
def gm_pass(tmp_path_factory):
    """10 minutes of the clean pass (white noise, no PCO / PCV) with the simulator's Gauss-Markov phase multipath."""
    from tests.attitude.conftest import CLEAN, _simulate
    return _simulate(tmp_path_factory, "gm", "earth-pointing", 5, {"duration_s": 600.0, **CLEAN, "multipath": True})


def _scale(d, mode: str, **over) -> float:
    from gnssatt.attitude.process import load_inputs, process
    from gnssatt.attitude.settings import AttitudeSettings
    from tests.attitude.conftest import set_files
    st = AttitudeSettings.preset("seed000", mode=mode, multipath_adaptive_method="autocovariance", **over)
    return process(load_inputs(set_files(d)), st).summary["noise_model"]["multipath_scale"]


def test_filter_finds_the_simulated_multipath_variance(gm_pass):
    """Truth 0.98. The estimate is the last 300 epochs' (the estimator's memory): ~300 s x ~30 arcs of a 60-s
    process, ~15 % sampling std (measured 0.78 kinematic / 0.85 dynamic here; 0.97 / 1.06 over 30 minutes; the
    leverage formula 1.12 / 1.10 and 1.17 / 1.17); 0.6-1.4 is ~2.5 sigma. Dynamic mode may come out higher: its
    baselines absorb less of a slowly varying error than an epoch's solution (module doc of multipath_vce)."""
    for mode in ("kinematic", "dynamic"):
        s = _scale(gm_pass, mode, sigma_multipath_phase_m=SIM_MP_SD_M)
        assert 0.6 < s < 1.4, (mode, s)


def test_filter_finds_no_multipath_on_the_clean_pass(clean_pass):
    """White noise only (the clean pass): the scale at its floor 0.05 (the leverage formula: ~0.15-0.3)."""
    for mode in ("kinematic", "dynamic"):
        s = _scale(clean_pass, mode)
        assert s < 0.1, (mode, s)
