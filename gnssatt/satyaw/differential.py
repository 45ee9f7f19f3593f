"""Differential observations of one satellite's two antennas seen by ground stations (seed 004 sec. 2, eq. 9).

Auxiliary minus main antenna, same frequency and same receiver: orbit, clocks, troposphere and ionosphere
cancel, leaving  d = k e . (O R(yaw) b) + pcv + A + eps  with e the unit line of sight receiver -> satellite in
ECEF, O R(yaw) the body -> ECEF rotation, b the main -> auxiliary antenna vector in the body frame, A a constant
per station arc (phase: ambiguity; code: differential code bias) and k = 1 (single frequency) or k1 (the
triple-frequency combination, gnssatt.satyaw.triple_frequency).

Observations are flat rows (n,) over (epoch, station); a `SatGeometry` holds the per-epoch orbit quantities.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnssatt.satyaw.attitude_models import (nominal_yaw_deg, nominal_yaw_rate_deg_s, orbit_angles,
                                            R_ecef_from_body)

__all__ = ["SatGeometry", "DiffObs", "satellite_geometry", "body_los", "yaw_coefficients", "split_arcs",
           "nadir_azimuth_deg", "observability"]


@dataclass
class SatGeometry:
    """Per-epoch geometry of one satellite: t_s (T,) seconds from the first epoch; R_orbital_from_ecef (T, 3, 3);
    nominal_yaw_deg, nominal_rate_deg_s, beta_deg, mu_deg (T,); r_sat_ecef_m (T, 3)."""

    t_s: np.ndarray
    R_orbital_from_ecef: np.ndarray
    nominal_yaw_deg: np.ndarray
    nominal_rate_deg_s: np.ndarray
    beta_deg: np.ndarray
    mu_deg: np.ndarray
    r_sat_ecef_m: np.ndarray


def satellite_geometry(t_s, r_sat_ecef_m, v_sat_ecef_m_s, r_sun_ecef_m) -> SatGeometry:
    """SatGeometry from satellite states (T, 3) and the Sun (T, 3) in ECEF at times t_s (T,)."""
    ang = orbit_angles(r_sat_ecef_m, v_sat_ecef_m_s, r_sun_ecef_m)
    nominal = nominal_yaw_deg(r_sat_ecef_m, v_sat_ecef_m_s, r_sun_ecef_m)
    rate = nominal_yaw_rate_deg_s(ang.beta_deg, ang.mu_deg, ang.mu_rate_deg_s)
    return SatGeometry(np.asarray(t_s, dtype=np.float64), ang.R_orbital_from_ecef, nominal, rate,
                       ang.beta_deg, ang.mu_deg, np.asarray(r_sat_ecef_m, dtype=np.float64))


@dataclass
class DiffObs:
    """Flat differential observations of one satellite.

    epoch, station, group (n,) int: epoch index into the SatGeometry, station index into `stations`, and the
    group whose constant (ambiguity or code bias, metres) the row shares (one group per station arc and type);
    value_m (n,): observed differential (m); sigma_m (n,): a priori sigma; is_code (n,) bool;
    los_ecef (n, 3): unit line of sight receiver -> satellite; k (float): geometry factor (1 or k1).
    group_station (n_groups,) and group_is_code (n_groups,) describe the groups.
    """

    epoch: np.ndarray
    station: np.ndarray
    group: np.ndarray
    value_m: np.ndarray
    sigma_m: np.ndarray
    is_code: np.ndarray
    los_ecef: np.ndarray
    stations: list[str]
    group_station: np.ndarray
    group_is_code: np.ndarray
    k: float = 1.0
    warnings: list[str] = field(default_factory=list)

    @property
    def n_groups(self) -> int:
        return int(len(self.group_station))

    def select(self, mask) -> "DiffObs":
        """The rows where mask holds, with groups renumbered (groups left empty are dropped)."""
        m = np.asarray(mask, dtype=bool)
        used, new_group = np.unique(self.group[m], return_inverse=True)
        return DiffObs(self.epoch[m], self.station[m], new_group.astype(np.int64), self.value_m[m],
                       self.sigma_m[m], self.is_code[m], self.los_ecef[m], list(self.stations),
                       self.group_station[used], self.group_is_code[used], self.k, list(self.warnings))


def body_los(R_orbital_from_ecef_rows, yaw_deg, los_ecef) -> np.ndarray:
    """(n, 3) line of sight receiver -> satellite in the body frame: R_body_from_ecef e."""
    R = R_ecef_from_body(R_orbital_from_ecef_rows, yaw_deg)
    return np.einsum("nji,nj->ni", R, los_ecef)


def yaw_coefficients(R_orbital_from_ecef_rows, los_ecef, baseline_body_m, k: float = 1.0):
    """(a, b, c) per row with k e . (O R(yaw) b) = a cos(yaw) + b sin(yaw) + c (seed 004 eq. 9 expanded).

    With e_o = R_orbital_from_ecef e: a = k (bx e_xo + by e_yo), b = k (bx e_yo - by e_xo), c = k bz e_zo.
    """
    e_o = np.einsum("nij,nj->ni", R_orbital_from_ecef_rows, los_ecef)
    bx, by, bz = (float(v) for v in baseline_body_m)
    a = k * (bx * e_o[:, 0] + by * e_o[:, 1])
    b = k * (bx * e_o[:, 1] - by * e_o[:, 0])
    c = k * bz * e_o[:, 2]
    return a, b, c


def nadir_azimuth_deg(e_body) -> tuple[np.ndarray, np.ndarray]:
    """Nadir (off-boresight) angle and azimuth (from body +x towards +y), degrees, of the direction
    satellite -> receiver, -e_body (n, 3): the grid of the differential PCV map (CONVENTIONS.md)."""
    d = -np.asarray(e_body)
    nadir = np.degrees(np.arccos(np.clip(d[:, 2], -1.0, 1.0)))
    az = np.mod(np.degrees(np.arctan2(d[:, 1], d[:, 0])), 360.0)
    return nadir, az


def observability(los_ecef, R_ecef_from_body_rows, baseline_body_m) -> np.ndarray:
    """(n,) length of the unit baseline's projection on the plane normal to the line of sight (0-1);
    CONVENTIONS.md's yaw.csv `observability` is its RMS over the stations of an epoch."""
    b = np.asarray(baseline_body_m, dtype=np.float64)
    b_e = np.einsum("nij,j->ni", R_ecef_from_body_rows, b / np.linalg.norm(b))
    along = np.einsum("ni,ni->n", b_e, los_ecef)
    return np.sqrt(np.clip(1.0 - along * along, 0.0, 1.0))


def split_arcs(epoch, station, phase_m, lli=None, *, max_gap_epochs: int = 3, slip_m: float = 0.05) -> np.ndarray:
    """Arc number (n,) of each row: a new arc per station at a gap of more than max_gap_epochs, a loss-of-lock
    flag, or a jump of the differential phase between consecutive epochs above slip_m (a cycle slip: the
    differential geometry changes by well under 1 mm/s). Rows must be sorted by (station, epoch)."""
    epoch = np.asarray(epoch)
    station = np.asarray(station)
    ph = np.asarray(phase_m, dtype=np.float64)
    new = np.ones(len(epoch), dtype=bool)
    if len(epoch) > 1:
        same = station[1:] == station[:-1]
        gap = (epoch[1:] - epoch[:-1]) > max_gap_epochs
        jump = np.abs(np.diff(ph)) > slip_m
        new[1:] = ~same | gap | jump
    if lli is not None:
        new |= (np.asarray(lli) > 0) & (np.asarray(lli) % 2 == 1)
    return np.cumsum(new) - 1
