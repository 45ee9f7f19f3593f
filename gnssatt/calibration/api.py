"""A calibration campaign in one call, without a server: `run_campaign(sets, ...)` runs the calibration job's
science (seed 000 sec. 3) over observation sets that each carry a reference attitude, and returns a
`CampaignResult` (calibrated baselines, differential PCV maps, residual statistics, the held-out comparison) whose
`write_products(out_dir)` writes the job's products.

The campaign is two passes over the sets and two reductions (gnssatt.calibration.campaign): pass 1 fixes each set
with the a priori baselines and reduces it to additive statistics; the baselines are averaged (Table 3) and the
maps iterated; pass 2 gives each set's residuals with the calibration and the final maps' counts and sigmas, and
on the held-out set the attitude filter without and with the calibration. A pass is handed to a map function as a
FanOut (gnssatt.calibration.tasks): by default every task runs here, in set order; the worker passes its own so
the tasks spread over its workers. Results are reduced in set order either way, so the products do not depend on
the map function. See docs/library.md for a runnable example.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

from gnssatt.calibration.campaign import (CampaignOptions, MapResult, SetFinal, SetStats, combine_residual_stats,
                                          finish_maps, reduce_baselines, reduce_maps, split_baselines)
from gnssatt.calibration.checks import CampaignError, check_campaign
from gnssatt.gnss.io.reader_warnings import reader_warnings
from gnssatt.calibration.held_out import HeldOutAttitude
from gnssatt.calibration.tasks import (HELD_OUT_COST, STAGE_PASS1, STAGE_PASS2, FanOut, SetTask,
                                       calibration_of_shared, run_task, set_infos, set_label, shared_of, task_cost)

__all__ = ["run_campaign", "CampaignResult", "campaign_sets", "in_process_map", "CampaignOptions",
           "HeldOutAttitude", "CampaignError"]

MapFunction = Callable[[FanOut], list]
Progress = Callable[..., None]


@dataclass
class CampaignResult:
    """What a calibration campaign gives.

    platform: the campaign's platform (gnssatt.gnss.io.platform.Platform); options: the CampaignOptions used;
    sets / held_out_set: labels of the calibration sets (set order) and of the held-out set ([] when none);
    baselines: Table 3 rows (BaselineRow: a priori, calibrated mean in the maps' split, batch-means sigma);
    calibrated_m: (first, second) -> (3,) calibrated body-frame baseline, m;
    maps: the iteration record per baseline and signal (MapResult: map_m as shared with pass 2, changes_mm,
    converged); final_maps: (first, second, signal) -> (values_mm, count, sigma_mm, final-pass residual_mm), each
    (n_el, n_az); pcv_maps: (first, second, signal) -> the map's CONVENTIONS JSON (pcv_<first>_<second>_<f>.json);
    residual_statistics: residual_statistics.json (before/after per baseline and signal, and "held_out");
    held_out_attitude: held_out_attitude.json, or None without a held-out set;
    reader_warnings: the input files' quirk warnings (gnssatt.gnss.io.reader_warnings), in set order;
    stats / finals: the per-set results of passes 1 and 2 (set order, the held-out set last in finals);
    pass1_runs / pass2_runs: per task {"seconds", "cpu_s"}; timing_s: wall seconds per stage.
    """

    platform: object
    options: CampaignOptions
    sets: list[str]
    held_out_set: list[str]
    baselines: list
    calibrated_m: dict
    maps: list[MapResult]
    final_maps: dict
    pcv_maps: dict
    residual_statistics: dict
    held_out_attitude: dict | None
    stats: list[SetStats]
    finals: list[SetFinal]
    pass1_runs: list[dict]
    pass2_runs: list[dict]
    timing_s: dict
    started_perf_s: float
    reader_warnings: list = field(default_factory=list)   # the input files' quirk warnings (reader_warnings)

    @property
    def held_out_table(self) -> list[dict]:
        """The report's held-out rows (gnssatt.calibration.products.held_out_table); [] without a held-out set."""
        from gnssatt.calibration.products import held_out_table

        return held_out_table(self.held_out_attitude) if self.held_out_attitude is not None else []

    def products(self, job_id: str | None = None, workers: dict | None = None) -> dict:
        """Product name -> content of the calibration job (gnssatt.calibration.products.campaign_products)."""
        from gnssatt.calibration.products import campaign_products

        return campaign_products(self, job_id, workers)

    def write_products(self, out_dir: str | Path, job_id: str | None = None) -> dict[str, Path]:
        """The job's products (but tasks.csv, the service's fan-out log) in out_dir; product name -> path."""
        from gnssatt.product_files import write_product_files

        return write_product_files(self.products(job_id), out_dir)


def campaign_sets(sets: Iterable, platform: str | Path | None = None) -> list:
    """The campaign's sets: each a directory (every file under it but truth/), a list of files, or a set object
    (id, name, files, of_kind, platform: gnssatt.gnss.io.observation_set.ObservationSet or the worker's
    InputSet), kept as it is. A directory is named after itself, a list of files "set-<n>". `platform`
    (platform.json) is added to each set of paths that has none."""
    from gnssatt.gnss.io.observation_set import ObservationSet

    out = []
    for i, s in enumerate(sets):
        if isinstance(s, (str, Path, list, tuple)):
            paths = [Path(s)] if isinstance(s, (str, Path)) else [Path(p) for p in s]
            set_id = paths[0].name if len(paths) == 1 and paths[0].is_dir() else f"set-{i + 1}"
            s = ObservationSet.of_paths(paths, set_id)
            if platform is not None and not s.of_kind("platform"):
                s = ObservationSet(s.id, s.name, s.files + ObservationSet.of_paths([platform], set_id).files)
        out.append(s)
    return out


def in_process_map(sets: list, options: CampaignOptions, progress: Progress | None = None) -> MapFunction:
    """The default map function: every task of a FanOut here, in set order (gnssatt.calibration.tasks.run_task),
    progress reported as tasks finish."""
    def map_fn(fan: FanOut) -> list:
        lo, hi = fan.progress_span
        out = []
        for i, task in enumerate(fan.tasks):
            if progress is not None:
                progress(lo + (hi - lo) * i / max(len(fan.tasks), 1), f"{fan.stage}: {i}/{len(fan.tasks)} done")
            out.append(run_task(fan, task, sets, options))
        return out
    return map_fn


def _raise_input_errors(results: list) -> None:
    for r in results:
        if isinstance(r, dict) and "input_error" in r:
            e = r["input_error"]
            raise CampaignError(e["title"], e["detail"], file=e.get("file"))


def _split_sets(sets: list, options: CampaignOptions, held_out: str | None):
    """(platform, calibration sets, [held-out set]) after the campaign checks that need no RINEX parsing (the
    calibration sets' reference coverage is checked in their pass-1 tasks, in parallel)."""
    from gnssatt.gnss.io.platform import parse_platform

    named = {s.id for s in sets if held_out in (s.id, s.name)} if held_out else set()
    check_campaign(set_infos(sets, read_reference=named), max_reference_gap_s=options.extract.max_reference_gap_s,
                   held_out=held_out)
    plat_file = sets[0].of_kind("platform")[0]
    platform = parse_platform(plat_file.path.read_bytes(), plat_file.name)
    held = [s for s in sets if held_out in (s.id, s.name)][:1] if held_out else []
    return platform, [s for s in sets if s.id not in {h.id for h in held}], held


def _calibrated_of(rows: list, n_sets: int) -> dict:
    """(first, second) -> (3,) m of the Table 3 rows; CampaignError when a baseline has no usable epoch."""
    calibrated = {(r.first, r.second): r.estimate.mean_m for r in rows}
    bad = [f"{a}>{b}" for (a, b), v in calibrated.items() if not np.all(np.isfinite(v))]
    if bad:
        raise CampaignError("No usable epochs", f"no epoch-wise solution survived for baseline(s) {bad} over "
                            f"{n_sets} set(s); check the reference attitude and the observations", about_sets=False)
    return calibrated


def run_campaign(sets: Iterable, platform: str | Path | None = None, options: CampaignOptions | None = None, *,
                 held_out: str | None = None, held_out_attitude: HeldOutAttitude | None = None,
                 map_fn: MapFunction | None = None, progress: Progress | None = None,
                 log: Callable[[str], None] | None = None) -> CampaignResult:
    """Calibrated baselines and differential PCV maps of a campaign: the calibration job's science on sets.

    Args:
        sets: the observation sets, in campaign order (campaign_sets: directories, lists of files or set objects);
            each with RINEX observations per antenna, GNSS orbits (navigation or SP3), the platform's own SP3, a
            reference attitude and platform.json.
        platform: platform.json, for sets of paths that lack one.
        options: CampaignOptions (extraction, grid, min_count, iteration, batch, gates); None = the job's defaults.
        held_out: id or name of a set kept out of the calibration and used for the before/after attitude.
        held_out_attitude: the attitude filter's processing of the held-out comparison (None: HeldOutAttitude.preset(),
            the job's default).
        map_fn: callable(FanOut) -> one result per task, in task order (gnssatt.calibration.tasks.run_task's);
            None = in_process_map.
        progress: optional callable(fraction in [0, 1], stage or None); log: optional callable(line).

    Raises CampaignError (title, detail, set_label, file) when the campaign cannot be calibrated; a file that
    cannot be parsed raises gnssatt.gnss.io.errors.ParseError.
    """
    t_start = time.perf_counter()
    options = options or CampaignOptions()
    sets = campaign_sets(sets, platform)
    progress = progress or (lambda fraction, stage=None: None)
    log = log or (lambda line: None)
    progress(0.0, "checking the campaign")
    plat, cal_sets, held = _split_sets(sets, options, held_out)
    if held and held_out_attitude is None:
        held_out_attitude = HeldOutAttitude.preset()
    log(f"calibration of {plat.name}: {len(cal_sets)} sets, held out: {[set_label(s) for s in held]}")
    map_fn = map_fn or in_process_map(sets, options, progress)
    timing = {}

    t0 = time.perf_counter()
    timing["checks"] = t0 - t_start
    r1 = map_fn(FanOut(1, STAGE_PASS1, (0.02, 0.5), [SetTask(s.id, set_label(s), False, task_cost(s))
                                                       for s in cal_sets]))
    _raise_input_errors(r1)
    timing["pass1"] = time.perf_counter() - t0
    stats = [r["stats"] for r in r1]
    rows = reduce_baselines(stats, plat)
    calibrated = _calibrated_of(rows, len(cal_sets))
    progress(0.5, "iterating PCV maps")
    t0 = time.perf_counter()
    map_results = reduce_maps(stats, calibrated, list(options.extract.signals), options,
                              boresights={a: ant.boresight_body for a, ant in plat.antennas.items()})
    calibrated = split_baselines(rows, map_results)   # baseline/map split made explicit (decomposition.py)
    timing["maps"] = time.perf_counter() - t0
    for m in map_results:
        log(f"map {m.first}>{m.second} {m.signal}: iterations {len(m.changes_mm)}, changes (mm RMS) "
            f"{[round(c, 4) for c in m.changes_mm]}, converged {m.converged}")

    t0 = time.perf_counter()
    shared = shared_of(calibrated, {(m.first, m.second, m.signal): m.map_m for m in map_results})
    # the held-out set costs ~12 set extractions (three extractions + two attitude filter runs): first in the queue
    held_ids = {s.id for s in held}
    tasks2 = [SetTask(s.id, set_label(s), s.id in held_ids, task_cost(s) * (HELD_OUT_COST if s.id in held_ids
                                                                            else 1.0)) for s in cal_sets + held]
    r2 = map_fn(FanOut(2, STAGE_PASS2, (0.52, 0.9), tasks2, shared, held_out_attitude))
    _raise_input_errors(r2)
    timing["pass2"] = time.perf_counter() - t0
    return _finish(plat, options, [cal_sets, held], rows, calibrated, map_results, shared, r1, r2, timing,
                   t_start)


def _finish(plat, options: CampaignOptions, sets: list, rows: list, calibrated: dict, map_results: list,
            shared: dict, r1: list, r2: list, timing: dict, t_start: float) -> CampaignResult:
    """Reduction 2 (final maps with the pass-2 counts and sigmas, residual statistics) and the result record."""
    from gnssatt.calibration.products import map_document

    t0 = time.perf_counter()
    cal_sets, held = sets
    finals = [r["final"] for r in r2]
    _, maps_m = calibration_of_shared(shared)   # the maps as pass 2 used them (rounded to 0.1 um)
    for m in map_results:
        m.map_m = maps_m[(m.first, m.second, m.signal)]
    final_maps = finish_maps(map_results, finals, options)
    pcv_maps = {}
    for m in map_results:
        key = (m.first, m.second, m.signal)
        values, count, sigma, _ = final_maps[key]
        pcv_maps[key] = map_document(plat.name, key, options.grid, values, count, sigma)
    resid = combine_residual_stats(finals)
    if held:
        resid["held_out"] = combine_residual_stats(finals, include_held_out=True)
    held_att = [f.attitude for f in finals if f.held_out]
    timing["finish"] = time.perf_counter() - t0
    runs = [[{k: r[k] for k in ("seconds", "cpu_s") if k in r} for r in rs] for rs in (r1, r2)]
    return CampaignResult(plat, options, [set_label(s) for s in cal_sets], [set_label(s) for s in held], rows,
                          calibrated, map_results, final_maps, pcv_maps, resid, held_att[0] if held_att else None,
                          [r["stats"] for r in r1], finals, runs[0], runs[1], timing, t_start,
                          reader_warnings(cal_sets + held))
