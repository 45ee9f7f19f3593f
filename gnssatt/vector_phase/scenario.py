"""A simulated single-antenna scenario with known truth: a ground platform rotating slowly about all three axes,
GPS satellites of the multi-antenna simulator's synthetic constellation, and carrier phases of eq. 35 with the
vector-phase term of eq. 32 (tests, bench and the job test).

Truth: body attitude R_body_from_ned = euler321(yaw0 + yaw_rate t, pitch_amp sin(2 pi t / period_s),
roll_amp sin(2 pi t / (0.7 period_s) + 1)), body z down, antenna boresight body -z (up); the receiver clock a
random walk in cycles; satellites at emission time (light time iterated, Earth rotation during the flight
applied), their attitude nominal yaw steering (gnssatt.vector_phase.satellite_attitude). Phase = rho / lambda
+ b + delta / (2 pi) + N + white noise (cycles), N a random integer per satellite.
Neglects: atmosphere, multipath, satellite clock (the user corrects it from the ephemeris), cycle slips.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from gnssatt.gnss.frames import R_ned_from_ecef, geodetic_to_ecef
from gnssatt.gnss.geometry import R_antenna_from_body
from gnssatt.gnss.rotations import euler321_to_dcm
from gnssatt.gnss.time import GpsTime
from gnssatt.sim.constellation import synthetic_gps
from gnssatt.vector_phase.phase_model import AntennaMount, delta_rad
from gnssatt.vector_phase.satellite_attitude import nominal_yaw_steering

__all__ = ["ScenarioSpec", "PhaseObservations", "Truth", "simulate", "C_M_S"]

C_M_S = 299792458.0
OMEGA_E_RAD_S = 7.2921151467e-5


@dataclass(frozen=True)
class ScenarioSpec:
    """What to simulate. n_sats: the highest satellites at the start (>= 6); sigma_phase_cyc: white phase noise;
    elevation_mask_deg: satellites below it (local level) are not chosen; velocity_ecef_m_s: a constant velocity
    of the antenna (non-zero: obs.velocity_ecef_m_s carries it, as a set's velocity.csv would)."""

    antenna: object
    n_epochs: int = 60
    interval_s: float = 1.0
    n_sats: int = 8
    sigma_phase_cyc: float = 0.002
    seed: int = 1
    start: tuple = (2018, 6, 6, 12, 0, 0.0)
    lat_deg: float = 45.3
    lon_deg: float = -75.8
    height_m: float = 100.0
    yaw0_deg: float = 30.0
    yaw_rate_deg_s: float = 0.5
    pitch_amp_deg: float = 10.0
    roll_amp_deg: float = 8.0
    period_s: float = 120.0
    clock_rw_cyc: float = 0.5
    elevation_mask_deg: float = 10.0
    boresight_body: tuple = (0.0, 0.0, -1.0)
    velocity_ecef_m_s: tuple = (0.0, 0.0, 0.0)


@dataclass
class PhaseObservations:
    """One antenna's carrier phases and the known satellite geometry: t_gps_s (n_ep,), sats (n_sv,), phase_cyc
    (n_ep, n_sv) NaN where not tracked, r_sat_ecef_m / x_sat_ecef / y_sat_ecef (n_ep, n_sv, 3), arc_start
    (n_ep, n_sv) True at the first epoch of each continuous arc (a new unknown N)."""

    t_gps_s: np.ndarray
    sats: list
    phase_cyc: np.ndarray
    r_sat_ecef_m: np.ndarray
    x_sat_ecef: np.ndarray
    y_sat_ecef: np.ndarray
    arc_start: np.ndarray
    sigma_phase_cyc: float = 0.002
    warnings: list = field(default_factory=list)
    velocity_ecef_m_s: np.ndarray | None = None

    def subset(self, columns) -> "PhaseObservations":
        """The same observations for a subset of satellites (column indices)."""
        idx = np.asarray(columns)
        return replace(self, sats=[self.sats[i] for i in idx], phase_cyc=self.phase_cyc[:, idx],
                       r_sat_ecef_m=self.r_sat_ecef_m[:, idx], x_sat_ecef=self.x_sat_ecef[:, idx],
                       y_sat_ecef=self.y_sat_ecef[:, idx], arc_start=self.arc_start[:, idx])


@dataclass
class Truth:
    """position_ecef_m (3,) at the first epoch, R_body_from_ecef (n_ep, 3, 3), clock_cyc (n_ep,), R_ned_from_ecef (3, 3); the
    constellation (gnssatt.sim.constellation.Constellation), the first epoch t0 (GpsTime) and the chosen
    satellite indices, to write the set as files (gnssatt.sim.vector_phase_set)."""

    position_ecef_m: np.ndarray
    R_body_from_ecef: np.ndarray
    clock_cyc: np.ndarray
    R_ned_from_ecef: np.ndarray
    constellation: object = None
    t0: object = None
    sat_index: np.ndarray | None = None


def _emission_positions(const, t_rx_s, r_rx, n_iter: int = 3):
    """Satellite ECEF positions at emission, in the ECEF frame at reception (n_ep, n_sv, 3)."""
    tau = np.full((len(t_rx_s), const.n), 0.075)
    for _ in range(n_iter):
        r_sat, _ = const.position_clock(t_rx_s[:, None] - tau)
        ang = OMEGA_E_RAD_S * tau
        c, s = np.cos(ang), np.sin(ang)
        r_rot = np.stack([c * r_sat[..., 0] + s * r_sat[..., 1], -s * r_sat[..., 0] + c * r_sat[..., 1],
                          r_sat[..., 2]], -1)
        tau = np.linalg.norm(r_rot - r_rx, axis=-1) / C_M_S
    return r_rot


def simulate(spec: ScenarioSpec) -> tuple[PhaseObservations, Truth, AntennaMount]:
    """(observations, truth, antenna mount) of the scenario."""
    rng = np.random.default_rng(spec.seed)
    t0 = GpsTime.from_calendar(*spec.start)
    const = synthetic_gps(t0)
    dt = np.arange(spec.n_epochs) * spec.interval_s
    t_since_ref = (t0 - const.t_ref) + dt
    lat, lon = np.radians(spec.lat_deg), np.radians(spec.lon_deg)
    r_rx = geodetic_to_ecef(lat, lon, spec.height_m)
    R_ned = R_ned_from_ecef(lat, lon)
    v_rx = np.asarray(spec.velocity_ecef_m_s, float)
    r_rx_t = (r_rx + dt[:, None] * v_rx)[:, None, :]                     # (n_ep, 1, 3)
    r_sat = _emission_positions(const, t_since_ref, r_rx_t)
    e0 = (r_sat[0] - r_rx) / np.linalg.norm(r_sat[0] - r_rx, axis=-1, keepdims=True)
    up = -R_ned[2]
    el_deg = np.degrees(np.arcsin(np.clip(e0 @ up, -1, 1)))
    e_end = r_sat[-1] - r_rx
    el_end = np.degrees(np.arcsin(np.clip((e_end / np.linalg.norm(e_end, axis=-1, keepdims=True)) @ up, -1, 1)))
    ok = np.flatnonzero((el_deg > spec.elevation_mask_deg) & (el_end > spec.elevation_mask_deg))
    chosen = ok[np.argsort(-el_deg[ok])][: spec.n_sats]
    if len(chosen) < spec.n_sats:
        raise ValueError(f"only {len(chosen)} satellites above {spec.elevation_mask_deg} deg in this scenario")
    chosen = np.sort(chosen)
    r_sat = r_sat[:, chosen]
    t_gps = float(t0.seconds()) + dt
    x_s, y_s = nominal_yaw_steering(t_gps[:, None], r_sat)
    tt = dt
    yaw = spec.yaw0_deg + spec.yaw_rate_deg_s * tt
    pitch = spec.pitch_amp_deg * np.sin(2 * np.pi * tt / spec.period_s)
    roll = spec.roll_amp_deg * np.sin(2 * np.pi * tt / (0.7 * spec.period_s) + 1.0)
    R_body = euler321_to_dcm(yaw, pitch, roll) @ R_ned
    mount = AntennaMount(spec.antenna, R_antenna_from_body(np.asarray(spec.boresight_body, float)))
    d = r_sat - r_rx_t
    rho = np.linalg.norm(d, axis=-1)
    delta = np.unwrap(delta_rad(mount, R_body, d / rho[..., None], x_s, y_s), axis=0)
    clock = np.concatenate([[0.0], np.cumsum(rng.normal(0, spec.clock_rw_cyc, spec.n_epochs - 1))]) + 0.3
    n_int = rng.integers(-10**6, 10**6, len(chosen))
    phase = (rho / mount.wavelength_m + clock[:, None] + delta / (2 * np.pi) + n_int
             + rng.normal(0, spec.sigma_phase_cyc, rho.shape))
    arc = np.zeros(phase.shape, bool)
    arc[0] = True
    obs = PhaseObservations(t_gps, [const.sats[i] for i in chosen], phase, r_sat, x_s, y_s, arc,
                            spec.sigma_phase_cyc,
                            velocity_ecef_m_s=np.tile(v_rx, (spec.n_epochs, 1)) if np.any(v_rx) else None)
    return obs, Truth(r_rx, R_body, clock, R_ned, const, t0, chosen), mount
