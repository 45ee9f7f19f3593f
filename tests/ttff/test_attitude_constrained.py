"""gnssatt.attitude.ambiguity.resolve_constrained (C-LAMBDA on the attitude filter's SD state, issue 7 item 3) on a
synthetic single-epoch SD float solution built like the EKF's first update: right integers accepted (never wrong ones),
and it fixes single-frequency epochs that MLAMBDA + length validation does not always fix."""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.ambiguity import resolve_constrained, resolve_lambda

LAM_M = 0.190293672798


def _sd_float(rng, n_sat=8, sigma_phase_m=0.004, sigma_code_m=0.4, length_m=1.05):
    """State [b (3), c dt (1), SD ambiguities (n_sat)] after one update with a 500-cycle ambiguity prior."""
    u = rng.normal(size=(n_sat, 3))
    u[:, 2] = np.abs(u[:, 2]) + 0.2
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    d = rng.normal(size=3)
    b = length_m * d / np.linalg.norm(d)
    N = rng.integers(-50, 50, n_sat).astype(float)
    clk = 0.37
    code = -u @ b + clk + rng.normal(0, np.sqrt(2) * sigma_code_m, n_sat)
    phase = -u @ b + clk + LAM_M * N + rng.normal(0, np.sqrt(2) * sigma_phase_m, n_sat)
    n = 4 + n_sat
    H = np.zeros((2 * n_sat, n))
    H[:, 0:3] = np.vstack([-u, -u])
    H[:, 3] = 1.0
    H[n_sat:, 4:] = LAM_M * np.eye(n_sat)
    R = np.diag([2 * sigma_code_m ** 2] * n_sat + [2 * sigma_phase_m ** 2] * n_sat)
    P0 = np.diag([4.0] * 3 + [1e4] + [500.0 ** 2] * n_sat)
    Pinv = np.linalg.inv(P0) + H.T @ np.linalg.inv(R) @ H
    P = np.linalg.inv(Pinv)
    x = P @ (H.T @ np.linalg.inv(R) @ np.concatenate([code, phase]))
    idx = np.arange(4, n)
    dd_true = np.delete(N, 0) - N[0]
    return x, 0.5 * (P + P.T), [(idx, 0)], np.arange(3), length_m, dd_true


def test_right_integers_accepted():
    rng = np.random.default_rng(7)
    n_acc = n_right = 0
    for _ in range(30):
        x, P, groups, b_idx, L, dd_true = _sd_float(rng)
        out = resolve_constrained(x, P, groups, b_idx, L, 0.03, 3.0)
        if out.accepted:
            n_acc += 1
            n_right += np.array_equal(out.a_fix, dd_true)
        assert not out.accepted or np.array_equal(out.a_fix, dd_true)     # never a wrong fix here
        assert not out.accepted or abs(out.length_m - L) < 0.03
    assert n_acc >= 20 and n_right == n_acc          # 24 of 30 with seed 7


def test_constrained_fixes_more_than_lambda_length():
    rng = np.random.default_rng(11)
    lam = con = 0
    for _ in range(40):
        x, P, groups, b_idx, L, dd_true = _sd_float(rng, n_sat=6, sigma_code_m=0.8)
        a = resolve_lambda(x, P, groups, b_idx, L, 0.03)
        c = resolve_constrained(x, P, groups, b_idx, L, 0.03, 3.0)
        lam += a.accepted and np.array_equal(a.a_fix, dd_true)
        con += c.accepted and np.array_equal(c.a_fix, dd_true)
        assert not c.accepted or np.array_equal(c.a_fix, dd_true)
    assert con > lam
