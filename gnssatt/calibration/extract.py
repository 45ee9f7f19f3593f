"""The ONE adapter between calibration and whatever produces fixed single-difference phases and epoch-wise
baselines for an observation set. Everything else in gnssatt/calibration works on what this module returns
(`SetExtraction`); `ExtractOptions.producer` chooses the producer.

Producers:
- "filter-kinematic" (default, seed 000 sec. 3.1): the attitude filter in kinematic mode
  (gnssatt.calibration.filter_baselines) gives the epoch-wise ECEF baselines and their covariances at the epochs
  where it has them fixed; the single-difference integers of the map statistics are those of the filter's fixed
  baseline at each epoch (rounded from it after removing the epoch's common phase, gnssatt.calibration.kinematic),
  the samples screened by the epoch-wise least squares' 10 cm gate. No reference attitude is used to fix anything.
- "reference-aided-ablation": the calibration's former own processor, kept only as an ablation
  (gnssatt.calibration.kinematic): the reference attitude predicts each baseline, the integers are rounded from
  that prediction and the baselines come from epoch-wise least squares (3 components + one clock per signal).
Both use the reference attitude to rotate the baselines and lines of sight into the body frame.

Inputs: RINEX observations of the platform's antennas, broadcast (or SP3) GNSS orbits, the reference attitude and,
when the set has one, the platform's own SP3 for its position and velocity; without it they come from single point
positioning of the master antenna's code (gnssatt.calibration.platform_state; CONVENTIONS.md "The platform's own
orbit").

Interface:
    load_set(input_set, options) -> SetData           (files -> arrays; SetInputError naming the set and file)
    extract(set_data, baselines_body, options, corrections=None) -> SetExtraction
SetExtraction: epochs, reference (R_body_from_ecef, ok), per baseline the epoch-wise ECEF baseline with covariance
and a `FixedPhases` table per signal (see gnssatt.calibration.pcv).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnssatt.calibration.kinematic import DEFAULT_GATE_M, BaselineFix, BaselineObservations, solve_baseline
from gnssatt.calibration.pcv import FixedPhases
from gnssatt.calibration.reference import ReferenceAtEpochs, reference_at_epochs
from gnssatt.gnss.constants import C_M_S
from gnssatt.gnss.signals import SIGNALS as _SIGNAL_TABLE
from gnssatt.gnss.time import GpsTime

#: signal name -> RINEX 3 (code, phase, C/N0) candidates in order of preference, carrier frequency: the GPS L1
#: and L2 entries of the signal table (gnssatt.gnss.signals.SIGNALS); calibration is GPS-only
SIGNALS = {name: _SIGNAL_TABLE[name] for name in ("L1", "L2")}


@dataclass
class ExtractOptions:
    """What extraction needs from the job config (defaults: seed 000 Tables 1-2)."""

    signals: tuple = ("L1", "L2")
    sigma_phase_m: float = 0.003  # undifferenced phase, Table 1; single difference sqrt(2) x
    cn0_mask_dbhz: dict = field(default_factory=lambda: {"L1": 35.0, "L2": 30.0})  # Table 2
    elevation_mask_antenna_deg: float = 0.0  # both antennas of a baseline
    max_reference_gap_s: float = 10.0
    gate_m: float = DEFAULT_GATE_M  # residual gate of the epoch-wise least squares (kinematic.py)
    # phase variance x 10^((reference - C/N0)/10) per antenna (tracking-loop jitter ~ 1/sqrt(C/N0), clipped to
    # [1/4, 16]). Off by default: on the simulated 10-set campaign it made the baselines (x +0.6/+0.9 mm vs
    # +0.3/+0.3 mm) and the raw L2 maps (4.5 vs 3.6 mm RMS) worse, the errors there being dominated by
    # time-correlated multipath that C/N0 does not see (docs/calibration.md); False = equal weights (Table 1)
    cn0_weighting: bool = False
    cn0_reference_dbhz: float = 45.0
    # where the epoch-wise baselines come from (module docstring): the attitude filter's kinematic mode, or the
    # former reference-aided processor as an ablation
    producer: str = "filter-kinematic"


#: ExtractOptions.producer values: the attitude filter's kinematic mode (default) and the ablation
PRODUCERS = ("filter-kinematic", "reference-aided-ablation")


def cn0_variance_factor(cn0_a_dbhz: np.ndarray, cn0_b_dbhz: np.ndarray, reference_dbhz: float = 45.0) -> np.ndarray:
    """Variance factor of a single difference relative to two antennas at the reference C/N0: the mean of
    10^((ref - C/N0)/10) of both antennas, each clipped to [0.25, 16] (NaN C/N0 counts as the reference).
    Implements: carrier tracking jitter variance ~ 1/(C/N0) (Kaplan & Hegarty, 2006, eq. 8.34, thermal term)."""
    def one(c):
        return np.clip(10.0 ** ((reference_dbhz - np.nan_to_num(c, nan=reference_dbhz)) / 10.0), 0.25, 16.0)
    return 0.5 * (one(cn0_a_dbhz) + one(cn0_b_dbhz))


class SetInputError(Exception):
    """A set cannot be used; `file` names the file at fault when there is one."""

    def __init__(self, message: str, file: str | None = None):
        super().__init__(message)
        self.file = file


@dataclass
class SetData:
    """Arrays of one observation set on common epochs (n_ep), GPS satellites (n_sat), signals (n_sig)."""

    label: str
    platform: object  # gnssatt.gnss.io.platform.Platform
    epochs: GpsTime
    sats: list
    signals: list
    wavelength_m: np.ndarray
    code_m: dict  # antenna -> (n_ep, n_sat, n_sig)
    phase_m: dict
    cn0_dbhz: dict
    los_ecef: np.ndarray  # (n_ep, n_sat, 3)
    range_rate_m_s: np.ndarray  # (n_ep, n_sat)
    reference: ReferenceAtEpochs
    position_source: str = "platform SP3"
    attitude_inputs: object = None  # gnssatt.attitude.process.AttitudeInputs of the same parsed files
    filter_runs: dict = field(default_factory=dict)  # cache: baselines key -> FilterBaselines


@dataclass
class SetExtraction:
    """Output of `extract` for one set: epochs, reference, baselines (first, second), per baseline a BaselineFix
    (ECEF epoch-wise solution) and per (baseline index, signal) FixedPhases in the body frame."""

    label: str
    epochs: GpsTime
    reference: ReferenceAtEpochs
    baselines: list
    fixes: list  # BaselineFix per baseline
    fixed_phases: dict  # (baseline index, signal) -> FixedPhases
    az_deg: list  # per baseline (n_ep, n_sat) antenna-frame azimuth of the first antenna
    el_deg: list


def _tag_ms(t: GpsTime) -> np.ndarray:
    return t.s.astype(np.int64) * 1000 + np.round(t.frac * 1000.0).astype(np.int64)


def _pick(obs, candidates):
    for code in candidates:
        if obs.code_index(code, "G") is not None:
            return code
    return None


def load_set(input_set, options: ExtractOptions) -> SetData:
    """SetData of an InputSet (worker.context): platform, observations, orbits, own orbit, reference attitude.

    Raises SetInputError naming what is missing (the caller turns it into a JobInputError naming the set).
    """
    from gnssatt.gnss.ephemeris import BroadcastEphemeris, PreciseEphemeris
    from gnssatt.gnss.geometry import emission_time_and_position
    from gnssatt.gnss.io.platform import match_observation_files, parse_platform
    from gnssatt.gnss.io.reference_attitude import read_reference_attitude
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs
    from gnssatt.gnss.io.sp3 import read_sp3
    from gnssatt.gnss.orbits.sp3_interp import interpolate_sp3, interpolate_sp3_velocity

    label = input_set.name or input_set.id
    plat_files = input_set.of_kind("platform")
    if not plat_files:
        raise SetInputError("has no platform.json")
    platform = parse_platform(plat_files[0].path.read_bytes(), plat_files[0].name)
    ref_files = input_set.of_kind("reference_attitude")
    if not ref_files:
        raise SetInputError("has no reference attitude (a CSV time_gps,frame,qw,qx,qy,qz); calibration needs one")
    ref = read_reference_attitude(ref_files[0].path.read_bytes(), ref_files[0].name)
    obs_files = {f.name: f for f in input_set.of_kind("rinex_obs")}
    mapping = match_observation_files(platform, {n: f.summary.get("marker_name") for n, f in obs_files.items()},
                                      plat_files[0].name)
    obs = {ant: read_rinex_obs(obs_files[fname].path, name=fname) for ant, fname in mapping.items()}
    # orbits: GNSS SP3 or broadcast navigation; the platform's own SP3 (non-GNSS satellite id)
    gnss_sp3, own_sp3 = None, None
    for f in input_set.of_kind("sp3"):
        s = read_sp3(f.path, name=f.name)
        if any(sat[:1] in "GREJC" and sat[1:].isdigit() for sat in s.sats) and len(s.sats) > 3:
            gnss_sp3 = s
        else:
            own_sp3 = s
    nav_files = input_set.of_kind("rinex_nav")
    nav = read_rinex_nav(nav_files[0].path, name=nav_files[0].name) if nav_files else None
    if gnss_sp3 is not None:
        eph = PreciseEphemeris(gnss_sp3, nav=nav)
    elif nav is not None:
        eph = BroadcastEphemeris(nav)
    else:
        raise SetInputError("has no GNSS orbits (a RINEX navigation file or an SP3 of the GNSS satellites)")

    antennas = list(platform.antennas)
    tags = [_tag_ms(obs[a].time) for a in antennas]
    all_tags = np.unique(np.concatenate(tags))
    sats = sorted({s for a in antennas for s in obs[a].sats if s[0] == "G"})
    col = {s: i for i, s in enumerate(sats)}
    sigs = list(options.signals)
    n_ep, n_sat, n_sig = len(all_tags), len(sats), len(sigs)
    lam = np.array([C_M_S / SIGNALS[s]["freq_hz"] for s in sigs])
    code, phase, cn0 = {}, {}, {}
    for a, tg in zip(antennas, tags):
        o = obs[a]
        rows = np.searchsorted(all_tags, tg)
        src = np.array([i for i, s in enumerate(o.sats) if s[0] == "G"], dtype=np.int64)
        dst = np.array([col[o.sats[i]] for i in src], dtype=np.int64)
        c_arr = np.full((n_ep, n_sat, n_sig), np.nan)
        p_arr = np.full((n_ep, n_sat, n_sig), np.nan)
        s_arr = np.full((n_ep, n_sat, n_sig), np.nan)
        for k, sig in enumerate(sigs):
            spec = SIGNALS[sig]
            cc, pc, sc = _pick(o, spec["code"]), _pick(o, spec["phase"]), _pick(o, spec["snr"])
            if cc is None or pc is None:
                continue
            c_arr[rows[:, None], dst[None, :], k] = o.values[:, src, o.code_index(cc, "G")]
            p_arr[rows[:, None], dst[None, :], k] = o.values[:, src, o.code_index(pc, "G")] * lam[k]
            if sc is not None:
                s_arr[rows[:, None], dst[None, :], k] = o.values[:, src, o.code_index(sc, "G")]
        c_arr[c_arr == 0.0] = np.nan
        p_arr[p_arr == 0.0] = np.nan
        code[a], phase[a], cn0[a] = c_arr, p_arr, s_arr
    t = GpsTime(all_tags // 1000, (all_tags % 1000) / 1000.0)
    reference = reference_at_epochs(ref, t, max_gap_s=options.max_reference_gap_s)

    # geometry at the platform's centre (one line of sight for all antennas: < 1e-7 rad apart): the platform's
    # SP3, else single point positioning of the master antenna's code
    if own_sp3 is not None:
        pos, _ = interpolate_sp3(own_sp3, [own_sp3.sats[0]], t)
        vel = interpolate_sp3_velocity(own_sp3, [own_sp3.sats[0]], t)
        r_rx, v_rx = pos[:, 0], vel[:, 0]
        source = f"platform SP3 {own_sp3.name}"
    else:
        from gnssatt.calibration.platform_state import platform_state_from_code

        master = platform.master if platform.master in obs else antennas[0]
        try:
            st = platform_state_from_code(obs[master], eph, t, mapping[master])
        except ValueError as exc:
            raise SetInputError(f"has no SP3 of the platform and {exc}", file=mapping[master]) from exc
        r_rx, v_rx, source = st.r_ecef_m, st.v_ecef_m_s, st.source
    seen = np.zeros((n_ep, n_sat), bool)
    for a in antennas:
        seen |= np.isfinite(phase[a]).any(-1)
    ie, js = np.nonzero(seen & np.isfinite(r_rx).all(-1)[:, None])
    los = np.full((n_ep, n_sat, 3), np.nan)
    rr = np.full((n_ep, n_sat), np.nan)
    if ie.size:
        res = emission_time_and_position(eph.state, np.asarray(sats)[js], r_rx[ie], GpsTime(t.s[ie], t.frac[ie]))
        los[ie, js] = res.los_ecef
        rr[ie, js] = np.einsum("ij,ij->i", res.los_ecef, res.v_sat_ecef_m_s - np.nan_to_num(v_rx[ie]))
    from gnssatt.attitude.process import AttitudeInputs

    att_inputs = AttitudeInputs(platform, obs, dict(mapping), nav=nav, gnss_sp3=gnss_sp3, platform_sp3=own_sp3,
                                reference=ref)
    return SetData(label, platform, t, sats, sigs, lam, code, phase, cn0, los, rr, reference, source, att_inputs)


def filter_run(data: SetData, baselines_body: dict, options: ExtractOptions):
    """FilterBaselines (gnssatt.calibration.filter_baselines) of the set with these body baselines, run once per
    set and baselines (cached on `data`: pass 2 and the held-out comparison reuse pass 1's run of the same task).
    Raises SetInputError when the filter cannot process the set."""
    from gnssatt.calibration.filter_baselines import filter_baselines

    key = tuple((tuple(k), tuple(round(float(x), 9) for x in v)) for k, v in sorted(baselines_body.items()))
    if key not in data.filter_runs:
        try:
            data.filter_runs[key] = filter_baselines(data, baselines_body, options)
        except ValueError as exc:
            raise SetInputError(f"could not be processed by the attitude filter's kinematic mode: {exc}") from exc
    return data.filter_runs[key]


def _filter_fix(obs: BaselineObservations, kin, bi: int, corr, options: ExtractOptions) -> BaselineFix:
    """BaselineFix of baseline bi from the filter's kinematic run `kin`: the integers of the filter's fixed
    baseline (rounded from it; epochs it has not fixed give nothing), the samples screened by the epoch-wise
    least squares' gate. Without corrections the baselines and covariances are the filter's; with PCV
    corrections (the epoch-wise held-out comparison) they are the corrected epoch-wise least squares on the
    filter's integers."""
    b_f = kin.b_ecef_m[bi]
    fix = solve_baseline(obs, b_f, correction_m=corr, gate_m=options.gate_m, fix_correction_m=None)
    if corr is not None:
        return fix
    ok = fix.ok & kin.fixed[:, bi]
    return BaselineFix(np.where(ok[:, None], b_f, np.nan), np.where(ok[:, None, None], kin.cov_ecef_m2[bi], np.nan),
                       ok, np.where(ok[:, None, None], fix.y_m, np.nan), np.where(ok[:, None, None], fix.weight, 0.0),
                       np.where(ok[:, None, None], fix.residual_m, np.nan))


def extract(data: SetData, baselines_body: dict, options: ExtractOptions,
            corrections: dict | None = None) -> SetExtraction:
    """SetExtraction of a loaded set.

    Args:
        baselines_body: (first, second) -> (3,) body-frame baseline: with the filter the body baselines of its
            length validation; in the ablation the prediction that fixes the integers. The epoch-wise solutions
            are free either way.
        corrections: optional (first, second, signal) -> callable(az_deg, el_deg) -> mm, PCV maps subtracted from
            the single differences before the epoch-wise solution (not used for fixing or FixedPhases).
    """
    from gnssatt.gnss.geometry import R_antenna_from_body

    plat = data.platform
    R_be = data.reference.R_body_from_ecef  # (n_ep, 3, 3), NaN without reference
    g_body = np.einsum("eij,esj->esi", R_be, data.los_ecef)
    sigma_sd = np.full(len(data.signals), np.sqrt(2.0) * options.sigma_phase_m)
    fixes, fixed, az_list, el_list = [], {}, [], []
    sat_idx = np.broadcast_to(np.arange(len(data.sats))[None, :], data.los_ecef.shape[:2])
    ep_idx = np.broadcast_to(np.arange(len(data.epochs))[:, None], data.los_ecef.shape[:2])
    if options.producer not in PRODUCERS:
        raise ValueError(f"ExtractOptions.producer {options.producer!r} is not one of {PRODUCERS} "
                         "(gnssatt/calibration/extract.py)")
    kin = filter_run(data, baselines_body, options) if options.producer == "filter-kinematic" else None
    for bi, (a1, a2) in enumerate(plat.baselines):
        b_body = np.asarray(baselines_body[(a1, a2)], dtype=np.float64)
        b_pred = np.einsum("eji,j->ei", R_be, b_body)  # R^T b
        d1 = np.einsum("ij,esj->esi", R_antenna_from_body(plat.antennas[a1].boresight_body), g_body)
        d2 = np.einsum("ij,esj->esi", R_antenna_from_body(plat.antennas[a2].boresight_body), g_body)
        az = np.degrees(np.mod(np.arctan2(d1[..., 1], d1[..., 0]), 2 * np.pi))
        el = np.degrees(np.arctan2(d1[..., 2], np.hypot(d1[..., 0], d1[..., 1])))
        el2 = np.degrees(np.arctan2(d2[..., 2], np.hypot(d2[..., 0], d2[..., 1])))
        ph = data.phase_m[a2] - data.phase_m[a1]
        cd = data.code_m[a2] - data.code_m[a1]
        mask = (el >= options.elevation_mask_antenna_deg) & (el2 >= options.elevation_mask_antenna_deg)
        mask = mask[..., None] & np.ones(len(data.signals), bool)
        for k, sig in enumerate(data.signals):
            lim = options.cn0_mask_dbhz.get(sig)
            if lim is not None:
                for a in (a1, a2):
                    c = data.cn0_dbhz[a][..., k]
                    mask[..., k] &= ~(np.isfinite(c) & (c < lim))
        ph = np.where(mask, ph, np.nan)
        cd = np.where(mask, cd, np.nan)
        corr = None
        if corrections:
            corr = np.zeros_like(ph)
            for k, sig in enumerate(data.signals):
                f = corrections.get((a1, a2, sig))
                if f is not None:
                    corr[..., k] = f(az, el) * 1e-3
        vfac = cn0_variance_factor(data.cn0_dbhz[a1], data.cn0_dbhz[a2], options.cn0_reference_dbhz) \
            if options.cn0_weighting else None
        obs = BaselineObservations(ph, cd, data.los_ecef, data.range_rate_m_s, data.wavelength_m, sigma_sd, vfac)
        if kin is None:
            fix = solve_baseline(obs, b_pred, correction_m=corr, gate_m=options.gate_m, fix_correction_m=None)
        else:
            fix = _filter_fix(obs, kin, bi, corr, options)
        fixes.append(fix)
        az_list.append(az)
        el_list.append(el)
        if corr is None:
            for k, sig in enumerate(data.signals):
                keep = np.isfinite(fix.y_m[..., k]) & data.reference.ok[:, None]
                fixed[(bi, sig)] = FixedPhases(ep_idx[keep].astype(np.int64), sat_idx[keep].astype(np.int64),
                                               fix.y_m[..., k][keep], g_body[keep], az[keep], el[keep],
                                               fix.weight[..., k][keep])
    return SetExtraction(data.label, data.epochs, data.reference, list(plat.baselines), fixes, fixed, az_list,
                         el_list)


__all__ = ["SIGNALS", "PRODUCERS", "ExtractOptions", "filter_run", "cn0_variance_factor", "SetInputError", "SetData", "SetExtraction", "load_set", "extract",
           "BaselineFix"]
