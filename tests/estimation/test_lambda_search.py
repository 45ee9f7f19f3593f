"""MLAMBDA against brute-force enumeration, RTKLIB's known answers and pyrtklib, plus lattice properties.

Authorities:
- Brute force: every integer vector in a box that provably holds the two best (see ``_brute_two_best``).
- RTKLIB 2.4.3 ``test/utest/t_lambda.c`` (tomojitakasu/RTKLIB, utest1/utest2): float vectors, covariances,
  the two best fixed vectors and their squared norms, asserted there to 1e-4.
- RTKLIB's ``lambda()`` itself through the ``pyrtklib`` bindings (independent C implementation).
"""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from tests.conftest import require_module
from hypothesis import given, settings, strategies as st

from gnssatt.estimation.lambda_search import (
    AmbiguitySearchError, decorrelate, ldl_decompose, mlambda, search,
)


def _qform(a_float, Q, cands):
    """(a - c)^T Q^-1 (a - c) for each row c, evaluated independently of the code under test."""
    r = np.asarray(cands, float) - a_float
    return np.einsum("ij,ij->i", r, np.linalg.solve(Q, r.T).T)


def _random_problem(rng, n, cond):
    """(a_float, Q): Q with eigenvalues log-spread over `cond`, a random orientation, float values off-integer."""
    U, _ = np.linalg.qr(rng.normal(size=(n, n)))
    eig = np.exp(rng.uniform(0.0, np.log(cond), n)) if n > 1 else np.ones(1)
    eig = eig / eig.max() * rng.uniform(0.05, 2.0)          # largest variance 0.05..2 cycles^2
    Q = (U * eig) @ U.T
    a = rng.uniform(-50, 50, n)
    return a, 0.5 * (Q + Q.T)


def _brute_two_best(a_float, Q, chi2):
    """The two best integer vectors by enumeration of every integer in the box |a_i - x_i| <= sqrt(chi2 Q_ii).

    Every x with (a - x)^T Q^-1 (a - x) <= chi2 lies in that box (Cauchy-Schwarz: (e_i^T r)^2 <= Q_ii r^T Q^-1 r),
    so with chi2 >= the true second-best value the box holds both best vectors.
    """
    half = np.sqrt(chi2 * np.diag(Q)) + 1e-9
    ranges = [np.arange(np.ceil(a - h), np.floor(a + h) + 1) for a, h in zip(a_float, half)]
    size = int(np.prod([len(r) for r in ranges]))
    assert size <= 400_000, f"box too large for brute force: {size}"
    grid = np.array(list(itertools.product(*ranges)))
    s = _qform(a_float, Q, grid)
    order = np.argsort(s)[:2]
    return grid[order].astype(np.int64), s[order]


@pytest.mark.parametrize("cond", [1.0, 1e2, 1e5], ids=["well", "cond1e2", "cond1e5"])
@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 6])
def test_mlambda_equals_brute_force(n, cond):
    rng = np.random.default_rng(1000 * n + int(np.log10(cond)))
    checked = 0
    for _ in range(40):
        a, Q = _random_problem(rng, n, cond)
        res = mlambda(a, Q, m=2)
        # the returned vectors are integer vectors, so the true second-best value <= their larger value
        s_check = _qform(a, Q, res.fixed)
        np.testing.assert_allclose(res.sqnorm, s_check, rtol=1e-8, atol=1e-10)
        half = np.sqrt(s_check.max() * np.diag(Q))
        if np.prod(2 * half + 1) > 400_000:
            continue
        fixed_bf, s_bf = _brute_two_best(a, Q, s_check.max() * (1 + 1e-9))
        np.testing.assert_allclose(res.sqnorm, s_bf, rtol=1e-9, atol=1e-12)
        np.testing.assert_array_equal(res.fixed, fixed_bf)
        checked += 1
    assert checked >= 30, f"only {checked} problems small enough for brute force"


def test_mlambda_m_best_equals_brute_force():
    rng = np.random.default_rng(7)
    for _ in range(30):
        a, Q = _random_problem(rng, 3, 1e3)
        res = mlambda(a, Q, m=6)
        chi2 = res.sqnorm.max() * (1 + 1e-9)
        half = np.sqrt(chi2 * np.diag(Q))
        ranges = [np.arange(np.ceil(x - h), np.floor(x + h) + 1) for x, h in zip(a, half)]
        grid = np.array(list(itertools.product(*ranges)))
        s = np.sort(_qform(a, Q, grid))[:6]
        np.testing.assert_allclose(res.sqnorm, s, rtol=1e-9)
        assert np.all(np.diff(res.sqnorm) >= 0)


# RTKLIB 2.4.3 test/utest/t_lambda.c, utest1 and utest2 (expected F and s as asserted there, tolerance 1e-4)
_A1 = [1585184.171, -6716599.430, 3915742.905, 7627233.455, 9565990.879, 989457273.200]
_Q1 = np.full((6, 6), 0.112202)
np.fill_diagonal(_Q1, 0.227134)
_Q1[5, :5] = _Q1[:5, 5] = 0.103473
_Q1[5, 5] = 0.434339
_F1 = [[1585184, -6716599, 3915743, 7627234, 9565991, 989457273],
       [1585184, -6716600, 3915743, 7627233, 9565991, 989457273]]
_S1 = [3.507984, 3.708456]
_A2 = [-13324172.755747, -10668894.713608, -7157225.010770, -6149367.974367, -7454133.571066,
       -5969200.494550, 8336734.058423, 6186974.084502, -17549093.883655, -13970158.922370]
_Q2 = np.zeros((10, 10))
_Q2[:5, :5] = 0.223160
_Q2[5:, 5:] = 0.367531
_Q2[:5, 5:] = _Q2[5:, :5] = 0.286388
np.fill_diagonal(_Q2[:5, :5], 0.446320)
np.fill_diagonal(_Q2[5:, 5:], 0.735063)
np.fill_diagonal(_Q2[:5, 5:], 0.572775)
np.fill_diagonal(_Q2[5:, :5], 0.572775)
_F2 = [[-13324188, -10668901, -7157236, -6149379, -7454143, -5969220, 8336726, 6186960, -17549108, -13970171],
       [-13324188, -10668908, -7157236, -6149379, -7454143, -5969220, 8336717, 6186960, -17549108, -13970171]]
_S2 = [1506.435789, 1612.811795]


@pytest.mark.parametrize("a, Q, F, s", [(_A1, _Q1, _F1, _S1), (_A2, _Q2, _F2, _S2)], ids=["utest1", "utest2"])
def test_rtklib_t_lambda_known_answers(a, Q, F, s):
    res = mlambda(np.array(a), Q, m=2)
    np.testing.assert_array_equal(res.fixed, np.array(F, dtype=np.int64))
    np.testing.assert_allclose(res.sqnorm, s, atol=1e-4)


def test_against_rtklib_lambda_via_pyrtklib():
    pyrtklib = require_module("pyrtklib")
    rtk_lambda = pyrtklib.__dict__["lambda"]
    Arr = pyrtklib.Arr1Ddouble
    rng = np.random.default_rng(11)
    for trial in range(60):
        n = int(rng.integers(2, 13))
        a, Q = _random_problem(rng, n, 1e4)
        a_arr, Q_arr, F_arr, s_arr = Arr(n), Arr(n * n), Arr(n * 2), Arr(2)
        for i in range(n):
            a_arr[i] = float(a[i])
        for i, v in enumerate(Q.flatten(order="F")):
            Q_arr[i] = float(v)
        assert rtk_lambda(n, 2, a_arr, Q_arr, F_arr, s_arr) == 0
        F = np.rint([[F_arr[i + j * n] for i in range(n)] for j in range(2)]).astype(np.int64)  # RTKLIB solves Z^T F = E in floating point
        res = mlambda(a, Q, m=2)
        np.testing.assert_allclose(res.sqnorm, [s_arr[0], s_arr[1]], rtol=1e-8)
        np.testing.assert_array_equal(res.fixed, F)


def test_ldl_reconstructs_and_conditional_variances():
    rng = np.random.default_rng(3)
    _, Q = _random_problem(rng, 6, 1e3)
    L, d = ldl_decompose(Q)
    np.testing.assert_allclose(L.T @ np.diag(d) @ L, Q, rtol=1e-10, atol=1e-14)
    assert np.allclose(np.diag(L), 1.0) and np.allclose(np.triu(L, 1), 0.0)
    # d[0] is the variance of a_0 given all others = 1 / (Q^-1)_00; d[n-1] = Q[n-1, n-1]
    assert d[0] == pytest.approx(1.0 / np.linalg.inv(Q)[0, 0], rel=1e-10)
    assert d[-1] == pytest.approx(Q[-1, -1])


def test_decorrelation_properties():
    rng = np.random.default_rng(4)
    for _ in range(20):
        _, Q = _random_problem(rng, 8, 1e6)
        dec = decorrelate(Q)
        np.testing.assert_array_equal(dec.Z @ dec.Z_inv, np.eye(8, dtype=np.int64))
        Qz = dec.Z.T @ Q @ dec.Z
        np.testing.assert_allclose(dec.L.T @ np.diag(dec.d) @ dec.L, Qz, rtol=1e-8, atol=1e-12 * np.abs(Qz).max())
        assert np.all(np.abs(np.tril(dec.L, -1)) <= 0.5 + 1e-12)          # size-reduced
        # no adjacent swap would lower d[j+1] (the LAMBDA reduction's stopping condition)
        delta = dec.d[:-1] + np.diag(dec.L, -1) ** 2 * dec.d[1:]
        assert np.all(delta >= dec.d[1:] * (1 - 1e-8))
        assert np.prod(dec.d) == pytest.approx(np.linalg.det(Q), rel=1e-6)   # volume preserved


def test_bad_covariances_raise_clear_errors():
    with pytest.raises(ValueError, match="not positive definite"):
        mlambda(np.zeros(2), np.array([[1.0, 1.0], [1.0, 1.0]]) - 1e-3 * np.eye(2))
    with pytest.raises(ValueError, match="not symmetric"):
        mlambda(np.zeros(2), np.array([[1.0, 0.5], [0.0, 1.0]]))
    with pytest.raises(ValueError, match="non-finite"):
        mlambda(np.array([np.nan, 0.0]), np.eye(2))
    with pytest.raises(ValueError, match="shape"):
        mlambda(np.zeros(3), np.eye(2))


def test_ill_conditioned_but_positive_definite_is_solved():
    # GNSS-like: three code-level directions (10 cycles^2) and phase-level ones (1e-4 cycles^2): cond 1e5
    rng = np.random.default_rng(5)
    n = 8
    U, _ = np.linalg.qr(rng.normal(size=(n, n)))
    Q = (U * np.r_[10.0, 10.0, 10.0, np.full(n - 3, 1e-4)]) @ U.T
    Q = 0.5 * (Q + Q.T)
    a_true = rng.integers(-100, 100, n)
    a = a_true + np.linalg.cholesky(Q) @ rng.normal(size=n)
    res = mlambda(a, Q)
    assert res.sqnorm[0] <= _qform(a, Q, a_true[None])[0] + 1e-9


def test_node_cap_raises():
    rng = np.random.default_rng(6)
    A = rng.normal(size=(30, 30))
    with pytest.raises(AmbiguitySearchError):
        mlambda(rng.normal(size=30) * 10, A @ A.T, max_nodes=50)


def test_search_without_decorrelation_matches():
    rng = np.random.default_rng(8)
    a, Q = _random_problem(rng, 4, 10.0)
    L, d = ldl_decompose(Q)
    z, s, _ = search(a, L, d, m=2)
    res = mlambda(a, Q, m=2)
    np.testing.assert_array_equal(z, res.fixed)


_problem = st.tuples(st.integers(1, 8), st.floats(0.0, 6.0), st.integers(0, 2**32 - 1))


def _problem_from(n, log_cond, seed):
    return _random_problem(np.random.default_rng(seed), n, 10.0 ** log_cond)


def _same_or_tie(res_a, res_b, shift=None):
    """Same candidates (after the shift), or equal squared norms where a tie allows another order."""
    fa = res_a.fixed + (0 if shift is None else shift)
    np.testing.assert_allclose(res_a.sqnorm, res_b.sqnorm, rtol=1e-6, atol=1e-9)
    for i in range(fa.shape[0]):
        if not np.array_equal(fa[i], res_b.fixed[i]):
            others = np.delete(res_a.sqnorm, i)
            assert np.any(np.isclose(others, res_a.sqnorm[i], rtol=1e-6)), "different candidate without a tie"


@settings(max_examples=60, deadline=None)
@given(_problem, st.lists(st.integers(-10**6, 10**6), min_size=8, max_size=8))
def test_integer_shift_equivariance(problem, shift):
    a, Q = _problem_from(*problem)
    k = np.array(shift[: a.size], dtype=np.int64)
    _same_or_tie(mlambda(a, Q), mlambda(a + k, Q), shift=k)


@settings(max_examples=60, deadline=None)
@given(_problem)
def test_Z_is_unimodular(problem):
    _, Q = _problem_from(*problem)
    dec = decorrelate(Q)
    assert abs(round(np.linalg.det(dec.Z.astype(float)))) == 1
    np.testing.assert_array_equal(dec.Z @ dec.Z_inv, np.eye(Q.shape[0], dtype=np.int64))
    assert np.all(np.abs(np.linalg.inv(dec.Z.astype(float)) - dec.Z_inv) < 1e-6)   # integer inverse


@settings(max_examples=60, deadline=None)
@given(_problem, st.integers(0, 2**32 - 1))
def test_permutation_invariance(problem, perm_seed):
    a, Q = _problem_from(*problem)
    p = np.random.default_rng(perm_seed).permutation(a.size)
    res = mlambda(a, Q)
    res_p = mlambda(a[p], Q[np.ix_(p, p)])
    permuted = type(res)(fixed=res.fixed[:, p], sqnorm=res.sqnorm, Z=res.Z, ratio=res.ratio, d=res.d,
                         n_nodes=res.n_nodes)
    _same_or_tie(permuted, res_p)
