"""The compiled rigid-update kernels (gnssatt.attitude.rigid_kernels) against their readable references
(rigid_update.rigid_retract_reference, rigid_smoother.rts_smooth_rigid_reference): the same baselines to 1e-12 m
and covariances to 1e-12 of their scale (rounding: the same operations in another order), the same links; the
one-baseline case (singular normal equations of the common rotation) included."""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.rigid_smoother import rts_gains, rts_smooth_rigid, rts_smooth_rigid_reference
from gnssatt.attitude.rigid_update import rigid_retract, rigid_retract_reference, rotation_exp
from gnssatt.attitude.rts_links import rts_links

B0 = np.array([[1.04653, -0.07191, 0.0], [0.0, 1.13969, 0.0]])


def test_retract_kernel_is_the_reference():
    """Two baselines in a 20-state filter, moved by a few mm (the filter's updates: mrad), one or both active."""
    rng = np.random.default_rng(1)
    b_idx = np.array([[3, 4, 5], [10, 11, 12]])
    for trial in range(6):
        A = rng.normal(size=(20, 20))
        x, P = rng.normal(size=20), A @ A.T
        bp = B0 + 1e-3 * rng.normal(size=B0.shape)
        x[b_idx] = bp + 3e-3 * rng.normal(size=B0.shape)
        active = np.array([True, trial % 2 == 0]) if trial < 4 else np.array([False, trial == 4])
        (x1, P1), (x2, P2) = (x.copy(), P.copy()), (x.copy(), P.copy())
        o1 = rigid_retract(x1, P1, bp, b_idx, active)
        o2 = rigid_retract_reference(x2, P2, bp, b_idx, active)
        assert np.abs(x1 - x2).max() < 1e-12 and np.abs(o1 - o2).max() < 1e-12
        assert np.abs(P1 - P2).max() < 1e-12 * np.abs(P).max()
        if trial == 1:
            assert np.abs(x1 - x).max() > 1e-6          # it did move the active baseline


def _body_track(n, rng, cut=(), nan_at=()):
    """Two baselines of one body turning by ~2 mrad per epoch after an omega block (3 states): forward posteriors
    and priors with noise, Phi = I; segment starts at `cut`, a non-finite posterior at `nan_at`."""
    m = 9
    xf, xp = np.zeros((n, m)), np.zeros((n, m))
    Pf, Pp = np.zeros((n, m, m)), np.zeros((n, m, m))
    B = B0.copy()
    for k in range(n):
        B = B @ rotation_exp(2e-3 * rng.normal(size=3)).T
        xf[k, :3] = 1e-3 * rng.normal(size=3)
        xf[k, 3:] = (B + 1e-4 * rng.normal(size=B.shape)).ravel()
        A = rng.normal(size=(m, m))
        Pf[k] = 1e-7 * (A @ A.T + m * np.eye(m))
        if k:
            xp[k] = xf[k - 1] + 1e-4 * rng.normal(size=m)
            Pp[k] = Pf[k - 1] + 1e-6 * np.eye(m)
    start = np.zeros(n, bool)
    start[[0, *cut]] = True
    xf[list(nan_at)] = np.nan
    return xf, Pf, xp, Pp, np.repeat(np.eye(m)[None], n, 0), start


def test_backward_kernel_is_the_reference_with_cuts_and_gaps():
    """300 epochs with two segment starts and a non-finite epoch: the same smoothed baselines (1e-12 m), omega,
    covariances (1e-12 of their scale), the same epochs left as filtered, and the same links as rts_links."""
    xf, Pf, xp, Pp, Phi, start = _body_track(300, np.random.default_rng(4), cut=(100, 101), nan_at=(200,))
    xs1, Ps1 = rts_smooth_rigid(xf, Pf, xp, Pp, Phi, start, 2)
    xs2, Ps2 = rts_smooth_rigid_reference(xf, Pf, xp, Pp, Phi, start, 2)
    assert np.array_equal(np.isfinite(xs1), np.isfinite(xs2))
    ok = np.isfinite(xs2).all(1)
    assert np.abs(xs1[ok] - xs2[ok]).max() < 1e-12
    assert np.abs(Ps1[ok] - Ps2[ok]).max() < 1e-12 * np.abs(Pf).max()
    assert np.abs(xs1[ok] - xf[ok]).max() > 1e-5          # the smoother moved them
    linked, C = rts_gains(xf, Pf, xp, Pp, Phi, start)
    ref = dict(rts_links(xf, Pf, xp, Pp, Phi, start))
    assert set(np.flatnonzero(linked)) == set(ref)
    assert max(np.abs(C[k] - ref[k]).max() for k in ref) < 1e-12


def test_backward_kernel_is_the_reference_with_one_baseline():
    """One baseline: the common rotation's normal equations are singular (no turn about b), the kernel takes
    lstsq's minimum-norm solution as the reference does."""
    xf, Pf, xp, Pp, Phi, start = _body_track(120, np.random.default_rng(9))
    sub = (xf[:, :6], Pf[:, :6, :6], xp[:, :6], Pp[:, :6, :6], Phi[:, :6, :6], start)
    xs1, Ps1 = rts_smooth_rigid(*sub, 1)
    xs2, Ps2 = rts_smooth_rigid_reference(*sub, 1)
    assert np.abs(xs1 - xs2).max() < 1e-12 and np.abs(Ps1 - Ps2).max() < 1e-12 * np.abs(Pf).max()
    assert np.abs(xs1 - xf[:, :6]).max() > 1e-5


def test_warm_up_compiles_the_signatures_the_filter_and_smoother_use():
    """warm_up (the worker's start) compiles one signature of each kernel, the one process() calls (C-contiguous
    float64 states, int64 indices, bool masks): a filter run with the smoother adds none."""
    from gnssatt.attitude import rigid_kernels as RK

    RK.warm_up()
    sig = (list(RK.rigid_retract_kernel.signatures), list(RK.rts_rigid_kernel.signatures))
    xf, Pf, xp, Pp, Phi, start = _body_track(20, np.random.default_rng(1))
    rts_smooth_rigid(xf, Pf, xp, Pp, Phi, start, 2)
    x, P = np.zeros(9), np.eye(9)
    x[3:] = B0.ravel()
    rigid_retract(x, P, B0, np.array([[3, 4, 5], [6, 7, 8]]), np.ones(2, bool))
    assert len(sig[0]) == 1 and len(sig[1]) == 1
    assert (list(RK.rigid_retract_kernel.signatures), list(RK.rts_rigid_kernel.signatures)) == sig
