"""The one wrong-fix definition (gnssatt.attitude.wrong_fix) on hand-made errors and sigmas."""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.wrong_fix import classify_fixed_errors, over_1deg_label


def test_wrong_needs_both_six_sigmas_and_one_degree_on_the_same_axis():
    err = np.array([[2.0, 0.0, 0.0],      # 2 deg at 0.1 deg sigma: wrong
                    [2.0, 0.0, 0.0],      # 2 deg at 0.5 deg sigma (4 sigma): over 1 deg, noise
                    [0.9, 0.0, 0.0],      # 9 sigma but under 1 deg: neither
                    [1.5, 0.8, 0.0],      # yaw over 1 deg within 6 sigma, pitch 8 sigma under 1 deg: over, not wrong
                    [np.nan, np.nan, np.nan],   # no reference: neither
                    [0.0, -3.0, 0.0]])    # a negative error counts by its size: wrong on pitch
    sig = np.array([[0.1, 0.1, 0.1], [0.5, 0.1, 0.1], [0.1, 0.1, 0.1], [0.5, 0.1, 0.1], [0.1, 0.1, 0.1],
                    [0.1, 0.2, 0.1]])
    c = classify_fixed_errors(err, sig)
    assert c.wrong.tolist() == [True, False, False, False, False, True]
    assert c.over_1deg.tolist() == [False, True, False, True, False, False]
    assert c.worst_axis[5] == 1 and c.worst_axis[3] == 1    # pitch: 8 sigma beats yaw's 3 sigma


def test_over_one_degree_labels():
    assert over_1deg_label(2.0, 0.5) == "noise"
    assert over_1deg_label(-2.0, 0.3) == "large"
    assert classify_fixed_errors(np.zeros((0, 3)), np.zeros((0, 3))).wrong.shape == (0,)
