"""Dynamic mode's length constraint (gnssatt.attitude.length_constraint, issue 21 item 2): the projection's
algebra, and on a short clean pass the lengths held to the body length without harming the attitude."""
from __future__ import annotations

import json

import numpy as np

from gnssatt.attitude.length_constraint import project_lengths, rescale_lengths
from gnssatt.attitude.process import load_inputs, process
from gnssatt.attitude.settings import ALL_PHASES, AttitudeSettings
from tests.attitude.conftest import set_files


def test_projection_moves_the_length_by_the_soft_constraint_gain_along_b_only():
    """b = (1.002, 0, 0) m, body length 1 m, radial variance (0.2 mm)^2, sigma_L 0.2 mm: half of the 2 mm goes
    (gain P_r / (P_r + sigma^2) = 0.5) along b; its direction, every other state and P are untouched; an inactive
    baseline is left alone."""
    x = np.array([0.3, 1.002, 0.0, 0.0])                  # state 0 correlated with b's radial component
    P = np.diag([1e-4, 4e-8, 1e-6, 1e-6])
    P[0, 1] = P[1, 0] = 1e-6
    P0 = P.copy()
    dl = project_lengths(x, P, np.array([[1, 2, 3]]), np.array([1.0]), 2e-4, np.array([True]))
    assert abs(dl[0] + 1e-3) < 1e-12
    assert abs(x[1] - 1.001) < 1e-12 and x[2] == 0.0 and x[3] == 0.0 and x[0] == 0.3
    assert np.array_equal(P, P0)
    x2 = np.array([0.3, 1.002, 0.0, 0.0])
    assert project_lengths(x2, P, np.array([[1, 2, 3]]), np.array([1.0]), 2e-4, np.array([False]))[0] == 0.0
    assert x2[1] == 1.002


def test_rescale_lengths_keeps_directions():
    b = np.array([[[3.0, 4.0, 0.0], [0.0, 0.0, 2.0]]])
    out = rescale_lengths(b, np.array([[1.0, 0.5]]))
    assert np.allclose(out, [[[0.6, 0.8, 0.0], [0.0, 0.0, 0.5]]], atol=1e-15)


def test_dynamic_lengths_stay_at_the_body_length_on_a_clean_pass(clean_pass):
    """Clean 6-min pass (white noise, no PCO: the body length is the truth), dynamic mode, forward filter and
    smoother: with the constraint (0.5 mm) the mean length error over fixed epochs is within 0.1 mm (the filter's
    length sigma ~0.1 mm) on each baseline, and the attitude error std within 5 % of the run without it (or
    better; the 106-min passes: docs/BENCHMARKS.md "Dynamic-mode lengths")."""
    from gnssatt.attitude.truth import attitude_errors_deg

    inputs = load_inputs(set_files(clean_pass))
    sols = {(sg, sm): process(inputs, AttitudeSettings.preset("seed000", **ALL_PHASES, mode="dynamic", smoother=sm,
                                                              length_constraint_sigma_m=sg))
            for sg in (0.0, 5e-4) for sm in (False, True)}
    pl = json.loads((clean_pass / "platform.json").read_text())
    pos = {k: np.array(v["position_m"]) for k, v in pl["antennas"].items()}
    L = np.array([np.linalg.norm(pos[b] - pos[a]) for a, b in pl["baselines"]])
    std = {}
    for (sg, sm), sol in sols.items():
        _, de = attitude_errors_deg(clean_pass, sol)
        std[sg, sm] = de[sol.att_fixed].std(0)
        if sg:
            fr = sol.fr
            for j in range(fr.fixed.shape[1]):
                f = fr.fixed[:, j]
                assert f.sum() > 200
                err_mm = (np.linalg.norm(fr.b_ecef_m[f, j], axis=1) - L[j]) * 1e3
                assert abs(err_mm.mean()) < 0.1, (sm, j, err_mm.mean())
    for sm in (False, True):
        assert np.all(std[5e-4, sm] < 1.05 * std[0.0, sm]), std
