"""MC-LAMBDA at few satellites (CubeSat-like 10 cm baselines, L1, 4 satellites = 3 DDs per baseline): the search
against a brute-force enumeration of every integer vector that can reach the joint bound, its objective computed
directly from the observations (not from the float decomposition); the rotation fit against many random starts on
short, imprecise baselines (where Gauss-Newton from the Wahba start alone missed the global minimum).

Theory: Teunissen (2007), Giorgi et al. (2010) eq. 9 (MC-LAMBDA objective); the enumeration box uses
x^T C^-1 x >= x_r^2 / C_rr (Cauchy-Schwarz) on each phase row with |g_r . b| <= |g_r| l for |b| = l.
"""
from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gnssatt.estimation.synthetic import CUBESAT_BODY_M, L1_WAVELENGTH_M, random_los, random_rotation
from gnssatt.estimation.constrained_search import (
    DDBlock, constrained_search_by_baselines, dd_geometry, rotation_fit, rotation_starts, single_epoch_float,
)
from gnssatt.estimation.constrained_search import _gauss_newton_rotation

LAM = L1_WAVELENGTH_M


def _few_sat_epoch(rng, n_sats, sigma_phase_m=0.006, sigma_code_m=0.5):
    """One L1 epoch of a 10 cm two-baseline platform: blocks, DD phase (cycles), DD code (m), truth, the design
    (A, y, block-diagonal covariance) of the direct objective."""
    body = CUBESAT_BODY_M
    q = body.shape[0]
    R = random_rotation(rng)
    ant = np.vstack([np.zeros(3), body @ R.T])
    e = random_los(rng, n_sats, 10.0)
    ref = int(np.argmax(e[:, 2]))
    G = dd_geometry(e, ref)
    sats = tuple(i for i in range(n_sats) if i != ref)
    keep = np.arange(n_sats) != ref
    N = rng.integers(-500, 500, size=(q + 1, n_sats))
    rho = -(ant @ e.T)
    phi = rho / LAM + N + rng.normal(0.0, sigma_phase_m / LAM, (q + 1, n_sats))
    code = rho + rng.normal(0.0, sigma_code_m, (q + 1, n_sats))
    blocks, ph, co, a_true = [], [], [], []
    for i in range(q):
        sdp, sdc, sdn = phi[i + 1] - phi[0], code[i + 1] - code[0], N[i + 1] - N[0]
        blocks.append(DDBlock(i, "L1", LAM, sats, ref, G))
        ph.append(sdp[keep] - sdp[ref])
        co.append(sdc[keep] - sdc[ref])
        a_true.append(sdn[keep] - sdn[ref])
    sol = single_epoch_float(blocks, ph, co, [(0, i + 1) for i in range(q)], sigma_phase_m, sigma_code_m)
    return sol, blocks, ph, co, np.concatenate(a_true), body, R


def _direct_objective(blocks, ph, co, body, sigma_phase_m=0.006, sigma_code_m=0.5):
    """J(a) = min_R ||y - A_a a - A_b vec(R F)||^2_{Q_y} - ||e_hat||^2, from the observations: the DD covariance
    built here from the undifferenced sigmas (master antenna 0 shared by both baselines)."""
    q = body.shape[0]
    n_i = blocks[0].n_dd
    n = n_i * q
    D = np.hstack([np.eye(n_i), -np.ones((n_i, 1))])                 # DD of one baseline from SDs
    C1 = np.kron(np.eye(q) + np.ones((q, q)), D @ D.T)                 # shared master: off-diagonal blocks 1x
    Wp = np.linalg.inv(C1 * (sigma_phase_m / LAM) ** 2)
    Wc = np.linalg.inv(C1 * sigma_code_m ** 2)
    Gb = np.zeros((n, 3 * q))
    for i, blk in enumerate(blocks):
        Gb[i * n_i:(i + 1) * n_i, 3 * i:3 * i + 3] = blk.geometry
    yp, yc = np.concatenate(ph), np.concatenate(co)
    Nb = Gb.T @ Wp @ Gb / LAM ** 2 + Gb.T @ Wc @ Gb
    # float residual: a free absorbs the phase rows, so ||e_hat||^2 is the code-only LS residual
    b_code = np.linalg.solve(Gb.T @ Wc @ Gb, Gb.T @ Wc @ yc)
    e2_float = float((yc - Gb @ b_code) @ Wc @ (yc - Gb @ b_code))

    def J(a):
        rp = yp - a
        b_ls = np.linalg.solve(Nb, Gb.T @ Wp @ rp / LAM + Gb.T @ Wc @ yc)
        e_p, e_c = rp - Gb @ b_ls / LAM, yc - Gb @ b_ls
        res = float(e_p @ Wp @ e_p + e_c @ Wc @ e_c)
        # rotation part: multi-start (the library's starts plus 12 random ones) so the reference is global
        starts = rotation_starts(b_ls, Nb, body) + list(Rotation.random(12, random_state=7).as_matrix())
        c_rot = min(_gauss_newton_rotation(b_ls, Nb, body, R0, 30)[0] for R0 in starts)
        return res + c_rot - e2_float
    return J, Wp, e2_float


@pytest.mark.parametrize("seed", range(6))
def test_mc_lambda_equals_enumeration_at_four_satellites(seed):
    rng = np.random.default_rng(100 + seed)
    sol, blocks, ph, co, a_true, body, _ = _few_sat_epoch(rng, 4)
    rows = [np.arange(0, 3), np.arange(3, 6)]
    res = constrained_search_by_baselines(sol.a_float_cyc, sol.Q_a, sol.b_float_m, sol.Q_b, sol.Q_ab, body, rows,
                                          m_first=3, ratio_cap=2.0, max_nodes=50_000, max_candidates=200)
    J, Wp, e2 = _direct_objective(blocks, ph, co, body)
    J1 = J(res.fixed[0].astype(float))
    assert J1 == pytest.approx(res.cost, rel=1e-6, abs=1e-6)     # the float decomposition is the direct objective
    hi = 2.0 * J1 + 1e-9                                           # everything the search had to see
    # box of every a with J(a) < hi: the whole weighted residual (J + e2) bounds each phase row's,
    # |phi_r - a_r - g_r . b / lambda| <= sqrt((hi + e2) C_rr), and |g_r . b| <= |g_r| l
    yp = np.concatenate(ph)
    Cp = np.linalg.inv(Wp)
    g = np.concatenate([np.linalg.norm(blk.geometry, axis=1) * np.linalg.norm(body[i]) for i, blk in enumerate(blocks)])
    half = g / LAM + np.sqrt((hi + e2) * np.diag(Cp))
    ranges = [np.arange(np.ceil(y - h), np.floor(y + h) + 1) for y, h in zip(yp, half)]
    grid = list(itertools.product(*ranges))
    assert 2 <= len(grid) < 20_000
    costs = sorted((J(np.array(c, float)), c) for c in grid)
    assert tuple(res.fixed[0]) == tuple(int(v) for v in costs[0][1])
    if not res.second_bounded:
        assert tuple(res.fixed[1]) == tuple(int(v) for v in costs[1][1])
        assert res.ratio == pytest.approx(costs[1][0] / costs[0][0], rel=1e-5)
    else:
        assert costs[1][0] >= 2.0 * costs[0][0] * (1 - 1e-6)
    # 6 mm per antenna, 3 DDs per baseline: the minimiser is wrong in one of these draws (seed 3), with ratio 1.13;
    # what the single-epoch validation would accept (ratio of the constrained objective >= 1.5) is right
    if res.ratio >= 1.5:
        assert np.array_equal(res.fixed[0], a_true)


def test_rotation_fit_is_global_on_short_imprecise_baselines():
    """10 cm baselines with cm-level, anisotropic errors (weak boresight): damped Newton from the Wahba start and
    its mirror images reaches the minimum over 40 random starts (plain Gauss-Newton from the Wahba start alone
    missed it on about half of such CubeSat leaves)."""
    rng = np.random.default_rng(5)
    body = CUBESAT_BODY_M
    worse = 0
    for _ in range(40):
        R = random_rotation(rng)
        # baseline errors: 5 mm horizontal, 3-8 cm along a random 'boresight', correlated between the baselines
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        Q1 = 0.005 ** 2 * np.eye(3) + rng.uniform(0.03, 0.08) ** 2 * np.outer(u, u)
        Qb = np.kron(np.array([[1.0, 0.5], [0.5, 1.0]]), Q1)
        b_hat = (body @ R.T).reshape(-1) + np.linalg.cholesky(Qb) @ rng.normal(size=6)
        W = np.linalg.inv(Qb)
        cost, Rf = rotation_fit(b_hat, W, body)
        assert np.allclose(Rf.T @ Rf, np.eye(3), atol=1e-10) and np.linalg.det(Rf) == pytest.approx(1.0)
        ref = min(_gauss_newton_rotation(b_hat, W, body, R0, 40)[0]
                  for R0 in Rotation.random(40, random_state=int(rng.integers(1 << 30))).as_matrix())
        assert cost <= ref * (1 + 1e-6) + 1e-9
        # the single Wahba start alone (the previous fit)
        worse += _gauss_newton_rotation(b_hat, W, body, rotation_starts(b_hat, W, body)[0], 8)[0] > ref * 1.001 + 1e-6
    assert worse >= 1        # the case the extra starts are for does occur in this family


def test_compiled_sphere_dual_bound_equals_the_python_one():
    """The C-LAMBDA node bound compiled (numba, scalars) gives the same floats as the plain-Python reference, and
    both stay below the exact constrained minimum (weak duality), on random metrics, centres and lengths."""
    from gnssatt.estimation.constrained_search import (_metric_eig, _sphere_dual_bound, _sphere_dual_bound_nb,
                                                       sphere_fit)

    rng = np.random.default_rng(7)
    same = 0
    for _ in range(2000):
        A = rng.normal(size=(3, 3))
        W = A @ A.T + rng.uniform(1e-3, 10.0) * np.eye(3)
        w, V = np.linalg.eigh(W)
        b = rng.normal(scale=rng.choice([0.05, 1.0, 5.0]), size=3)
        length = float(rng.uniform(0.05, 2.0))
        wl, Vt = [float(v) for v in w], [[float(v) for v in row] for row in V.T]
        ref = _sphere_dual_bound([float(v) for v in b], wl, Vt, length)
        got = _sphere_dual_bound_nb(float(b[0]), float(b[1]), float(b[2]), _metric_eig(w, V), length, 3.0)
        assert got == pytest.approx(ref, rel=1e-12, abs=1e-300)
        same += got == ref
        exact, _ = sphere_fit(b, W, length)
        assert got <= exact * (1 + 1e-9) + 1e-12
    assert same >= 1990, same          # bit-identical but for rare last-bit differences
