"""The attitude job on parsed inputs: observations -> geometry -> EKF -> attitude, baselines and statistics.

`load_inputs(files)` parses an observation set given as (name, kind, path) triples; `process(inputs, settings)`
runs everything and returns an `AttitudeSolution` that gnssatt.attitude.products turns into files.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gnssatt.attitude.antenna_consider import attitude_consider
from gnssatt.attitude.filter import FilterResult, run_filter
from gnssatt.attitude.geometry import EpochGeometry, compute_geometry, platform_state_from_sp3
from gnssatt.attitude.observations import PlatformObs, build_platform_obs, glonass_channels
from gnssatt.attitude.platform_defaults import apply_platform_defaults
from gnssatt.attitude.settings import AttitudeSettings, effective_signals, signal_system
from gnssatt.attitude.solution import attitude_from_baselines, attitude_quaternion, baseline_az_el, euler_and_sigma
from gnssatt.attitude.update_kernels import quest_dcm
from gnssatt.gnss import rotations as rot
from gnssatt.gnss.frames import (R_enu_from_ecef, R_gcrf_from_ecef, R_ned_from_ecef, R_orbital_from_ecef,
                                ecef_to_geodetic)
from gnssatt.gnss.leap_seconds import expiry_warning
from gnssatt.gnss.time import GpsTime

__all__ = ["AttitudeInputs", "AttitudeSolution", "InputProblem", "load_inputs", "process"]


class InputProblem(ValueError):
    """The inputs cannot give an attitude (missing file, unusable platform); carries file/field for the job."""

    def __init__(self, title: str, detail: str, file: str | None = None, field: str | None = None):
        super().__init__(detail)
        self.title, self.detail, self.file, self.field = title, detail, file, field


@dataclass
class AttitudeInputs:
    platform: object                       # gnssatt.gnss.io.platform.Platform
    obs: dict                              # antenna id -> RinexObs
    obs_names: dict                        # antenna id -> file name in the set
    nav: object | None = None              # NavData
    gnss_sp3: object | None = None         # Sp3Data of GNSS satellites
    platform_sp3: object | None = None     # Sp3Data of the platform itself
    reference: object | None = None        # ReferenceAttitude
    warnings: list = field(default_factory=list)


@dataclass
class AttitudeSolution:
    settings: AttitudeSettings
    inputs: AttitudeInputs
    pobs: PlatformObs
    geom: EpochGeometry
    fr: FilterResult
    baselines: list                        # [(first id, second id)]
    body_baselines_m: np.ndarray           # (n_bl, 3)
    # attitude rows (epochs where every baseline has a solution); None with one baseline
    att_epochs: np.ndarray | None = None   # indices into pobs.time
    q_body_from_ecef: np.ndarray | None = None
    q_body_from_gcrf: np.ndarray | None = None
    euler_deg: np.ndarray | None = None    # (n, 3) yaw, pitch, roll
    sigma_euler_deg: np.ndarray | None = None
    att_fixed: np.ndarray | None = None
    att_n_sats: np.ndarray | None = None
    baseline_table: dict = field(default_factory=dict)   # column arrays of baselines.csv
    # the platform kind's defaults applied (gnssatt.attitude.platform_defaults): [{"setting", "value", "reason"}]
    platform_defaults: list = field(default_factory=list)
    summary: dict = field(default_factory=dict)
    # summary.json "antenna_consider": the unmodelled phase-centre term in sigma_euler_deg (antenna_consider.py)
    antenna_consider: dict | None = None
    sigma_consider_euler_deg: np.ndarray | None = None   # (n, 3): the part of sigma_euler_deg that term makes

    @property
    def time(self) -> GpsTime | None:
        """GPS time of each attitude row (None with one baseline)."""
        return None if self.att_epochs is None else self.pobs.time[self.att_epochs]

    def write_products(self, out_dir) -> dict:
        """The job's text products in out_dir (gnssatt.attitude.products.write_products); name -> path."""
        from gnssatt.attitude.products import write_products
        return write_products(self, out_dir)


def _start_obs_reading(obs_files: dict, background=None):
    """A callable giving ({name: RinexObs}, {name: exception}) of the observation files {name: path}, each parsed
    once. background (see process): all files but the first are parsed by it meanwhile (the three files of a
    three-antenna set take ~0.4 s one after the other), the first here at once, and the callable collects them (if
    the background fails they are parsed then, here). Without it all are parsed here at once."""
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs

    def read_all(items) -> tuple[dict, dict]:
        parsed, failed = {}, {}
        for fname, fpath in items:
            try:
                parsed[fname] = read_rinex_obs(fpath, name=fname)
            except Exception as exc:  # noqa: BLE001 - a bad file is reported when an antenna needs it
                failed[fname] = exc
        return parsed, failed

    items = list(obs_files.items())
    if background is None or len(items) < 2:
        done = read_all(items)
        return lambda: done
    handle = background(lambda: read_all(items[1:]))
    try:
        first = read_all(items[:1])
    except BaseException:
        handle.cancel()
        raise

    def collect() -> tuple[dict, dict]:
        try:
            rest = handle.result()
        except Exception:  # noqa: BLE001 - e.g. an exception that does not pickle: parse them here
            rest = read_all(items[1:])
        parsed, failed = {**first[0], **rest[0]}, {**first[1], **rest[1]}
        return ({f: parsed[f] for f in obs_files if f in parsed}, {f: failed[f] for f in obs_files if f in failed})
    return collect


def _other_inputs(files: list[tuple[str, str, Path]]) -> dict:
    """AttitudeInputs fields nav, gnss_sp3, platform_sp3, reference of the set's other files (the first of each)."""
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav
    from gnssatt.gnss.io.sp3 import read_sp3

    out = {"nav": None, "gnss_sp3": None, "platform_sp3": None, "reference": None}
    for fname, kind, fpath in files:
        if kind == "rinex_nav" and out["nav"] is None:
            out["nav"] = read_rinex_nav(fpath, name=fname)
        elif kind == "sp3":
            sp3 = read_sp3(fpath, name=fname)
            key = "gnss_sp3" if any(s[0] in "GJ" for s in sp3.sats) else "platform_sp3"
            out[key] = out[key] or sp3
        elif kind == "reference_attitude":
            from gnssatt.gnss.io.reference_attitude import read_reference_attitude
            out["reference"] = read_reference_attitude(Path(fpath).read_bytes(), name=fname)
    return out


def load_inputs(files: list[tuple[str, str, Path]], background=None) -> AttitudeInputs:
    """Parse a set given as (name, kind, path) with kinds rinex_obs, rinex_nav, sp3, platform, reference_attitude.
    background: see process (all observation files but one are parsed by it, _start_obs_reading, while the
    other files are parsed here)."""
    from gnssatt.gnss.io.platform import match_observation_files, parse_platform

    plat_files = [f for f in files if f[1] == "platform"]
    if not plat_files:
        raise InputProblem("No platform description", "the attitude job needs a platform.json in the set "
                           "(antennas in the body frame, CONVENTIONS.md)", field="platform")
    name, _, path = plat_files[0]
    platform = parse_platform(Path(path).read_bytes(), name=name)
    if len(platform.antennas) < 2 or not platform.baselines:
        raise InputProblem("Too few antennas", f"{name}: attitude needs at least two antennas (one baseline)",
                           file=name)
    obs_files = {f[0]: f[2] for f in files if f[1] == "rinex_obs"}
    collect = _start_obs_reading(obs_files, background)
    try:          # parsed meanwhile; a problem of these files is raised after those of the observation files
        others, other_problem = _other_inputs(files), None
    except Exception as exc:  # noqa: BLE001 - raised below, in the order of the checks without background
        others, other_problem = None, exc
    # each file parsed once: the marker names come from the headers; a bad file is reported when an antenna
    # needs it
    parsed, failed = collect()
    markers = {f: parsed[f].header.marker_name if f in parsed else None for f in obs_files}
    mapping = match_observation_files(platform, markers, name=name)
    needed = {a for bl in platform.baselines for a in bl}
    obs = {}
    for ant in platform.antennas:
        if ant in needed:
            if mapping[ant] in failed:
                raise failed[mapping[ant]]
            obs[ant] = parsed[mapping[ant]]
    if other_problem is not None:
        raise other_problem
    inputs = AttitudeInputs(platform, obs, {a: mapping[a] for a in obs}, **others)
    if inputs.nav is None and inputs.gnss_sp3 is None:
        raise InputProblem("No GNSS orbits", "the set needs a RINEX navigation file or an SP3 of the GNSS "
                           "satellites", field="rinex_nav")
    return inputs


def _sat_state(inputs: AttitudeInputs, systems=("G",)):
    """(sat_state callable, source) for satellites of `systems`: the GNSS SP3, else the broadcast records of each
    system (gnssatt.gnss.orbits.broadcast.BroadcastOrbit per system; BeiDou BDT and GEO handled there). A
    system without records leaves its satellites without geometry (a warning); no records at all is an error."""
    if inputs.gnss_sp3 is not None:
        from gnssatt.gnss.geometry import sp3_state
        return sp3_state(inputs.gnss_sp3), "sp3"
    from gnssatt.gnss.orbits.broadcast import BroadcastOrbit
    glo = getattr(inputs.nav, "glonass", None)
    kinds = set(inputs.nav.kepler) | ({"R"} if glo is not None and len(glo) else set())
    have = [x for x in systems if x in kinds]
    missing = [x for x in systems if x not in kinds]
    if not have:
        raise InputProblem("No ephemerides", f"{inputs.nav.name} holds no records of {'/'.join(systems)}",
                           file=inputs.nav.name)
    if missing:
        inputs.warnings.append(f"{inputs.nav.name}: no ephemerides of system(s) {'/'.join(missing)}; their "
                               "satellites are not used")
    if have == ["G"]:
        return BroadcastOrbit(inputs.nav.kepler["G"]), "broadcast"
    orbits = {x: BroadcastOrbit(inputs.nav.kepler[x]) for x in have if x != "R"}
    if "R" in have:                      # GLONASS state vectors (gnssatt.gnss.orbits.glonass)
        from gnssatt.gnss.ephemeris import BroadcastEphemeris
        glo_eph = BroadcastEphemeris(inputs.nav)
        orbits["R"] = lambda sats, t: (lambda st: (st.r_ecef_m, st.v_ecef_m_s, st.clock_s, st.clock_rate_s_s))(
            glo_eph.state(sats, t))
    return _multi_system_state(orbits), "broadcast"


def _multi_system_state(orbits: dict):
    """A sat_state callable (sats, t) -> (r, v, clk, clk_rate) dispatching each satellite to its system's orbit."""
    def state(sats, t):
        sats = np.atleast_1d(np.asarray(sats)).astype(str)
        n = sats.size
        ts = GpsTime(np.broadcast_to(np.asarray(t.s), (n,)), np.broadcast_to(np.asarray(t.frac), (n,)))
        r, v = np.full((n, 3), np.nan), np.full((n, 3), np.nan)
        clk, rate = np.full(n, np.nan), np.full(n, np.nan)
        letters = np.array([x[:1] for x in sats])
        for sysl, orbit in orbits.items():
            m = letters == sysl
            if m.any():
                r[m], v[m], clk[m], rate[m] = orbit(sats[m], ts[m])
        return r, v, clk, rate
    return state


def _platform_state(inputs: AttitudeInputs, pobs: PlatformObs, master: str):
    """(r (n_ep, 3), v (n_ep, 3), source) of the platform reference point at the epoch tags."""
    if inputs.platform_sp3 is not None:
        r, v = platform_state_from_sp3(inputs.platform_sp3, pobs.time)
        if np.isfinite(r).all(-1).mean() > 0.5:
            return r, v, f"platform SP3 {inputs.platform_sp3.name}"
    from gnssatt.gnss.ephemeris import BroadcastEphemeris, PreciseEphemeris
    from gnssatt.gnss.positioning import SppOptions, spp

    eph = PreciseEphemeris(inputs.gnss_sp3, nav=inputs.nav) if inputs.gnss_sp3 is not None \
        else BroadcastEphemeris(inputs.nav)
    obs = inputs.obs[master]
    # GPS when the master's file has it (as always); a GLONASS-only file is positioned by GLONASS (issue 21)
    systems = ("G",) if any(s[0] == "G" for s in obs.sats) or not any(s[0] == "R" for s in obs.sats) else ("R",)
    sol = spp(obs, eph, SppOptions(systems=systems, velocity=True))
    tags = sol.time_tag.s * 1000 + np.round(sol.time_tag.frac * 1000).astype(np.int64)
    want = pobs.time.s * 1000 + np.round(pobs.time.frac * 1000).astype(np.int64)
    r = np.full((len(want), 3), np.nan)
    v = np.full((len(want), 3), np.nan)
    pos = sol.position_ecef_m
    vel = sol.velocity_ecef_m_s
    good = np.isfinite(pos).all(-1)
    idx = np.searchsorted(tags, want)
    idx_c = np.clip(idx, 0, len(tags) - 1)
    hit = (tags[idx_c] == want) & good[idx_c]
    r[hit], v[hit] = pos[idx_c[hit]], vel[idx_c[hit]]
    if not hit.any():
        raise InputProblem("No platform position", f"single point positioning of {inputs.obs_names[master]} "
                           "gave no position; add an SP3 of the platform", file=inputs.obs_names[master])
    # a ground or slow platform: fill epochs without an SPP fix (gaps) by the nearest fix
    good_i = np.flatnonzero(hit)
    near = good_i[np.clip(np.searchsorted(good_i, np.arange(len(want))), 0, len(good_i) - 1)]
    missing = ~hit
    r[missing] = r[near[missing]]
    v[missing] = np.nan_to_num(v[near[missing]])
    v = np.nan_to_num(v)
    return r, v, f"single point positioning of {inputs.obs_names[master]}"


def _R_ref_from_ecef(kind: str, r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Orbital frame (spacecraft) or NED (terrestrial) <- ECEF, (n, 3, 3)."""
    if kind == "terrestrial":
        lat, lon, _ = ecef_to_geodetic(r)
        return R_ned_from_ecef(lat, lon)
    return R_orbital_from_ecef(r, v)


def single_baseline_attitude_fn(b_body_m: np.ndarray, R_ref_from_ecef: np.ndarray):
    """attitude_fn(b_ecef (1, 3), fixed, k) -> R_body_from_ecef (3, 3) of a one-baseline platform, for its PCV maps
    (which need the antennas' frame): TRIAD with the baseline exact and the body z axis on the reference frame's z
    (NED down for terrestrial platforms, nadir of the orbital frame for spacecraft) at epoch k, i.e. no rotation
    about the baseline out of level / Earth pointing (the one angle one baseline cannot give). None when the
    baseline is along z. Implements: TRIAD (Shuster & Oh 1981 sec. II) via gnssatt.gnss.rotations.triad."""
    z_body = np.array([0.0, 0.0, 1.0])
    if np.linalg.norm(np.cross(b_body_m, z_body)) < 1e-3 * np.linalg.norm(b_body_m):
        return None

    def attitude_fn(b, fixed, k=None):
        z_ecef = R_ref_from_ecef[0 if k is None else k][2]          # the reference frame's z axis in ECEF
        q = rot.triad(b_body_m, z_body, np.asarray(b[0], float), z_ecef)
        return rot.quat_to_dcm(q) if np.all(np.isfinite(q)) else None
    return attitude_fn


def _filter_passes(pobs, geom, bl_idx, body, boresight, settings: AttitudeSettings, R0, attitude_fn, prog):
    """FilterResult of the pass: run_filter, a second pass with the adaptive omega noise when the settings ask for
    it (dynamic mode), then the RTS smoother when they ask for it."""
    two_pass = settings.mode == "dynamic" and settings.smoothing.adaptive_noise
    span = 0.375 if two_pass else 0.75
    fr = run_filter(pobs, geom, bl_idx, body, boresight, settings, R0, attitude_fn,
                    progress=lambda f: prog(0.15 + span * f))
    if two_pass:
        # smoother_adaptive_noise: the omega random walk per epoch from the smoothed first pass, then the whole
        # filter again with it (gnssatt/attitude/smoother.py adaptive_noise_profile); products from the second pass
        from gnssatt.attitude.process_noise_em import floor_passes
        noise0 = fr.smoother_data["noise_state"]

        def rerun(q_omega):
            return run_filter(pobs, geom, bl_idx, body, boresight, settings, R0, attitude_fn,
                              progress=lambda f: prog(0.15 + span * (1 + f)), q_omega=q_omega, noise0=noise0)
        fr, info = floor_passes(fr, rerun, settings)
        fr.smoother_data["adaptive_noise"] = info
    if fr.smoother_data is not None:
        from gnssatt.attitude.smoother import smooth_filter_result
        smooth_filter_result(fr, settings)
    return fr


def process(inputs: AttitudeInputs, settings: AttitudeSettings, progress=None, background=None) -> AttitudeSolution:
    """AttitudeSolution of the whole pass. progress(fraction, stage) is called often (cancellation point).
    background: None, or a callable fn -> handle (result(), cancel()) running fn meanwhile elsewhere (the worker's
    worker.forked.Forked): most of the satellite geometry is then computed while the filter runs
    (gnssatt.attitude.geometry.compute_geometry)."""
    def prog(f, stage=None):
        if progress is not None:
            progress(f, stage)

    plat = inputs.platform
    antennas = list(inputs.obs)
    settings, defaults_applied = apply_platform_defaults(settings, plat.kind, inputs.obs)
    prog(0.02, "aligning observations")
    try:
        signals = effective_signals(settings)
    except ValueError as e:
        raise InputProblem("Unknown signals", str(e), field="signals") from e
    systems = list(dict.fromkeys(signal_system(x) for x in signals))
    pobs = build_platform_obs(inputs.obs, signals, channels=glonass_channels(inputs.obs, inputs.nav))
    if len(pobs.time) == 0 or len(pobs.sats) == 0:
        raise InputProblem("No observations", f"the observation files hold no {'/'.join(systems)} epochs for "
                           f"{'/'.join(signals)}")
    ant_index = {a: i for i, a in enumerate(antennas)}
    baselines = [(a, b) for a, b in plat.baselines if a in ant_index and b in ant_index]
    bl_idx = [(ant_index[a], ant_index[b]) for a, b in baselines]
    body = []
    for a, b in baselines:
        cal = settings.calibration.calibrated_baselines.get((a, b))
        body.append(np.asarray(cal, float) if cal is not None else plat.baseline_body_m(a, b))
    body = np.array(body)
    boresight = np.array([plat.antennas[a].boresight_body for a in antennas])
    prog(0.05, "platform position")
    master = plat.master if plat.master in ant_index else antennas[0]
    r_p, v_p, psrc = _platform_state(inputs, pobs, master)
    prog(0.10, "satellite geometry")
    sat_state, orbit_src = _sat_state(inputs, systems)
    observed = np.isfinite(pobs.code_m).any(axis=(0, 3))
    geom = compute_geometry(pobs.time, pobs.sats, observed, sat_state, r_p, v_p, psrc, background=background)
    R_ref_from_ecef = _R_ref_from_ecef(plat.kind, r_p, v_p)                      # (n_ep, 3, 3)
    # initial attitude
    k0 = int(np.argmax(np.isfinite(r_p).all(-1)))
    if settings.initial_q_body_from_ecef is not None:
        R0 = rot.quat_to_dcm(np.asarray(settings.initial_q_body_from_ecef, float))
    else:
        R0 = R_ref_from_ecef[k0]                 # Earth pointing (orbital frame) or level, heading north
    attitude_fn = None
    if len(baselines) >= 2:
        if settings.attitude_method != "triad":
            w_len = np.linalg.norm(body, axis=1)
            w_len = w_len / w_len.sum()
            body_c = np.ascontiguousarray(body, dtype=np.float64)

            def attitude_fn(b, fixed, k=None):
                # attitude_quaternion's QUEST (weights by length; also for "ml") for one epoch, compiled
                return quest_dcm(np.ascontiguousarray(b, dtype=np.float64), body_c, w_len)
        else:
            def attitude_fn(b, fixed, k=None):
                q, _ = attitude_quaternion(b[None], body, settings.attitude_method)
                return rot.quat_to_dcm(q[0])
    elif settings.calibration.pcv_maps:
        attitude_fn = single_baseline_attitude_fn(body[0], R_ref_from_ecef)
    prog(0.15, "filtering")
    try:
        fr = _filter_passes(pobs, geom, bl_idx, body, boresight, settings, R0, attitude_fn, prog)
    except BaseException:
        geom.cancel()                 # the geometry's background part, if it is still running
        raise
    geom.complete()
    prog(0.92, "attitude")
    sol = AttitudeSolution(settings, inputs, pobs, geom, fr, baselines, body, platform_defaults=defaults_applied)
    # ---- baselines table ----
    n_ep, n_bl = fr.ok.shape
    jj, kk = np.nonzero(fr.ok.T)          # baseline-major -> sort by epoch after
    order = np.lexsort((jj, kk))
    jj, kk = jj[order], kk[order]
    first_ant_pos = r_p[kk]
    lat, lon, _ = ecef_to_geodetic(first_ant_pos)
    Renu = R_enu_from_ecef(lat, lon)
    bvec = fr.b_ecef_m[kk, jj]
    Pbl = np.empty((kk.size, 3, 3))
    for a in range(3):
        for c in range(3):
            Pbl[:, a, c] = fr.P_b_m2[kk, 3 * jj + a, 3 * jj + c]
    L, az, el, sL, saz, sel = baseline_az_el(bvec, Pbl, Renu)
    sol.baseline_table = {"epoch": kk, "bl": jj, "b": bvec, "length_m": L, "azimuth_deg": az,
                          "elevation_deg": el, "sigma_length_m": sL, "sigma_azimuth_deg": saz,
                          "sigma_elevation_deg": sel, "fixed": fr.fixed[kk, jj], "n_sats": fr.n_sats[kk, jj]}
    # ---- attitude ----
    if n_bl >= 2:
        ep = np.flatnonzero(fr.ok.all(axis=1))
        q_e, P_th = attitude_from_baselines(fr.b_ecef_m[ep], fr.P_b_m2[ep], body, settings.attitude_method)
        good = np.isfinite(q_e).all(-1)
        ep, q_e, P_th = ep[good], q_e[good], P_th[good]
        R_be = rot.quat_to_dcm(q_e)
        t_ep = pobs.time[ep]
        R_gcrf_ecef = R_gcrf_from_ecef(t_ep)
        leap_warning = expiry_warning(t_ep)  # GCRF needs UT1 via UTC: stale after the leap table's expiry
        if leap_warning:
            sol.inputs.warnings.append(f"attitude in GCRF: {leap_warning}")
        R_bi = R_be @ np.swapaxes(R_gcrf_ecef, -1, -2)
        q_i = rot.dcm_to_quat(R_bi)
        R_b_ref = R_be @ np.swapaxes(R_ref_from_ecef[ep], -1, -2)
        # the antennas' unmodelled phase-centre offsets: a consider term (gnssatt.attitude.antenna_consider); the
        # estimate q_e is computed without it and stays as it is
        P_c, sol.sigma_consider_euler_deg, sol.antenna_consider = attitude_consider(
            plat, baselines, list(pobs.signals), settings, q_e, fr.b_ecef_m[ep], body, R_b_ref)
        yaw, pitch, roll, sy, sp, sr = euler_and_sigma(R_b_ref, P_th + P_c)
        if fr.smoother_data is not None and fr.smoother_data.get("covariance") is not None:
            fr.smoother_data["covariance"]["antenna_consider_deg"] = sol.antenna_consider["attitude_sigma_deg_median"]
        sol.att_epochs = ep
        sol.q_body_from_ecef = rot.quat_normalize(q_e)
        sol.q_body_from_gcrf = q_i
        sol.euler_deg = np.stack([yaw, pitch, roll], 1)
        sol.sigma_euler_deg = np.stack([sy, sp, sr], 1)
        sol.att_fixed = fr.fixed[ep].all(axis=1)
        sol.att_n_sats = fr.n_sats[ep].max(axis=1)
    prog(0.95, "statistics")
    from gnssatt.attitude.statistics import summarize
    sol.summary = summarize(sol, R_ref_from_ecef, orbit_src)
    if sol.antenna_consider is not None:
        sol.summary["antenna_consider"] = sol.antenna_consider
    return sol
