"""The triple-frequency ionosphere-free geometry-free combination of two antennas (seed 004 sec. 3.1, eq. 3-8,
Table 2, Appendix A).

Phi_125 = k1 Phi1 + k2 Phi2 + k5 Phi5 with sum(k) = 0 (geometry-free, A1) and sum(k / f^2) = 0 (ionosphere-free,
A2): one coefficient is free, k2 = a k1, k5 = -(1 + a) k1 (A3-A4). Phi1 comes from the auxiliary antenna, so
Phi_125 = k1 e . b_21 + A_125 + eps (eq. 7, 9): the yaw information is k1 times the single-frequency one while the
noise is sigma sqrt(k1^2 + k2^2 + k5^2) (eq. 8), and their ratio does not depend on the free parameter (A5).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from gnssatt.gnss.constants import C_M_S
from gnssatt.gnss.signals import FREQ_QZS_L1_HZ, FREQ_QZS_L2_HZ, FREQ_QZS_L5_HZ

__all__ = ["Coefficients", "table2_coefficients", "family_coefficients", "family_constant_a", "noise_factor",
           "combine"]


class Coefficients(NamedTuple):
    """Combination coefficients k1, k2, k5 (dimensionless) for frequencies f1, f2, f5 (Hz)."""

    k1: float
    k2: float
    k5: float
    f_hz: tuple[float, float, float]

    @property
    def k(self) -> np.ndarray:
        return np.array([self.k1, self.k2, self.k5])

    def windup_wavelength_m(self) -> float:
        """sum_i k_i lambda_i (m): the wind-up term's scale (Table 2: -0.199 cm)."""
        return float(np.sum(self.k * C_M_S / np.asarray(self.f_hz)))


def table2_coefficients(f1_hz: float = FREQ_QZS_L1_HZ, f2_hz: float = FREQ_QZS_L2_HZ,
                        f5_hz: float = FREQ_QZS_L5_HZ) -> Coefficients:
    """Eq. 4's coefficients: the difference of the L1/L2 and L1/L5 ionosphere-free combinations (Table 2:
    k1 = +0.285, k2 = -1.546, k5 = +1.261 for QZSS L1/L2/L5)."""
    a1, a2, a5 = f1_hz ** 2, f2_hz ** 2, f5_hz ** 2
    k1 = a1 / (a1 - a2) - a1 / (a1 - a5)
    k2 = -a2 / (a1 - a2)
    k5 = a5 / (a1 - a5)
    return Coefficients(k1, k2, k5, (f1_hz, f2_hz, f5_hz))


def family_constant_a(f1_hz: float = FREQ_QZS_L1_HZ, f2_hz: float = FREQ_QZS_L2_HZ,
                      f5_hz: float = FREQ_QZS_L5_HZ) -> float:
    """Appendix A's constant a with k2 = a k1 (A3): a = -(f1^2 f2^2 - f2^2 f5^2) / (f1^2 f2^2 - f1^2 f5^2).

    Erratum: seed 004 prints a without the minus sign; A1 and A2 give k2/k1 = (1/f1^2 - 1/f5^2) / (1/f5^2 -
    1/f2^2), which is the expression above (-5.421 for L1/L2/L5, so that Table 2's k2 = -1.546 = a 0.285).
    A5 holds for either sign."""
    a1, a2, a5 = f1_hz ** 2, f2_hz ** 2, f5_hz ** 2
    return -(a1 * a2 - a2 * a5) / (a1 * a2 - a1 * a5)


def family_coefficients(k1: float, f1_hz: float = FREQ_QZS_L1_HZ, f2_hz: float = FREQ_QZS_L2_HZ,
                        f5_hz: float = FREQ_QZS_L5_HZ) -> Coefficients:
    """The member of the one-parameter family with the given k1: k2 = a k1, k5 = -(1 + a) k1 (eq. A3-A4)."""
    a = family_constant_a(f1_hz, f2_hz, f5_hz)
    return Coefficients(float(k1), a * k1, -(1.0 + a) * k1, (f1_hz, f2_hz, f5_hz))


def noise_factor(c: Coefficients) -> float:
    """sqrt(k1^2 + k2^2 + k5^2): eq. 8's amplification of an equal per-signal phase noise (Table 2: 2.015)."""
    return float(np.sqrt(np.sum(c.k ** 2)))


def combine(c: Coefficients, phi1_m, phi2_m, phi5_m) -> np.ndarray:
    """Phi_125 (m) = k1 Phi1 + k2 Phi2 + k5 Phi5 (eq. 5) of phases in metres, any matching shapes."""
    return c.k1 * np.asarray(phi1_m) + c.k2 * np.asarray(phi2_m) + c.k5 * np.asarray(phi5_m)
