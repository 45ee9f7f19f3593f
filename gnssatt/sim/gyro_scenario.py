"""A simulated GPS + MEMS gyro set after seed 002 sec. 4.3 and Table 1: three antennas on a 0.6 m square, L1
only at 0.2 Hz with 1 % of a wavelength of phase noise and medium multipath, a 650 km circular equatorial or
polar orbit, Earth pointing with residual oscillations (< 1 deg, < 0.1 deg/s), a 10 Hz gyro log, and the
injected faults (GPS phase jumps, a GPS outage, a gyro drift fault), each written to truth/.

Built on gnssatt.sim.simulate_set (the "earth-pointing" preset with overrides); the true attitude at the gyro rate
comes from the set's reference attitude written noise-free at the gyro interval, then moved to
truth/attitude_gyro_rate.csv (the set keeps no reference attitude). "Medium multipath" is the simulator's default
phase multipath (0.5 mm at boresight to 4 mm at the antenna horizon, Gauss-Markov 60 s): half of the strong level
of the "hard" preset, as seed 002 takes 50 % of its strong multipath case.
"""
from __future__ import annotations

import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gnssatt.gnss.time import GpsTime
from gnssatt.sim.api import SimulatedSet, simulate_set
from gnssatt.sim.gps_faults import PhaseFault, fault_schedule, inject_outage, inject_phase_faults
from gnssatt.sim.gyro import GyroErrorModel, simulate_gyro

__all__ = ["GyroScenario", "GyroSet", "simulate_gyro_set", "SQUARE_0P6_ANTENNAS", "ORBIT_PERIOD_650KM_S"]

L1_WAVELENGTH_M = 299792458.0 / 1575.42e6
#: 650 km circular orbit period, s: 2 pi sqrt(a^3 / GM), a = 6378.137 + 650 km, GM = 3.986004418e14
ORBIT_PERIOD_650KM_S = float(2 * np.pi * np.sqrt((6378137.0 + 650e3) ** 3 / 3.986004418e14))
#: seed 002 sec. 4: master at a corner, antenna 2 along body x, antenna 1 along body y (0.6 m, Table 1)
SQUARE_0P6_ANTENNAS = {
    "ANT-0": {"position_m": [0.0, 0.0, 0.0], "boresight": [0, 0, -1]},
    "ANT-1": {"position_m": [0.0, 0.6, 0.0], "boresight": [0, 0, -1]},
    "ANT-2": {"position_m": [0.6, 0.0, 0.0], "boresight": [0, 0, -1]},
}


@dataclass(frozen=True)
class GyroScenario:
    """What to simulate. Times in seconds after the first epoch."""

    orbit: str = "equatorial"                  # equatorial (i = 0 deg) | polar (i = 90 deg)
    duration_s: float = ORBIT_PERIOD_650KM_S
    gps_interval_s: float = 5.0                # 0.2 Hz
    gyro_interval_s: float = 0.1               # 10 Hz
    phase_sigma_m: float = 0.01 * L1_WAVELENGTH_M
    wobble_amp_deg: tuple = (0.7, 0.7, 0.7)
    wobble_period_s: tuple = (150.0, 110.0, 130.0)
    gps_fault_interval_s: float = 0.0          # 0: none; 60 for Table 1
    gps_fault_size_cyc: float = 0.35
    fault_min_elevation_deg: float = 15.0      # faults only on satellites above this (the processing's mask)
    outages: tuple = ()                        # ((start_s, duration_s), ...)
    gyro: GyroErrorModel = field(default_factory=GyroErrorModel)
    start_gps: str = "2018-06-06T12:20:00"
    overrides: dict = field(default_factory=dict)   # further simulate_set parameters


@dataclass
class GyroSet:
    """A simulated set with its gyro log and the injected faults."""

    sim: SimulatedSet
    gyro_csv: Path
    scenario: GyroScenario
    t0: GpsTime
    gps_faults: list = field(default_factory=list)     # PhaseFault
    outages_gps_s: list = field(default_factory=list)  # (start, end) GPS seconds

    @property
    def files(self) -> list[Path]:
        """The upload: the observation set's files plus the gyro log."""
        return self.sim.files + [self.gyro_csv]


def _sim_overrides(sc: GyroScenario) -> dict:
    inc = {"equatorial": 0.0, "polar": 90.0}[sc.orbit]
    return {"antennas": SQUARE_0P6_ANTENNAS, "master": "ANT-0", "platform_name": "seed002-0.6m",
            "perigee_alt_km": 650.0, "apogee_alt_km": 650.0, "inclination_deg": inc, "signals": ["L1"],
            "start_gps": sc.start_gps, "duration_s": float(sc.duration_s), "interval_s": sc.gps_interval_s,
            "noise_phase_m": sc.phase_sigma_m, "noise_grows_with_cn0": False, "pcv": False, "pco_scatter_mm": 0.0,
            "acquisition_delays": False, "wobble_amp_deg": list(sc.wobble_amp_deg),
            "wobble_period_s": list(sc.wobble_period_s), "reference_interval_s": sc.gyro_interval_s,
            "reference_sigma_arcsec": 0.0, "truth_components": False, **sc.overrides}


def _true_attitude(ref_csv: Path) -> tuple[GpsTime, np.ndarray]:
    from gnssatt.gnss.io.reference_attitude import read_reference_attitude

    ref = read_reference_attitude(ref_csv.read_bytes(), ref_csv.name)
    return ref.time, ref.q_body_from_frame


def _visibility(sim: SimulatedSet, mask_deg: float) -> tuple[np.ndarray, dict]:
    """(epoch GPS seconds, epoch -> satellites with L1 phase on every antenna and at least mask_deg above every
    antenna's horizon at the true attitude): the satellites a receiver with that mask would use."""
    from gnssatt.gnss import rotations as rot
    from gnssatt.gnss.io.sniff import identify
    from gnssatt.gyro.gps_data import load_gps

    files = [(p.name, identify(p, p.name)[0], p) for p in sim.files]
    gps = load_gps(files)
    q_be = np.loadtxt(sim.truth_dir / "attitude.csv", delimiter=",", skiprows=1, usecols=range(3, 7), ndmin=2)
    R_be = rot.quat_to_dcm(q_be)                                       # truth rows: every epoch, same order
    t = gps.time.s.astype(float) + gps.time.frac
    vis = {}
    for k, te in enumerate(t):
        ok = np.flatnonzero(gps.valid[k])
        el = np.degrees(np.arcsin(np.clip((gps.los_ecef[k, ok] @ R_be[k].T) @ gps.boresight_body.T, -1, 1)))
        vis[float(te)] = [gps.sats[j] for j in ok[el.min(axis=1) >= mask_deg]]
    return t, vis


def simulate_gyro_set(sc: GyroScenario, out_dir: str | Path, *, seed: int = 0) -> GyroSet:
    """Simulate the set of `sc` into out_dir: RINEX/nav/SP3/platform.json, gyro.csv and truth/ (attitude at the
    gyro rate, gyro truth, gps_faults.csv, outages.csv, gyro_faults.csv). Same seed and scenario -> same files."""
    out = Path(out_dir)
    sim = simulate_set("earth-pointing", out, seed=seed, **_sim_overrides(sc))
    ref = sim.reference_attitude
    truth_att = sim.truth_dir / "attitude_gyro_rate.csv"
    shutil.move(str(ref), truth_att)
    t_ref, q_ref = _true_attitude(truth_att)
    t0 = t_ref[0]
    t_s = t_ref - t0
    rng = np.random.default_rng(np.random.SeedSequence([seed, 2002, 1]))
    rates, truth = simulate_gyro(t_s, q_ref, sc.gyro, rng)
    from gnssatt.gyro.gyro_csv import gyro_csv_text

    gyro_csv = out / "gyro.csv"
    gyro_csv.write_text(gyro_csv_text(t_ref[1:], rates, np.full(len(rates), sc.gyro.temperature_c)))
    _write_gyro_truth(sim.truth_dir, t_ref[1:], truth, sc.gyro)
    g0 = float(t0.s) + float(t0.frac)
    outages = [(g0 + a, g0 + a + d) for a, d in sc.outages]
    faults: list[PhaseFault] = []
    if sc.gps_fault_interval_s > 0:
        t_ep, vis = _visibility(sim, sc.fault_min_elevation_deg)
        frng = np.random.default_rng(np.random.SeedSequence([seed, 2002, 2]))
        faults = fault_schedule(frng, t_ep, vis, list(sim.obs), sc.gps_fault_interval_s, sc.gps_fault_size_cyc,
                                skip=outages)
        for ant, path in sim.obs.items():
            inject_phase_faults(path, [f for f in faults if f.antenna == ant])
    for a, b in outages:
        inject_outage(list(sim.obs.values()), a, b)
    _write_fault_truth(sim.truth_dir, faults, outages)
    sim = SimulatedSet(dir=sim.dir, obs=sim.obs, nav=sim.nav, platform=sim.platform, reference_attitude=truth_att,
                       truth_dir=sim.truth_dir, platform_sp3=sim.platform_sp3, summary=sim.summary)
    return GyroSet(sim, gyro_csv, sc, t0, faults, outages)


def _write_gyro_truth(truth_dir: Path, t: GpsTime, truth: dict, model: GyroErrorModel) -> None:
    iso = t.iso(3)
    w, d, f = truth["true_rate_rad_s"], truth["drift_rad_s"], truth["fault_drift_rad_s"]
    rows = ["time_gps,wx_rad_s,wy_rad_s,wz_rad_s,drift_x_rad_s,drift_y_rad_s,drift_z_rad_s,"
            "fault_x_rad_s,fault_y_rad_s,fault_z_rad_s"]
    rows += ["%s," % s + ",".join("%.12e" % v for v in vals)
             for s, vals in zip(iso, np.hstack([w, d, f]).tolist())]
    (truth_dir / "gyro.csv").write_text("\n".join(rows) + "\n")
    lines = ["axis,start_s,end_s,size_rad_s,ramp_s"]
    lines += [f"{'xyz'[x.axis]},{x.start_s},{x.end_s},{x.size_rad_s},{x.ramp_s}" for x in model.faults]
    (truth_dir / "gyro_faults.csv").write_text("\n".join(lines) + "\n")


def _write_fault_truth(truth_dir: Path, faults: list, outages: list) -> None:
    lines = ["antenna,satellite,start_gps_s,end_gps_s,size_cyc,kind"]
    lines += [f"{f.antenna},{f.sat},{f.start_gps_s:.3f},{f.end_gps_s:.3f},{f.size_cyc},{f.kind}" for f in faults]
    (truth_dir / "gps_faults.csv").write_text("\n".join(lines) + "\n")
    lines = ["start_gps_s,end_gps_s"] + [f"{a:.3f},{b:.3f}" for a, b in outages]
    (truth_dir / "outages.csv").write_text("\n".join(lines) + "\n")
