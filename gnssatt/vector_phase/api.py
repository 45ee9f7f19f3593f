"""The vector-phase attitude in one call, without a server: `solve_set(files, options)` reads a single-antenna
observation set (gnssatt.vector_phase.inputs), starts from the reference attitude's first epoch, a given attitude
or a coarse search, runs the EKF or the epoch-wise estimator (seed 003 eq. 44-45) and returns a
`VectorPhaseResult`, whose `products()` / `write_products(out_dir)` give the job's products (attitude.csv,
observability.csv, residuals.csv, summary.json, the plots and report.html). `solve_observations` does the same
on PhaseObservations already in memory (tests, bench).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gnssatt.vector_phase.batch import BatchOptions, batch_solve
from gnssatt.vector_phase.ekf import EkfOptions, ekf_solve
from gnssatt.vector_phase.phase_model import ReceiverState
from gnssatt.vector_phase.solution import euler_rows

__all__ = ["VectorPhaseOptions", "VectorPhaseResult", "solve_set", "solve_observations"]


@dataclass(frozen=True)
class VectorPhaseOptions:
    """estimator: "ekf" or "batch"; initial_attitude: "reference" (the set's reference attitude at the first
    epoch), "given" (q_body_from_ecef) or "coarse-search"; initial_position_ecef_m: None = the code solution's
    median (metres off: position then absorbs part of the phase changes); ekf / batch: the estimators' options;
    coarse_step_deg / coarse_tilt_max_deg / coarse_epochs: the coarse search grid;
    position_random_walk_m_per_sqrt_s: solve_set sets ekf.q_position_m2_s from it, None = by the set
    (gnssatt.vector_phase.defaults: 0 static, the velocity's sigma when the set gives a velocity)."""

    estimator: str = "ekf"
    initial_attitude: str = "reference"
    q_body_from_ecef: tuple | None = None
    initial_position_ecef_m: tuple | None = None
    antenna_id: str | None = None
    antenna_model: str | None = None
    sigma_phase_cyc: float = 0.005
    elevation_mask_deg: float = 10.0
    ekf: EkfOptions = field(default_factory=EkfOptions)
    batch: BatchOptions = field(default_factory=BatchOptions)
    coarse_step_deg: float = 30.0
    coarse_tilt_max_deg: float = 0.0
    coarse_epochs: int = 60
    position_random_walk_m_per_sqrt_s: float | None = None


@dataclass
class VectorPhaseResult:
    """solution (Solution), euler (EulerRows), R_ref_from_ecef (n_ep, 3, 3) of the Euler angles' reference frame
    (NED or orbital), R_ecef_from_gcrf (n_ep, 3, 3), reference_euler_deg (n_ep, 3) or None, summary (dict)."""

    solution: object
    euler: object
    R_ref_from_ecef: np.ndarray
    R_ecef_from_gcrf: np.ndarray
    reference_euler_deg: np.ndarray | None
    summary: dict

    def products(self, job_id: str | None = None, with_plots: bool = True) -> dict:
        """Product name -> content (text, dict or PNG bytes)."""
        from gnssatt.report import html_report
        from gnssatt.vector_phase.plots import vector_phase_plots
        from gnssatt.vector_phase.products import attitude_csv, observability_csv, residuals_csv

        summary = dict(self.summary, job_id=job_id) if job_id else dict(self.summary)
        out = {"attitude.csv": attitude_csv(self.solution, self.euler, self.R_ecef_from_gcrf),
               "observability.csv": observability_csv(self.solution),
               "residuals.csv": residuals_csv(self.solution), "summary.json": summary}
        if with_plots:
            pngs = vector_phase_plots(self.solution, self.euler, self.reference_euler_deg)
            out.update(pngs)
            out["report.html"] = html_report("Single-antenna attitude · vector phase (seed 003)", summary, pngs)
        return out

    def write_products(self, out_dir, job_id: str | None = None) -> dict[str, Path]:
        from gnssatt.product_files import write_product_files

        return write_product_files(self.products(job_id), out_dir)


def _ref_frames(sol, kind: str, position_ecef_m):
    """R_ref_from_ecef (n_ep, 3, 3): NED at the position (terrestrial) or the orbital frame (spacecraft)."""
    from gnssatt.gnss.frames import R_ned_from_ecef, R_orbital_from_ecef, ecef_to_geodetic

    n = len(sol.t_gps_s)
    if kind == "spacecraft":
        r = np.where(np.isfinite(sol.position_ecef_m), sol.position_ecef_m, position_ecef_m)
        v = np.gradient(r, sol.t_gps_s, axis=0) if n > 1 else np.zeros((n, 3))
        return R_orbital_from_ecef(r, v)
    lat, lon, _ = ecef_to_geodetic(np.asarray(position_ecef_m, float))
    return np.broadcast_to(R_ned_from_ecef(lat, lon), (n, 3, 3)).copy()


def _gcrf(t_gps_s):
    from gnssatt.gnss.frames import R_ecef_from_gcrf
    from gnssatt.gnss.time import GpsTime

    whole = np.floor(t_gps_s).astype(np.int64)
    return R_ecef_from_gcrf(GpsTime(whole, t_gps_s - whole))


def solve_observations(obs, mount, initial: ReceiverState, options: VectorPhaseOptions | None = None, *,
                       kind: str = "terrestrial", reference_R_body_from_ecef=None, progress=None,
                       extra_summary: dict | None = None) -> VectorPhaseResult:
    """VectorPhaseResult of PhaseObservations from a known initial state."""
    opt = options or VectorPhaseOptions()
    if opt.estimator == "batch":
        sol = batch_solve(obs, mount, initial, opt.batch, progress)
    else:
        sol = ekf_solve(obs, mount, initial, opt.ekf, progress)
    R_ref = _ref_frames(sol, kind, initial.position_ecef_m)
    euler = euler_rows(sol, R_ref, mount.R_ant_from_body[2])
    ref_deg = None
    summary = _summary(sol, euler, mount, opt)
    if reference_R_body_from_ecef is not None:
        from gnssatt.vector_phase.comparison import compare_with_reference
        ref_deg, summary["reference_comparison"] = compare_with_reference(sol, euler, R_ref, mount,
                                                                          reference_R_body_from_ecef)
    summary.update(extra_summary or {})
    return VectorPhaseResult(sol, euler, R_ref, _gcrf(sol.t_gps_s), ref_deg, summary)


def _summary(sol, euler, mount, opt: VectorPhaseOptions) -> dict:
    texts, counts = np.unique(np.asarray(sol.observability, dtype=object).astype(str), return_counts=True)
    res = sol.residuals_cyc[np.isfinite(sol.residuals_cyc)]
    return {"method": "vector-phase", "estimator": sol.method, "antenna_model": mount.antenna.name,
            "epochs": int(len(sol.t_gps_s)), "epochs_with_solution": int(sol.valid.sum()),
            "satellites": list(sol.sats), "sigma_phase_cyc": float(opt.sigma_phase_cyc),
            "observability": {t: int(c) for t, c in zip(texts, counts)},
            "angles_determined_fraction": {a: float(np.mean(euler.determined[sol.valid, i])) if sol.valid.any()
                                           else 0.0 for i, a in enumerate(("yaw", "pitch", "roll"))},
            "median_sigma_deg": {a: float(np.nanmedian(euler.sigma_deg[:, i]))
                                 if np.isfinite(euler.sigma_deg[:, i]).any() else None
                                 for i, a in enumerate(("yaw", "pitch", "roll"))},
            "rms_residual_cyc": float(np.sqrt(np.mean(res ** 2))) if res.size else None,
            "frames": "ECEF with zero EOP; Euler angles 3-2-1 of body relative to NED (terrestrial) or the "
                      "orbital frame (spacecraft)", "warnings": list(sol.warnings),
            "start_hypotheses": sol.start_hypotheses}


def _initial(inputs, opt: VectorPhaseOptions, position, R_ref0):
    """(R_body_from_ecef at the first epoch, its source, the coarse-search record or None)."""
    from gnssatt.vector_phase.inputs import InputProblem

    if opt.initial_attitude == "given":
        if opt.q_body_from_ecef is None:
            raise InputProblem("No initial attitude", "initial_attitude 'given' needs q_body_from_ecef",
                               field="config.vector_phase.q_body_from_ecef")
        from gnssatt.gnss.rotations import quat_to_dcm
        return quat_to_dcm(np.asarray(opt.q_body_from_ecef, float)), "given", None
    if opt.initial_attitude == "coarse-search":
        from gnssatt.vector_phase.coarse_search import coarse_search
        found = coarse_search(inputs.obs, inputs.mount, position, R_ref0, step_deg=opt.coarse_step_deg,
                              tilt_max_deg=opt.coarse_tilt_max_deg, n_epochs=opt.coarse_epochs,
                              min_sats=opt.ekf.min_sats)
        return found.R_body_from_ecef, "coarse-search", found
    if inputs.reference is None:
        raise InputProblem("No initial attitude", "initial_attitude 'reference' needs a reference attitude file "
                           "in the set (CONVENTIONS.md); or give q_body_from_ecef, or use 'coarse-search'",
                           field="config.vector_phase.initial_attitude")
    from gnssatt.vector_phase.comparison import reference_R_body_from_ecef
    R = reference_R_body_from_ecef(inputs.reference, inputs.obs.t_gps_s[:1])[0]
    if not np.all(np.isfinite(R)):
        raise InputProblem("No initial attitude", "the reference attitude does not cover the first epoch",
                           field="config.vector_phase.initial_attitude")
    return R, "reference", None


def _position_walk(opt: VectorPhaseOptions, inputs) -> tuple[VectorPhaseOptions, list]:
    """(options with ekf.q_position_m2_s set, [the default applied] or [])."""
    from dataclasses import replace

    from gnssatt.vector_phase.defaults import position_walk_default
    applied = []
    walk = opt.position_random_walk_m_per_sqrt_s
    if walk is None:
        walk, record = position_walk_default(inputs.obs.velocity_ecef_m_s is not None, inputs.sigma_velocity_m_s)
        applied.append(record)
    return replace(opt, ekf=replace(opt.ekf, q_position_m2_s=float(walk) ** 2)), applied


def solve_set(files, options: VectorPhaseOptions | None = None, progress=None) -> VectorPhaseResult:
    """VectorPhaseResult of an observation set given as (name, kind, path) triples (gnssatt.attitude.api.
    identify_files gives them for plain paths). Raises gnssatt.vector_phase.inputs.InputProblem."""
    from gnssatt.vector_phase.comparison import reference_R_body_from_ecef
    from gnssatt.vector_phase.inputs import InputProblem, load_set

    opt = options or VectorPhaseOptions()
    inputs = load_set(files, antenna_id=opt.antenna_id, antenna_model=opt.antenna_model,
                      sigma_phase_cyc=opt.sigma_phase_cyc, elevation_mask_deg=opt.elevation_mask_deg)
    n_sats = np.sum(np.isfinite(inputs.obs.phase_cyc), axis=1)
    need = opt.ekf.min_sats if opt.estimator == "ekf" else opt.batch.min_sats
    if n_sats.max(initial=0) < need:
        raise InputProblem("Too few satellites", f"{inputs.obs_file}: at most {int(n_sats.max(initial=0))} GPS "
                           f"satellites with L1 phase above the {opt.elevation_mask_deg:g} deg mask at any epoch; "
                           f"the vector-phase method needs >= {need} (position, clock and three angles, seed 003 "
                           "eq. 45)", file=inputs.obs_file)
    opt, applied = _position_walk(opt, inputs)
    position = (np.asarray(opt.initial_position_ecef_m, float) if opt.initial_position_ecef_m is not None
                else inputs.a_priori_position_ecef_m)
    kind = inputs.platform.kind
    from gnssatt.vector_phase.solution import Solution
    R_ref0 = _ref_frames(Solution.empty(inputs.obs.t_gps_s[:1], [], "x"), kind, position)[0]
    R0, source, coarse = _initial(inputs, opt, position, R_ref0)
    ref = reference_R_body_from_ecef(inputs.reference, inputs.obs.t_gps_s) if inputs.reference is not None else None
    extra = {"initial_attitude": source, "antenna_id": inputs.antenna_id, "observation_file": inputs.obs_file,
             "initial_position_source": "config" if opt.initial_position_ecef_m is not None else "code solution",
             "defaults_applied": applied}
    if coarse is not None:
        extra["coarse_search"] = {"euler_deg": list(coarse.euler_deg), "score": coarse.score,
                                  "second_score": coarse.second_score, "candidates": coarse.n_candidates,
                                  "ambiguous": coarse.ambiguous}
    result = solve_observations(inputs.obs, inputs.mount, ReceiverState(position, 0.0, R0), opt, kind=kind,
                                reference_R_body_from_ecef=ref, progress=progress, extra_summary=extra)
    result.summary["warnings"] = list(inputs.warnings) + result.summary["warnings"]
    return result
