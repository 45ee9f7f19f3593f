"""Triple-frequency ionosphere-free geometry-free combination against seed 004 Table 2 and Appendix A."""
import numpy as np
import pytest

from gnssatt.satyaw.triple_frequency import (combine, family_coefficients, family_constant_a, noise_factor,
                                             table2_coefficients)

F1, F2, F5 = 1575.42e6, 1227.60e6, 1176.45e6


def test_table2_values():
    c = table2_coefficients()
    # Table 2 prints three decimals
    assert c.k1 == pytest.approx(0.285, abs=5e-4)
    assert c.k2 == pytest.approx(-1.546, abs=5e-4)
    assert c.k5 == pytest.approx(1.261, abs=5e-4)
    assert noise_factor(c) == pytest.approx(2.015, abs=5e-4)          # eq. 8
    assert c.windup_wavelength_m() == pytest.approx(-0.00199, abs=5e-6)  # -0.199 cm


@pytest.mark.parametrize("k1", [0.285, 1.0, -0.7, 3.2])
def test_family_is_geometry_and_ionosphere_free_with_constant_ratio(k1):
    c = family_coefficients(k1)
    assert np.sum(c.k) == pytest.approx(0.0, abs=1e-12)                       # A1
    assert np.sum(c.k / np.array([F1, F2, F5]) ** 2) * F1 ** 2 == pytest.approx(0.0, abs=1e-12)  # A2
    a = family_constant_a()
    # seed 004 prints a without its minus sign (erratum, see family_constant_a); Table 2 fixes the sign
    assert a == pytest.approx(-(F1**2 * F2**2 - F2**2 * F5**2) / (F1**2 * F2**2 - F1**2 * F5**2), rel=1e-12)
    assert a == pytest.approx(-1.546 / 0.285, rel=2e-3)
    # A5: sigma_125 / sigma = |k1| sqrt(2 (1 + a + a^2)); the information/noise ratio k1/factor is constant
    assert noise_factor(c) == pytest.approx(abs(k1) * np.sqrt(2 * (1 + a + a * a)), rel=1e-12)
    t2 = table2_coefficients()
    assert abs(c.k1) / noise_factor(c) == pytest.approx(t2.k1 / noise_factor(t2), rel=1e-12)
    # Table 2 itself is the member with its k1
    np.testing.assert_allclose(family_coefficients(t2.k1).k, t2.k, rtol=1e-12)


def test_combination_removes_geometry_and_ionosphere_and_keeps_k1_baseline():
    rng = np.random.default_rng(3)
    n = 50
    rho = 3.7e7 + rng.normal(0, 1e3, n)        # common geometry/clocks/troposphere (m)
    iono_l1 = rng.uniform(1, 20, n)            # L1 ionospheric delay (m), scaled by 1/f^2
    proj = rng.uniform(-1.5, 1.5, n)           # e . b21 (m), on the auxiliary antenna's L1 only
    phis = []
    for f, extra in ((F1, proj), (F2, 0.0), (F5, 0.0)):
        phis.append(rho - iono_l1 * (F1 / f) ** 2 + extra)
    for k1 in (0.285, 2.0):
        c = family_coefficients(k1)
        np.testing.assert_allclose(combine(c, *phis), k1 * proj, atol=2e-6)  # float64 of ~4e7 m terms
