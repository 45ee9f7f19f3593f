"""Settings of the GPS + gyro fusion, nested by concern (seed 002 Table 1 models and the FDI control parameters).

Defaults are seed 002 Table 1: gyro long-term stability 48 urad/s (10 deg/h) as the Gauss-Markov sigma of the
drift, random walk 20 urad/sqrt(s) (0.066 deg/sqrt(h)); L1 phase 1 % of a wavelength (1.9 mm) before
differencing; 15 deg mask; kappa = 3 (sec. 3.1); five delayed propagators (sec. 4.3: "after 5 time delays, the
gain in the fault detection was marginal").
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["GyroNoise", "GpsNoise", "GpsFdi", "GyroFdi", "FusionSettings"]

L1_WAVELENGTH_M = 299792458.0 / 1575.42e6


@dataclass
class GyroNoise:
    """Gyro model of sec. 2.2: omega_m = omega + beta_omega + e_omega, beta_omega first-order Gauss-Markov."""

    arw_rad_sqrt_s: float = 0.066 * np.pi / 180.0 / 60.0      # e_omega: angle random walk N (Table 1)
    drift_sigma_rad_s: float = 10.0 * np.pi / 180.0 / 3600.0  # beta_omega steady-state sigma (Table 1 stability)
    drift_tau_s: float = 1800.0                               # tau_omega (not in Table 1; the simulator's)
    initial_drift_sigma_rad_s: float = 10.0 * np.pi / 180.0 / 3600.0


@dataclass
class GpsNoise:
    """Undifferenced L1 phase error per satellite: white (thermal) + multipath growing to the antenna horizon."""

    phase_sigma_m: float = 0.01 * L1_WAVELENGTH_M     # Table 1: 1 % of the L1 wavelength
    multipath_zenith_m: float = 0.0005                # multipath sigma at boresight ...
    multipath_horizon_m: float = 0.004                # ... at the antenna horizon (quadratic in off-boresight angle)
    multipath_cap_m: float = 0.010
    multipath_tau_s: float = 60.0                     # tau_theta of the GPS attitude's Gauss-Markov part
    elevation_mask_deg: float = 15.0                  # antenna-frame elevation (Table 1 mask angle)
    min_satellites: int = 4


@dataclass
class GpsFdi:
    """Exclusion bank of sec. 3.1: threshold from kappa, by default the chi-square quantile with the normal
    kappa-sigma tail; threshold_model "gaussian" is the paper's J* = mu + kappa sigma_J, sigma_J = sqrt(2 mu)
    (gnssatt.gyro.exclusion_bank.threshold)."""

    kappa: float = 3.0
    enabled: bool = True
    threshold_model: str = "chi2"


@dataclass
class GyroFdi:
    """Bank of delayed propagators of sec. 3.2: propagator j starts j * delay_step_s in the past."""

    n_propagators: int = 5
    delay_step_s: float = 60.0
    threshold_sigma: float = 5.0          # |residual| / its theoretical sigma on any axis ...
    persistence: int = 3                  # ... in this many consecutive GPS epochs flags the gyro
    reference: str = "filter"             # "filter": vs the posterior; "independent": own delayed EKFs; "gps"
    clear_after: int = 6                  # epochs below the threshold that end a gyro fault event
    fault_drift_sigma_rad_s: float = 10 * 10.0 * np.pi / 180.0 / 3600.0   # drift uncertainty added on detection

    def __post_init__(self):
        if self.reference not in ("filter", "gps", "independent"):
            raise ValueError(f"gyro_fdi.reference is {self.reference!r}; use 'independent' (own delayed filters "
                             "against the snapshot), 'filter' (the filter's posterior) or 'gps' (the snapshot "
                             "attitude)")


@dataclass
class FusionSettings:
    """All settings of one fusion run; see docs/gyro_fusion.md."""

    gyro: GyroNoise = field(default_factory=GyroNoise)
    gps: GpsNoise = field(default_factory=GpsNoise)
    gps_fdi: GpsFdi = field(default_factory=GpsFdi)
    gyro_fdi: GyroFdi = field(default_factory=GyroFdi)
    initial_q_body_from_ecef: tuple | None = None     # None: Earth pointing (the orbital frame) at the first epoch
    max_prior_angle_deg: float = 5.0                  # largest attitude uncertainty the integer search accepts

    @classmethod
    def from_dict(cls, d: dict | None) -> "FusionSettings":
        """Settings from a nested dict {"gyro": {...}, "gps": {...}, "gps_fdi": {...}, "gyro_fdi": {...}, ...}."""
        d = dict(d or {})
        groups = {"gyro": GyroNoise, "gps": GpsNoise, "gps_fdi": GpsFdi, "gyro_fdi": GyroFdi}
        kw = {k: groups[k](**d.pop(k)) for k in list(d) if k in groups}
        return cls(**kw, **d)
