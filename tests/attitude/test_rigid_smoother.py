"""The smoother's backward step for rigid baselines (gnssatt.attitude.rigid_smoother, issue 21 item 2): box-plus /
box-minus on a baseline, the recursion keeping a rigid baseline's length where the linear RTS step shortens it, the
same as the linear step to second order for small moves, and on a short clean pass with `baseline_update: rigid`
the smoothed lengths and attitude against the additive update's smoother."""
from __future__ import annotations

import json

import numpy as np

from gnssatt.attitude.process import load_inputs, process
from gnssatt.attitude.rigid_smoother import boxminus, boxminus_body, boxplus, boxplus_body, rts_smooth_rigid
from gnssatt.attitude.rigid_update import rotation_exp
from gnssatt.attitude.settings import ALL_PHASES, AttitudeSettings
from gnssatt.attitude.smoother import rts_smooth
from tests.attitude.conftest import set_files


def test_boxplus_inverts_boxminus_and_measures_length_and_arc():
    rng = np.random.default_rng(5)
    b0 = rng.normal(size=(50, 3))
    b1 = b0 + 0.3 * rng.normal(size=(50, 3))
    d = boxminus(b1, b0)
    assert np.allclose(boxplus(b0, d), b1, atol=1e-12)
    n0, n1 = np.linalg.norm(b0, axis=1), np.linalg.norm(b1, axis=1)
    u0 = b0 / n0[:, None]
    radial = np.sum(d * u0, axis=1)
    ang = np.arccos(np.clip(np.sum(b0 * b1, axis=1) / (n0 * n1), -1, 1))
    assert np.allclose(radial, n1 - n0, atol=1e-12)                                   # the length difference
    assert np.allclose(np.linalg.norm(d - radial[:, None] * u0, axis=1), n0 * ang, atol=1e-12)   # |b0| x the arc
    assert np.allclose(boxminus(b0, b0), 0.0, atol=1e-15) and np.allclose(boxplus(b0, 0 * b0), b0, atol=1e-15)


def test_body_boxplus_inverts_body_boxminus_and_moves_a_rigid_body_rigidly():
    """Two baselines of one body: boxplus_body(b0, boxminus_body(b1, b0)) = b1 for bodies turned by up to ~0.1 rad with
    non-rigid moves besides (the fixed point converges as the angle: the filter's moves are mrad); a pure rotation
    of the body halved in the tangent space is a rotation of the body (the
    angle between the baselines and their lengths kept to 1e-12), where the per-baseline boxplus changes the angle at
    second order (> 1e-7 rad for a 5 mrad turn)."""
    rng = np.random.default_rng(7)
    b0 = np.array([[1.04653, -0.07191, 0.0], [0.0, 1.13969, 0.0]])
    for s in (1e-4, 1e-3, 1e-2, 0.05):
        b1 = (b0 + 1e-2 * s * rng.normal(size=b0.shape)) @ rotation_exp(s * rng.normal(size=3)).T
        d, R_m = boxminus_body(b1, b0)
        b2, R_p = boxplus_body(b0, d)
        assert np.abs(b2 - b1).max() < 1e-10 and np.abs(R_m - R_p).max() < 1e-9

    def angle(B):
        return np.arccos(B[0] @ B[1] / np.linalg.norm(B[0]) / np.linalg.norm(B[1]))

    b1 = b0 @ rotation_exp(np.array([3e-3, -3e-3, 2e-3])).T
    half, _ = boxplus_body(b0, 0.5 * boxminus_body(b1, b0)[0])
    assert abs(angle(half) - angle(b0)) < 1e-12
    assert np.allclose(np.linalg.norm(half, axis=1), np.linalg.norm(b0, axis=1), atol=1e-12)
    per_baseline = boxplus(b0, 0.5 * boxminus(b1, b0))
    assert abs(angle(per_baseline) - angle(b0)) > 1e-7


def _rigid_track(n, rng, step_m=2e-3, sr=1e-8, st=1e-6, q=4e-6):
    """One baseline of length 1 m turning by a random walk (step_m per epoch across b), after an omega block with
    no dynamics: forward posteriors on the sphere, each prior the previous posterior (Phi = I) with process noise q
    across b only; P radial sr, across st (m^2), in each epoch's own frame."""
    b = np.zeros((n, 3))
    b[0] = [1.0, 0.0, 0.0]
    for k in range(1, n):
        v = b[k - 1] + step_m * rng.normal(size=3)
        b[k] = v / np.linalg.norm(v)
    m = 6
    xf, xp = np.zeros((n, m)), np.zeros((n, m))
    Pf, Pp = np.zeros((n, m, m)), np.zeros((n, m, m))
    xf[:, 3:] = b
    for k in range(n):
        u = b[k]
        Pf[k, :3, :3] = 1e-6 * np.eye(3)
        Pf[k, 3:, 3:] = sr * np.outer(u, u) + st * (np.eye(3) - np.outer(u, u))
        if k:
            xp[k] = xf[k - 1]
            up = b[k - 1]
            Pp[k] = Pf[k - 1].copy()
            Pp[k, :3, :3] += 1e-8 * np.eye(3)
            Pp[k, 3:, 3:] += q * (np.eye(3) - np.outer(up, up))
        else:
            xp[k], Pp[k] = xf[k], Pf[k]
    start = np.zeros(n, bool)
    start[0] = True
    return xf, Pf, xp, Pp, np.repeat(np.eye(m)[None], n, 0), start


def test_rigid_backward_step_keeps_the_length_the_linear_one_shortens():
    """A 1 m baseline turning by 2 mm per epoch over 2000 epochs, no process noise along b: the tangent-space step
    keeps every smoothed length at 1 m (to rounding); the linear RTS step shortens them by its chords (the
    half-square of the across-b moves it does not carry back, summed over the later epochs: here > 0.1 mm)."""
    xf, Pf, xp, Pp, Phi, start = _rigid_track(2000, np.random.default_rng(11))
    xs_r, Ps_r = rts_smooth_rigid(xf, Pf, xp, Pp, Phi, start, 1)
    xs_l, _ = rts_smooth(xf, Pf, xp, Pp, Phi, start)
    L_r, L_l = np.linalg.norm(xs_r[:, 3:], axis=1), np.linalg.norm(xs_l[:, 3:], axis=1)
    assert np.abs(L_r - 1.0).max() < 1e-10, np.abs(L_r - 1.0).max()
    assert (1.0 - L_l).max() > 1e-4, (1.0 - L_l).max()
    # the direction moved: the smoother does something, and its radial variance stays that of the forward filter
    assert np.degrees(np.arccos(np.clip(np.sum(xs_r[:, 3:] * xf[:, 3:], 1), -1, 1))).max() > 0.01
    u = xs_r[:, 3:]
    assert np.allclose(np.einsum("ka,kab,kb->k", u, Ps_r[:, 3:, 3:], u), 1e-8, rtol=0.05)


def test_rigid_backward_step_is_the_linear_one_for_small_moves():
    """Moves of 1 um per epoch: chords and arcs differ by ~1e-12 m per epoch; both steps agree to 1e-9 m."""
    xf, Pf, xp, Pp, Phi, start = _rigid_track(300, np.random.default_rng(2), step_m=1e-6)
    xs_r, _ = rts_smooth_rigid(xf, Pf, xp, Pp, Phi, start, 1)
    xs_l, _ = rts_smooth(xf, Pf, xp, Pp, Phi, start)
    assert np.abs(xs_r - xs_l).max() < 1e-9


def test_rigid_smoother_on_a_clean_pass(clean_pass):
    """Clean 6-min pass (no PCO: the body length is the truth), dynamic mode, smoother: with `baseline_update:
    rigid` the smoothed lengths stay within 0.35 mm of the body length on each baseline (the length a few minutes
    of data give) and vary by under 0.05 mm over the fixed epochs (a length without process noise is one
    number for the smoother), and the smoothed attitude error std is within 3 % of the additive update's smoother
    or better."""
    from gnssatt.attitude.truth import attitude_errors_deg

    inputs = load_inputs(set_files(clean_pass))
    sols = {u: process(inputs, AttitudeSettings.preset("seed000", **ALL_PHASES, mode="dynamic", baseline_update=u,
                                                       smoothing={"enabled": True}))
            for u in ("additive", "rigid")}
    pl = json.loads((clean_pass / "platform.json").read_text())
    pos = {k: np.array(v["position_m"]) for k, v in pl["antennas"].items()}
    std = {}
    for u, sol in sols.items():
        _, de = attitude_errors_deg(clean_pass, sol)
        std[u] = de[sol.att_fixed].std(0)
    fr = sols["rigid"].fr
    for j, (a, b) in enumerate(pl["baselines"]):
        f = fr.fixed.all(axis=1)
        assert f.sum() > 200
        e_mm = (np.linalg.norm(fr.b_ecef_m[f, j], axis=1) - np.linalg.norm(pos[b] - pos[a])) * 1e3
        assert np.abs(e_mm).max() < 0.35 and np.ptp(e_mm) < 0.05, (j, e_mm.min(), e_mm.max())
    assert np.all(std["rigid"] < 1.03 * std["additive"]), std
