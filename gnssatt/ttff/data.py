"""One observation set of a time-to-first-fix study, parsed once: aligned observations of every antenna, epoch
geometry, the platform's baselines, the orbital frame and, when the set has them, the truth (reference attitude;
integer ambiguities of the simulator's truth/arcs.csv).

`load_study_set(files, label, truth_dir=None, max_duration_s=None)` -> StudySet. `files` are (name, kind, path)
triples as gnssatt.attitude.process.load_inputs takes them (kinds rinex_obs, rinex_nav, sp3, platform,
reference_attitude).

Implements: the observation alignment and geometry of the attitude job (gnssatt.attitude.observations /
geometry, seed 000 sec. 2); truth attitude by slerp of the reference attitude (gnssatt.calibration.reference);
DD truth integers from the simulator's arc table (docs/simulator.md: phase = rho/lambda + N + fractional biases
that cancel in double differences).
Neglects: systems other than GPS (as the attitude filter).
"""
from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gnssatt.attitude.observations import PlatformObs, build_platform_obs
from gnssatt.gnss.time import GpsTime

__all__ = ["StudySet", "Truth", "load_study_set", "subset_signals", "initial_offset_euler_deg"]

#: A reference attitude sample further than this from a GNSS epoch is not used as truth (s).
TRUTH_MAX_GAP_S = 10.0


@dataclass
class Truth:
    """Truth at the epochs of a StudySet.

    R_body_from_ecef: (n_ep, 3, 3), NaN where absent; ok (n_ep,) bool.
    n_cyc: (n_ant, n_ep, n_sat, n_sig) integer ambiguity of the arc covering each observation (NaN: unknown),
        in the StudySet's antenna / satellite / signal order; None without the simulator's truth/arcs.csv.
    source: text naming where it came from.
    """

    R_body_from_ecef: np.ndarray
    ok: np.ndarray
    n_cyc: np.ndarray | None
    source: str


@dataclass
class StudySet:
    """A parsed set. Arrays of `pobs` are (n_ant, n_ep, n_sat, n_sig); baselines are antenna index pairs."""

    label: str
    kind: str                       # spacecraft | terrestrial
    pobs: PlatformObs
    geom: object                    # gnssatt.attitude.geometry.EpochGeometry
    baselines: list                 # [(first id, second id)]
    bl_idx: list                    # [(first index, second index)] into pobs.antennas
    body_baselines_m: np.ndarray    # (n_bl, 3)
    boresight_body: np.ndarray      # (n_ant, 3)
    R_ref_from_ecef: np.ndarray     # (n_ep, 3, 3) orbital frame (spacecraft) or NED (terrestrial)
    truth: Truth | None = None
    warnings: list = field(default_factory=list)

    @property
    def t_s(self) -> np.ndarray:
        """Seconds since the first epoch, (n_ep,)."""
        return np.asarray(self.pobs.time - self.pobs.time[0], dtype=np.float64)


def _platform_state(inputs, pobs: PlatformObs, master: str):
    """(r (n_ep, 3), v (n_ep, 3), source): platform SP3 when given, else code SPP of the master antenna."""
    from gnssatt.attitude.geometry import platform_state_from_sp3

    if inputs.platform_sp3 is not None:
        r, v = platform_state_from_sp3(inputs.platform_sp3, pobs.time)
        if np.isfinite(r).all(-1).mean() > 0.5:
            return r, v, f"platform SP3 {inputs.platform_sp3.name}"
    from gnssatt.gnss.ephemeris import BroadcastEphemeris, PreciseEphemeris
    from gnssatt.gnss.positioning import SppOptions, spp

    eph = PreciseEphemeris(inputs.gnss_sp3, nav=inputs.nav) if inputs.gnss_sp3 is not None \
        else BroadcastEphemeris(inputs.nav)
    sol = spp(inputs.obs[master], eph, SppOptions(systems=("G",), velocity=True))
    tags = sol.time_tag.s * 1000 + np.round(sol.time_tag.frac * 1000).astype(np.int64)
    want = pobs.time.s * 1000 + np.round(pobs.time.frac * 1000).astype(np.int64)
    r = np.full((len(want), 3), np.nan)
    v = np.full((len(want), 3), np.nan)
    idx = np.clip(np.searchsorted(tags, want), 0, max(len(tags) - 1, 0))
    good = np.isfinite(sol.position_ecef_m).all(-1)
    hit = (tags[idx] == want) & good[idx] if len(tags) else np.zeros(len(want), bool)
    r[hit] = sol.position_ecef_m[idx[hit]]
    v[hit] = np.nan_to_num(sol.velocity_ecef_m_s[idx[hit]])
    return r, v, f"single point positioning of {inputs.obs_names[master]}"


def _sat_state(inputs):
    if inputs.gnss_sp3 is not None:
        from gnssatt.gnss.geometry import sp3_state
        return sp3_state(inputs.gnss_sp3)
    from gnssatt.gnss.orbits.broadcast import BroadcastOrbit
    return BroadcastOrbit(inputs.nav.kepler["G"])


def _truncate(obs_by_ant: dict, max_duration_s: float | None) -> dict:
    """Keep only epochs within max_duration_s of the earliest tag (a TTFF study needs the start only)."""
    if max_duration_s is None:
        return obs_by_ant
    firsts = [o.time[0] for o in obs_by_ant.values() if len(o.time)]
    if not firsts:
        return obs_by_ant
    t0 = firsts[0]
    t0 = t0 + min(float(np.asarray(t - t0, dtype=np.float64)) for t in firsts)
    out = {}
    for ant, o in obs_by_ant.items():
        keep = np.asarray(o.time - t0, dtype=np.float64) <= max_duration_s + 1e-6
        out[ant] = _select(o, keep)
    return out


def _select(o, keep: np.ndarray):
    import dataclasses

    changes = {"time": o.time[keep], "values": o.values[keep], "lli": o.lli[keep]}
    for name in ("ssi", "epoch_flag", "clock_offset_s", "n_sats_epoch"):
        v = getattr(o, name, None)
        if isinstance(v, np.ndarray) and v.shape[:1] == keep.shape:
            changes[name] = v[keep]
    return dataclasses.replace(o, **changes)


def read_arcs(path: Path, pobs: PlatformObs) -> np.ndarray:
    """(n_ant, n_ep, n_sat, n_sig) integer ambiguities (NaN outside arcs) from the simulator's truth/arcs.csv.

    Arc times are epoch tags (receiver time) as the simulator writes them; rows of antennas, satellites or
    signals not in `pobs` are ignored.
    """
    ant_i = {a: i for i, a in enumerate(pobs.antennas)}
    sat_i = {s: i for i, s in enumerate(pobs.sats)}
    sig_i = {s: i for i, s in enumerate(pobs.signals)}
    tags = pobs.time.s.astype(np.int64) * 1000 + np.round(pobs.time.frac * 1000).astype(np.int64)
    out = np.full(pobs.code_m.shape, np.nan)
    with open(path, newline="") as fh:
        for row in csv.DictReader(fh):
            a, s, f = ant_i.get(row["antenna"]), sat_i.get(row["sat"]), sig_i.get(row["signal"])
            if a is None or s is None or f is None:
                continue
            t0, t1 = GpsTime.from_iso(row["start_time_gps"]), GpsTime.from_iso(row["end_time_gps"])
            m0 = int(t0.s) * 1000 + int(round(float(t0.frac) * 1000))
            m1 = int(t1.s) * 1000 + int(round(float(t1.frac) * 1000))
            sel = (tags >= m0) & (tags <= m1)
            out[a, sel, s, f] = float(row["ambiguity_cyc"])
    return out


def load_study_set(files: list[tuple[str, str, Path]], label: str, truth_dir: Path | None = None,
                   max_duration_s: float | None = None, signals=("L1", "L2")) -> StudySet:
    """StudySet of one observation set (see module docstring).

    Args:
        files: (name, kind, path) triples of the set.
        label: the set's name in the study's tables.
        truth_dir: a simulator truth/ folder (arcs.csv) for exact integer checks; None: reference attitude only.
        max_duration_s: keep only this many seconds from the first epoch (None: all).
        signals: signals to read (a configuration later selects a subset with subset_signals).
    Raises:
        gnssatt.attitude.process.InputProblem / gnssatt.gnss.io.errors.ParseError on unusable inputs.
    """
    from gnssatt.attitude.geometry import compute_geometry
    from gnssatt.attitude.process import InputProblem, load_inputs
    from gnssatt.gnss.frames import R_ned_from_ecef, R_orbital_from_ecef, ecef_to_geodetic

    inputs = load_inputs(files)
    plat = inputs.platform
    obs = _truncate(inputs.obs, max_duration_s)
    pobs = build_platform_obs(obs, list(signals))
    if len(pobs.time) == 0 or len(pobs.sats) == 0:
        raise InputProblem("No GPS observations", f"set {label!r}: the observation files hold no GPS epochs")
    antennas = list(obs)
    ant_index = {a: i for i, a in enumerate(antennas)}
    baselines = [(a, b) for a, b in plat.baselines if a in ant_index and b in ant_index]
    bl_idx = [(ant_index[a], ant_index[b]) for a, b in baselines]
    body = np.array([plat.baseline_body_m(a, b) for a, b in baselines])
    boresight = np.array([plat.antennas[a].boresight_body for a in antennas])
    master = plat.master if plat.master in ant_index else antennas[0]
    r_p, v_p, psrc = _platform_state(inputs, pobs, master)
    observed = np.isfinite(pobs.code_m).any(axis=(0, 3))
    geom = compute_geometry(pobs.time, pobs.sats, observed, _sat_state(inputs), r_p, v_p, psrc)
    if plat.kind == "terrestrial":
        lat, lon, _ = ecef_to_geodetic(r_p)
        R_ref = R_ned_from_ecef(lat, lon)
    else:
        R_ref = R_orbital_from_ecef(r_p, v_p)
    truth = None
    if inputs.reference is not None:
        from gnssatt.calibration.reference import reference_at_epochs

        ref = reference_at_epochs(inputs.reference, pobs.time, max_gap_s=TRUTH_MAX_GAP_S)
        n_cyc = None
        src = "reference attitude"
        if truth_dir is not None and (Path(truth_dir) / "arcs.csv").exists():
            n_cyc = read_arcs(Path(truth_dir) / "arcs.csv", pobs)
            src = "reference attitude + simulator truth/arcs.csv"
        truth = Truth(ref.R_body_from_ecef, ref.ok, n_cyc, src)
    return StudySet(label, plat.kind, pobs, geom, baselines, bl_idx, body, boresight, R_ref, truth,
                    list(pobs.warnings) + list(inputs.warnings))


def subset_signals(pobs: PlatformObs, signals: list[str]) -> PlatformObs:
    """The PlatformObs restricted to `signals` (a configuration: L1+L2, L1 or L2), sharing no arrays."""
    k = [pobs.signals.index(s) for s in signals]
    return PlatformObs(pobs.time, pobs.antennas, pobs.sats, list(signals), pobs.wavelength_m[k],
                       pobs.code_m[..., k], pobs.phase_m[..., k], pobs.cn0_dbhz[..., k], pobs.lli[..., k],
                       pobs.present, pobs.codes_used, list(pobs.warnings), pobs.approx_position_ecef_m)


def initial_offset_euler_deg(ss: StudySet, k: int = 0) -> tuple[float, float, float] | None:
    """(yaw, pitch, roll) of the true attitude at epoch k relative to the reference frame (orbital / NED), or
    None without truth: the initial offset from the filter's Earth-pointing (or level) prior."""
    from gnssatt.gnss.rotations import dcm_to_euler321

    if ss.truth is None or not ss.truth.ok[k]:
        return None
    R = ss.truth.R_body_from_ecef[k] @ ss.R_ref_from_ecef[k].T
    y, p, r = dcm_to_euler321(R)
    return float(y), float(p), float(r)
