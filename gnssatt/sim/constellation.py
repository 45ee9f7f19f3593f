"""A synthetic GPS constellation: one continuous orbit + clock model per satellite, and its broadcast records.

Each satellite follows the IS-GPS-200 ephemeris model with constant parameters. A broadcast record
for reference time toe_k is the same model re-epoched (M0, Omega0, i0, af0, af1 shifted to toe_k), so
every record reproduces the truth exactly; only the RINEX text rounding (13 significant digits)
separates the navigation file from the truth (< 0.1 mm in position, < 1e-15 s in clock).

Implements: IS-GPS-200 Table 20-IV (user algorithm for ephemeris determination), sec. 20.3.3.3.3.1
(satellite clock correction with the relativistic term F e sqrt(A) sin E), sec. 20.3.3.3.3.2 (TGD,
L1 C/A: dt_sv - TGD; L2 P(Y): dt_sv - gamma TGD).
Neglects: satellite antenna offsets (the broadcast orbit is the antenna phase centre), inter-signal
corrections beyond TGD, orbit/clock errors of the broadcast message (truth = broadcast).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.gnss.time import SECONDS_PER_WEEK, GpsTime
from gnssatt.sim._constants import F_REL_S_SQRT_M, GAMMA_L2, GM_GPS_M3_S2, OMEGA_E_RAD_S

RECORD_INTERVAL_S = 7200
_ABSENT_PRN = 4  # 31 satellites as in mid-2018: PRN 4 unassigned


@dataclass
class BroadcastRecord:
    """One GPS LNAV broadcast record (field names as gnssatt/gnss/io/rinex_nav.KeplerEphemeris)."""

    sat: str
    toc: GpsTime
    af0_s: float
    af1_s_s: float
    af2_s_s2: float
    iode: int
    crs_m: float
    delta_n_rad_s: float
    m0_rad: float
    cuc_rad: float
    e: float
    cus_rad: float
    sqrt_a_sqrt_m: float
    toe_sow: float
    cic_rad: float
    omega0_rad: float
    cis_rad: float
    i0_rad: float
    crc_m: float
    omega_rad: float
    omega_dot_rad_s: float
    idot_rad_s: float
    week: int
    health: int
    tgd_s: float
    iodc: int
    transmission_sow: float
    fit_interval_h: float
    accuracy_m: float
    codes_on_l2: int = 1
    l2p_flag: int = 0


@dataclass
class Constellation:
    """Continuous orbit + clock models: arrays (n_sats,) of IS-GPS-200 parameters at reference time t_ref."""

    sats: list[str]
    t_ref: GpsTime          # reference epoch (a 2 h boundary), = toe = toc of the model
    sqrt_a: np.ndarray
    e: np.ndarray
    i0: np.ndarray
    omega0: np.ndarray      # Omega0 as broadcast for the week of t_ref
    omega: np.ndarray
    m0: np.ndarray
    delta_n: np.ndarray
    omega_dot: np.ndarray
    idot: np.ndarray
    cuc: np.ndarray
    cus: np.ndarray
    crc: np.ndarray
    crs: np.ndarray
    cic: np.ndarray
    cis: np.ndarray
    af0: np.ndarray
    af1: np.ndarray
    af2: np.ndarray
    tgd: np.ndarray

    @property
    def n(self) -> int:
        return len(self.sats)

    def _week_start_ref(self) -> int:
        return int(self.t_ref.s) - int(self.t_ref.s) % SECONDS_PER_WEEK

    def position_clock(self, dt_s: np.ndarray, sat_idx: np.ndarray | slice = slice(None)):
        """ECEF positions (..., 3) in m at transmission and clock offsets dt_sv (...) in s, incl. relativity.

        Args:
            dt_s: seconds since t_ref of the (true GPS) transmission times, shape (..., n_sel) where the
                last axis runs over the satellites selected by sat_idx.
            sat_idx: satellite selection (indices into self.sats), default all.
        Returns:
            r_ecef_m (..., n_sel, 3) in the ECEF frame at the transmission time, dt_sv_s (..., n_sel).
        Implements: IS-GPS-200 Table 20-IV; sec. 20.3.3.3.3.1. tk is the true elapsed time since toe
        (the model is continuous, no +-302400 s wrap is needed).
        """
        p = {f: getattr(self, f)[sat_idx] for f in ("sqrt_a", "e", "i0", "omega0", "omega", "m0", "delta_n",
                                                     "omega_dot", "idot", "cuc", "cus", "crc", "crs", "cic",
                                                     "cis", "af0", "af1", "af2")}
        tk = np.asarray(dt_s, dtype=np.float64)
        a = p["sqrt_a"] ** 2
        n = np.sqrt(GM_GPS_M3_S2 / a ** 3) + p["delta_n"]
        M = p["m0"] + n * tk
        e = p["e"]
        E = M.copy()
        for _ in range(6):  # Newton; e < 0.03 converges to 1e-16 in 4 steps
            E = E - (E - e * np.sin(E) - M) / (1.0 - e * np.cos(E))
        sinE, cosE = np.sin(E), np.cos(E)
        nu = np.arctan2(np.sqrt(1.0 - e * e) * sinE, cosE - e)
        phi = nu + p["omega"]
        s2, c2 = np.sin(2 * phi), np.cos(2 * phi)
        u = phi + p["cus"] * s2 + p["cuc"] * c2
        r = a * (1.0 - e * cosE) + p["crs"] * s2 + p["crc"] * c2
        inc = p["i0"] + p["idot"] * tk + p["cis"] * s2 + p["cic"] * c2
        # Omega = Omega0 + (Omega_dot - wE) tk - wE toe, with toe counted from the week of t_ref
        toe_sow = float(int(self.t_ref.s) - self._week_start_ref())
        Om = p["omega0"] + (p["omega_dot"] - OMEGA_E_RAD_S) * tk - OMEGA_E_RAD_S * toe_sow
        xp, yp = r * np.cos(u), r * np.sin(u)
        cO, sO, ci = np.cos(Om), np.sin(Om), np.cos(inc)
        pos = np.stack([xp * cO - yp * ci * sO, xp * sO + yp * ci * cO, yp * np.sin(inc)], axis=-1)
        dt_sv = p["af0"] + p["af1"] * tk + p["af2"] * tk * tk + F_REL_S_SQRT_M * e * p["sqrt_a"] * sinE
        return pos, dt_sv

    def records(self, t_first: GpsTime, t_last: GpsTime) -> list[BroadcastRecord]:
        """Broadcast records every 2 h with toe from the last 2 h boundary <= t_first to the first >= t_last.

        Records are in time order, then satellite order. IODE = IODC = record count mod 256 (<= 255).
        """
        k0 = int(np.floor((t_first - self.t_ref) / RECORD_INTERVAL_S))
        k1 = int(np.ceil((t_last - self.t_ref) / RECORD_INTERVAL_S))
        out = []
        ws_ref = self._week_start_ref()
        for k in range(k0, k1 + 1):
            T = float(k * RECORD_INTERVAL_S)
            toe = self.t_ref + T
            week = int(toe.s) // SECONDS_PER_WEEK
            toe_sow = float(int(toe.s) - week * SECONDS_PER_WEEK)
            n = np.sqrt(GM_GPS_M3_S2 / self.sqrt_a ** 6) + self.delta_n
            m0 = _wrap(self.m0 + n * T)
            # Omega0_k = Omega0 + Omega_dot T - wE (week_k_start - week_ref_start)
            om0 = _wrap(self.omega0 + self.omega_dot * T - OMEGA_E_RAD_S * (week * SECONDS_PER_WEEK - ws_ref))
            i0 = self.i0 + self.idot * T
            af0 = self.af0 + self.af1 * T + self.af2 * T * T
            af1 = self.af1 + 2 * self.af2 * T
            iodc = (k - k0 + 1) % 256
            for j, sat in enumerate(self.sats):
                out.append(BroadcastRecord(
                    sat=sat, toc=toe, af0_s=float(af0[j]), af1_s_s=float(af1[j]), af2_s_s2=float(self.af2[j]),
                    iode=iodc, crs_m=float(self.crs[j]), delta_n_rad_s=float(self.delta_n[j]),
                    m0_rad=float(m0[j]), cuc_rad=float(self.cuc[j]), e=float(self.e[j]),
                    cus_rad=float(self.cus[j]), sqrt_a_sqrt_m=float(self.sqrt_a[j]), toe_sow=toe_sow,
                    cic_rad=float(self.cic[j]), omega0_rad=float(om0[j]), cis_rad=float(self.cis[j]),
                    i0_rad=float(i0[j]), crc_m=float(self.crc[j]), omega_rad=float(self.omega[j]),
                    omega_dot_rad_s=float(self.omega_dot[j]), idot_rad_s=float(self.idot[j]), week=week,
                    health=0, tgd_s=float(self.tgd[j]), iodc=iodc,
                    transmission_sow=toe_sow - 7200.0 + 18.0, fit_interval_h=4.0, accuracy_m=2.0))
        return out

    def tgd_scale(self, signal: str) -> float:
        """Multiplier of TGD in the code clock offset of a signal: L1 C/A 1, L2 P(Y) gamma (IS-GPS-200)."""
        return 1.0 if signal == "L1" else GAMMA_L2


def _wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def synthetic_gps(t_ref: GpsTime, seed: int = 2018) -> Constellation:
    """A realistic synthetic 31-satellite GPS constellation (six planes A-F, 55 deg) at a 2 h boundary t_ref.

    Args:
        t_ref: reference epoch; it is moved back to the previous 2 h boundary of GPS time.
        seed: constellation seed (independent of the scenario's noise seed).
    Slots follow the nominal 24-slot baseline (IS-GPS-200 / SPS PS 2008 Table 3.2-1 style spacing, planes
    60 deg apart) plus 7 extra satellites; eccentricity 0.001-0.02, inclination 55 +- 1.5 deg, harmonic
    corrections and clock parameters of typical broadcast magnitude.
    """
    rng = np.random.default_rng(np.random.SeedSequence([seed, 7007]))
    s = int(t_ref.s)
    s -= s % RECORD_INTERVAL_S
    t_ref = GpsTime(s)
    per_plane = [5, 5, 5, 5, 6, 5]
    prns = [p for p in range(1, 33) if p != _ABSENT_PRN]
    omega0, arglat, idx = [], [], 0
    for plane, count in enumerate(per_plane):
        base = rng.uniform(0, 2 * np.pi)
        for k in range(count):
            omega0.append(np.radians(60.0 * plane - 160.0) + rng.normal(0, 0.01))
            arglat.append(base + 2 * np.pi * k / count + rng.normal(0, 0.15))
            idx += 1
    n = len(prns)
    order = rng.permutation(n)
    omega0 = np.asarray(omega0)[order]
    arglat = np.asarray(arglat)[order]
    e = rng.uniform(0.001, 0.02, n)
    omega = rng.uniform(-np.pi, np.pi, n)
    # mean anomaly such that omega + M ~ argument of latitude (small e)
    m0 = _wrap(arglat - omega)
    sqrt_a = np.sqrt(26_559_700.0 + rng.normal(0, 1500.0, n))
    return Constellation(
        sats=[f"G{p:02d}" for p in prns], t_ref=t_ref, sqrt_a=sqrt_a, e=e,
        i0=np.radians(55.0 + rng.uniform(-1.5, 1.5, n)), omega0=_wrap(omega0), omega=omega, m0=m0,
        delta_n=rng.uniform(3.8e-9, 5.5e-9, n), omega_dot=rng.uniform(-8.5e-9, -7.6e-9, n),
        idot=rng.uniform(-5e-10, 5e-10, n), cuc=rng.normal(0, 3e-6, n), cus=rng.normal(0, 6e-6, n),
        crc=rng.normal(220, 60, n), crs=rng.normal(0, 60, n), cic=rng.normal(0, 1e-7, n),
        cis=rng.normal(0, 1e-7, n), af0=rng.uniform(-6e-4, 6e-4, n), af1=rng.normal(0, 4e-12, n),
        af2=np.zeros(n), tgd=np.round(rng.uniform(-1.2e-8, 8e-9, n) / 2 ** -31) * 2 ** -31)


def nearest_healthy_records(sats: list, health, dt_s: np.ndarray, max_s: float) -> dict[str, int]:
    """{satellite: index of its healthy record nearest in time}: records i with health 0 and dt_s[i] <= max_s
    (dt_s the records' absolute time from the start, s); the first of equally near records is kept."""
    chosen: dict[str, int] = {}
    for i, sat in enumerate(sats):
        if int(health[i]) != 0 or dt_s[i] > max_s:
            continue
        if sat not in chosen or dt_s[i] < dt_s[chosen[sat]]:
            chosen[sat] = i
    return chosen


def gps_from_nav(nav_path, t0: GpsTime) -> Constellation:
    """The GPS constellation of a real RINEX navigation file, as continuous models referenced at the 2 h
    boundary at or before t0: per healthy satellite, the record whose toe is nearest t0, its elements carried
    to that reference time (the inverse of `Constellation.records`), so that the simulated orbits are exactly
    the broadcast model of that record and the navigation file the simulator writes reproduces it.

    Args:
        nav_path: RINEX 2/3/4 navigation file (plain or compressed) holding GPS LNAV records.
        t0: start of the pass; records farther than 4 h from it are not used.
    Implements: IS-GPS-200 Table 20-IV (Omega_0 referenced to the week start, so moving the reference by dT
    adds Omega_dot dT and subtracts omega_E times the change of week start).
    """
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav

    nav = read_rinex_nav(nav_path)
    kep = nav.kepler.get("G")
    if kep is None or len(kep) == 0:
        raise ValueError(f"nav_file {nav_path}: no GPS records")
    s = int(t0.s)
    t_ref = GpsTime(s - s % RECORD_INTERVAL_S)
    ws_ref = int(t_ref.s) - int(t_ref.s) % SECONDS_PER_WEEK
    toe = kep.toe_gpst()
    toc = kep.toc_gpst()
    dt_s = np.array([abs(float(toe[i] - t0)) for i in range(len(kep.sat))])
    chosen = nearest_healthy_records(kep.sat.tolist(), kep.health, dt_s, 4 * 3600.0)
    if len(chosen) < 4:
        raise ValueError(f"nav_file {nav_path}: only {len(chosen)} healthy GPS satellites within 4 h of "
                         f"{t0.iso()}; choose start_gps inside the file's span")
    sats = sorted(chosen)
    idx = np.array([chosen[x] for x in sats])
    take = {f: np.asarray(getattr(kep, f), dtype=np.float64)[idx] for f in (
        "sqrt_a_sqrt_m", "e", "i0_rad", "omega0_rad", "omega_rad", "m0_rad", "delta_n_rad_s", "omega_dot_rad_s",
        "idot_rad_s", "cuc_rad", "cus_rad", "crc_m", "crs_m", "cic_rad", "cis_rad", "af0_s", "af1_s_s",
        "af2_s_s2", "tgd_s")}
    dT = np.array([float(t_ref - toe[i]) for i in idx])
    dTc = np.array([float(t_ref - toc[i]) for i in idx])
    ws_j = np.array([int(toe[i].s) - int(toe[i].s) % SECONDS_PER_WEEK for i in idx], dtype=np.float64)
    n = np.sqrt(GM_GPS_M3_S2 / take["sqrt_a_sqrt_m"] ** 6) + take["delta_n_rad_s"]
    af2 = take["af2_s_s2"]
    return Constellation(
        sats=sats, t_ref=t_ref, sqrt_a=take["sqrt_a_sqrt_m"], e=take["e"], i0=take["i0_rad"] + take["idot_rad_s"] * dT,
        omega0=_wrap(take["omega0_rad"] + take["omega_dot_rad_s"] * dT - OMEGA_E_RAD_S * (ws_ref - ws_j)),
        omega=take["omega_rad"], m0=_wrap(take["m0_rad"] + n * dT), delta_n=take["delta_n_rad_s"],
        omega_dot=take["omega_dot_rad_s"], idot=take["idot_rad_s"], cuc=take["cuc_rad"], cus=take["cus_rad"],
        crc=take["crc_m"], crs=take["crs_m"], cic=take["cic_rad"], cis=take["cis_rad"],
        af0=take["af0_s"] + take["af1_s_s"] * dTc + af2 * dTc ** 2, af1=take["af1_s_s"] + 2 * af2 * dTc, af2=af2,
        tgd=take["tgd_s"])


__all__ = ["BroadcastRecord", "Constellation", "synthetic_gps", "gps_from_nav", "RECORD_INTERVAL_S",
           "nearest_healthy_records"]
