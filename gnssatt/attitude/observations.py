"""Observations of every antenna of a platform as dense arrays on common epochs.

Receivers tag their epochs in their own time (CONVENTIONS.md "Time"): a free-running clock may be up to 1 ms
off and jump by 1 ms, but each receiver still tags whole (receiver) seconds. Epochs are therefore matched by
their tags; the receivers' different true reception times are handled in the measurement model
(gnssatt.attitude.filter: clock partial 1 - rho_dot / c), not by shifting observations.

Signals are system-qualified (gnssatt.attitude.settings.SIGNALS: "G:L1", "E:E5b", "C:B1I"...; "L1"/"L2" are GPS):
the satellites are those of every system some signal belongs to, and a (satellite, signal) pair of two different
systems stays NaN. So each signal is one system on one frequency, the unit within which the filter forms double
differences (its own phase clock, own ambiguity group) and whose wavelength is one number.

Implements: RINEX 3.04 LLI (bit 0 loss of lock, bit 1 half-cycle ambiguity) and SSI semantics; signal choice
L1 C/A + L2 P(Y) (semi-codeless W first, else L2C) per seed 000 sec. 1; RINEX 3.04 Tables 4-8 codes for Galileo,
BeiDou and QZSS.
GLONASS FDMA ("R:G1", "R:G2"): each satellite's phase is scaled by its own wavelength c / f_k, k from the file's
GLONASS SLOT / FRQ # (RINEX 3.02+), else from `channels` (the navigation records); `wavelength_sat_m` (n_sat, n_sig)
carries the per-satellite wavelengths to the filter (GLONASS ICD 5.1 sec. 3.3.1.4).
Neglects: GLONASS inter-channel biases (zero for receivers of one model; see gnssatt.attitude.settings glonass_icb).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnssatt.attitude.settings import SIGNALS
from gnssatt.gnss.constants import C_M_S
from gnssatt.gnss.time import GpsTime

__all__ = ["PlatformObs", "build_platform_obs", "glonass_channels"]


@dataclass
class PlatformObs:
    """Observations of n_ant antennas on n_ep common epochs, n_sat satellites, n_sig signals.

    time: GpsTime (n_ep,) epoch tags. antennas: antenna ids in array order. sats: satellite ids.
    signals: signal names ('L1', 'L2', 'E:E1', ...; gnssatt.attitude.settings.SIGNALS). wavelength_m: (n_sig,).
    code_m, phase_m, cn0_dbhz: (n_ant, n_ep, n_sat, n_sig) float64, NaN where absent (phase in metres).
    lli: (n_ant, n_ep, n_sat, n_sig) int8, -1 absent. present: (n_ant, n_ep) bool (antenna has the epoch).
    codes_used: per antenna, signal -> (code, phase, snr) RINEX 3 codes actually read.
    warnings: human-readable notes (e.g. signal missing on an antenna).
    """

    time: GpsTime
    antennas: list[str]
    sats: list[str]
    signals: list[str]
    wavelength_m: np.ndarray
    code_m: np.ndarray
    phase_m: np.ndarray
    cn0_dbhz: np.ndarray
    lli: np.ndarray
    present: np.ndarray
    codes_used: dict = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    approx_position_ecef_m: dict = field(default_factory=dict)  # antenna -> (3,) header position or None
    wavelength_sat_m: np.ndarray | None = None   # (n_sat, n_sig) per-satellite wavelength (FDMA), NaN: unknown

    def __post_init__(self):
        if self.wavelength_sat_m is None:
            self.wavelength_sat_m = np.repeat(np.asarray(self.wavelength_m, float)[None, :], len(self.sats), axis=0)


def _tag_ms(t: GpsTime) -> np.ndarray:
    return t.s.astype(np.int64) * 1000 + np.round(t.frac * 1000.0).astype(np.int64)


def _pick(obs, candidates: list[str], system: str = "G") -> str | None:
    for code in candidates:
        if obs.code_index(code, system) is not None:
            return code
    return None


def glonass_channels(obs_by_antenna: dict, nav=None) -> dict[str, int]:
    """GLONASS frequency channel k per satellite ('R01' -> 1): GLONASS SLOT / FRQ # of the files, else the
    navigation records' frequency numbers."""
    out: dict[str, int] = {}
    glo = getattr(nav, "glonass", None)
    if glo is not None and len(glo):
        for sat, k in zip(glo.sat, glo.frequency_number):
            if -7 <= int(k) <= 6:
                out[str(sat)] = int(k)
    for o in obs_by_antenna.values():
        out.update(getattr(o.header, "glonass_slots", {}) or {})
    return out


def _sat_wavelengths(sats: list[str], signals: list[str], lam: np.ndarray, channels: dict) -> np.ndarray:
    """(n_sat, n_sig) wavelength of each satellite's signal: the signal's one wavelength, or for an FDMA signal
    c / f_k of the satellite's channel (NaN when its channel is unknown: the satellite is not used)."""
    from gnssatt.gnss.signals import glonass_wavelength_m

    out = np.repeat(lam[None, :], len(sats), axis=0)
    for k, sig in enumerate(signals):
        band = SIGNALS[sig].get("fdma_band")
        if band is None:
            continue
        for i, sat in enumerate(sats):
            ch = channels.get(sat)
            out[i, k] = glonass_wavelength_m(band, ch) if ch is not None else np.nan
    return out


def build_platform_obs(obs_by_antenna: dict, signals: list[str], system: str | None = None,
                       channels: dict | None = None) -> PlatformObs:
    """PlatformObs of RinexObs files (antenna id -> gnssatt.gnss.io.rinex_obs.RinexObs) for `signals` (names of
    SIGNALS, each of one system).

    Epoch union of all tags (to the millisecond); satellites of the signals' systems seen by any antenna (sorted
    as RINEX names sort: C, E, G, J). A signal absent from a file leaves NaN for that antenna (and a warning).
    `system` (legacy): if given, only that system's signals are accepted.
    """
    sig_sys = [SIGNALS[s]["system"] for s in signals]
    if system is not None and any(x != system for x in sig_sys):
        raise ValueError(f"signals {signals} are not all of system {system}")
    systems = set(sig_sys)
    antennas = list(obs_by_antenna)
    tags = [_tag_ms(o.time) for o in obs_by_antenna.values()]
    all_tags = np.unique(np.concatenate(tags)) if tags else np.zeros(0, np.int64)
    sats = sorted({s for o in obs_by_antenna.values() for s in o.sats if s[0] in systems})
    sat_col = {s: i for i, s in enumerate(sats)}
    n_ant, n_ep, n_sat, n_sig = len(antennas), len(all_tags), len(sats), len(signals)
    shape = (n_ant, n_ep, n_sat, n_sig)
    code = np.full(shape, np.nan)
    phase = np.full(shape, np.nan)
    cn0 = np.full(shape, np.nan)
    lli = np.full(shape, -1, dtype=np.int8)
    present = np.zeros((n_ant, n_ep), bool)
    lam = np.array([C_M_S / SIGNALS[s]["freq_hz"] for s in signals])
    lam_sat = _sat_wavelengths(sats, list(signals), lam, channels if channels is not None
                               else glonass_channels(obs_by_antenna))
    used: dict = {}
    warnings: list[str] = []
    approx: dict = {}
    for a, (ant, obs) in enumerate(obs_by_antenna.items()):
        rows = np.searchsorted(all_tags, tags[a])
        present[a, rows] = True
        used[ant] = {}
        approx[ant] = obs.header.approx_position_ecef_m
        for k, sig in enumerate(signals):
            spec = SIGNALS[sig]
            system_k = spec["system"]
            cols_src = [i for i, s in enumerate(obs.sats) if s[0] == system_k]
            cols_dst = np.array([sat_col[obs.sats[i]] for i in cols_src], dtype=np.int64)
            cols_src = np.array(cols_src, dtype=np.int64)
            c_code = _pick(obs, spec["code"], system_k)
            c_phase = _pick(obs, spec["phase"], system_k)
            c_snr = _pick(obs, spec["snr"], system_k)
            if c_code is None or c_phase is None:
                warnings.append(f"antenna {ant}: no {sig} code/phase ({'/'.join(spec['code'])}) in {obs.name}")
                continue
            used[ant][sig] = (c_code, c_phase, c_snr)
            r_i, c_i = rows[:, None], cols_dst[None, :]
            code[a, r_i, c_i, k] = obs.values[:, cols_src, obs.code_index(c_code, system_k)]
            ki = obs.code_index(c_phase, system_k)
            phase[a, r_i, c_i, k] = obs.values[:, cols_src, ki] * lam_sat[cols_dst, k][None, :]
            lli[a, r_i, c_i, k] = obs.lli[:, cols_src, ki]
            if c_snr is not None:
                cn0[a, r_i, c_i, k] = obs.values[:, cols_src, obs.code_index(c_snr, system_k)]
        # a zero value means "not observed" in many writers
        for arr in (code, phase):
            bad = arr[a] == 0.0
            arr[a][bad] = np.nan
    t = GpsTime(all_tags // 1000, (all_tags % 1000) / 1000.0)
    return PlatformObs(t, antennas, sats, list(signals), lam, code, phase, cn0, lli, present, used, warnings, approx,
                       lam_sat)
