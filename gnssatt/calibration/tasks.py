"""One fan-out task of a calibration campaign: a set's pass 1 or pass 2 (gnssatt.calibration.campaign) with the
checks and the reading around it, as a picklable result. The library's in-process map (gnssatt.calibration.api)
and the worker's task entry points (worker/jobs/calibration.py) both call these.

A set is any object with `id`, `name`, `files` (each with `name`, `kind`, `path`, `summary`), `of_kind(kind)` and
`platform()`: gnssatt.gnss.io.observation_set.ObservationSet, or the worker's InputSet.

A task returns a dict: {"stats": SetStats} (pass 1) or {"final": SetFinal} (pass 2), with its wall and CPU
"seconds" / "cpu_s"; or {"input_error": {"title", "detail", "file"}} when the set cannot be used. The input error
is returned, not raised, so that a fan-out over workers fails the campaign once, naming the set, instead of
retrying the task; run_campaign raises it as a CampaignError.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from gnssatt.calibration.campaign import CampaignOptions, set_final, set_statistics
from gnssatt.calibration.held_out import HeldOutAttitude, held_out_attitude

__all__ = ["STAGE_PASS1", "STAGE_PASS2", "HELD_OUT_COST", "SetTask", "FanOut", "set_label", "find_set",
           "observation_span", "set_infos", "task_cost", "load_campaign_set", "statistics_of_set", "final_of_set",
           "shared_of", "calibration_of_shared", "run_task"]

STAGE_PASS1 = "pass 1 (baselines, PCV statistics)"
STAGE_PASS2 = "pass 2 (residuals, final maps, held-out set)"
#: the held-out task's cost in set extractions (pass 2: three extractions + two attitude filter runs)
HELD_OUT_COST = 12.0


@dataclass(frozen=True)
class SetTask:
    """One task of a fan-out: the set (by id), its label, whether it is the held-out set, and its expected cost
    (s of observations, x HELD_OUT_COST for the held-out set; 0 when unknown) to order the queue by."""

    set_id: str
    label: str
    held_out: bool = False
    cost_s: float = 0.0


@dataclass(frozen=True)
class FanOut:
    """One pass over the sets, handed to a map function: pass 1 (statistics) or 2 (final), its stage name and
    progress span, the tasks in set order, and for pass 2 what every task shares: `shared` (the calibrated
    baselines and maps, JSON-able: shared_of) and `held_out` (how the held-out set's attitude is computed)."""

    pass_number: int
    stage: str
    progress_span: tuple[float, float]
    tasks: list[SetTask]
    shared: dict | None = None
    held_out: HeldOutAttitude | None = field(default=None, compare=False)


def set_label(s) -> str:
    return s.name or s.id


def find_set(sets, set_id: str):
    for s in sets:
        if s.id == set_id:
            return s
    raise KeyError(f"set {set_id} is not an input of this campaign")


def observation_span(s):
    """(first, last) GpsTime of a set's observations from the files' summaries (no RINEX parsing)."""
    from gnssatt.gnss.time import GpsTime

    obs = s.of_kind("rinex_obs")
    firsts = [GpsTime.from_iso(f.summary["time_first"]) for f in obs if f.summary.get("time_first")]
    lasts = [GpsTime.from_iso(f.summary["time_last"]) for f in obs if f.summary.get("time_last")]
    first = min(firsts, key=lambda t: (int(t.s), float(t.frac))) if firsts else None
    last = max(lasts, key=lambda t: (int(t.s), float(t.frac))) if lasts else None
    return first, last


def set_infos(sets, read_reference) -> list:
    """SetInfo of each set (gnssatt.calibration.checks); the reference file is parsed only when read_reference is
    True or a collection holding the set's id (the calibration sets' references are checked in their own pass-1
    task; the parent checks what the summaries and platform.json give, and the held-out set's reference)."""
    from gnssatt.calibration.checks import SetInfo
    from gnssatt.gnss.io.reference_attitude import read_reference_attitude

    infos = []
    for s in sets:
        first, last = observation_span(s)
        refs = s.of_kind("reference_attitude")
        ref_times = None
        if refs and (read_reference is True or (read_reference and s.id in read_reference)):
            ref_times = read_reference_attitude(refs[0].path.read_bytes(), refs[0].name).time
        infos.append(SetInfo(s.id, set_label(s), s.platform(), first, last, refs[0].name if refs else None,
                             ref_times))
    return infos


def task_cost(s) -> float:
    """Expected cost of a set's task: its observation span (s); 0 when unknown."""
    first, last = observation_span(s)
    return float(last - first) if first is not None and last is not None else 0.0


def _input_error(title: str, detail: str, file: str | None = None) -> dict:
    return {"input_error": {"title": title, "detail": detail, "file": file}}


def load_campaign_set(s, options: CampaignOptions):
    """(SetData, None) of a set (gnssatt.calibration.extract.load_set), or (None, an {"input_error"} dict) when the
    set cannot be read or its reference attitude covers too few of its epochs (min_reference_coverage)."""
    from gnssatt.calibration.extract import SetInputError, load_set
    from gnssatt.gnss.io.errors import ParseError

    try:
        data = load_set(s, options.extract)
    except SetInputError as exc:
        return None, _input_error("Set unusable for calibration", f"set {set_label(s)!r} {exc}", exc.file)
    except ParseError as exc:
        return None, _input_error("An input file could not be parsed", f"set {set_label(s)!r}: {exc}", exc.path)
    if data.reference.coverage < options.min_reference_coverage:
        from gnssatt.calibration.reference import uncovered_spans
        spans = "; ".join(f"{a} to {b}" for a, b in uncovered_spans(data.epochs, data.reference.ok))
        return None, _input_error(
            "Reference attitude does not cover the observations",
            f"set {set_label(s)!r}: the reference attitude covers {100 * data.reference.coverage:.1f} % of the "
            f"observation epochs (min_reference_coverage {options.min_reference_coverage:g}); uncovered: {spans}")
    return data, None


def statistics_of_set(s, options: CampaignOptions) -> dict:
    """Pass 1 of one set: {"stats": SetStats (gnssatt.calibration.campaign.set_statistics), "seconds", "cpu_s"}
    or {"input_error": ...}.

    Also the set's own campaign check (reference attitude against the observation span, gnssatt.calibration.checks)
    that needs its reference file read: done here, in parallel, instead of in the parent before the fan-out."""
    from gnssatt.calibration.checks import CampaignError, check_campaign

    t0, c0 = time.perf_counter(), time.process_time()
    try:
        check_campaign(set_infos([s], read_reference=True), max_reference_gap_s=options.extract.max_reference_gap_s)
    except CampaignError as exc:
        return _input_error(exc.title, exc.detail, exc.file)
    data, err = load_campaign_set(s, options)
    if err:
        return err
    stats = set_statistics(data, options)
    return {"stats": stats, "seconds": time.perf_counter() - t0, "cpu_s": time.process_time() - c0}


def shared_of(calibrated: dict, maps_m: dict) -> dict:
    """What every pass-2 task shares, JSON-able: {"calibrated": {"A>B": [x, y, z] m}, "maps": {"A>B L1": [value m
    rounded to 0.1 um, or None on empty bins]}}; the parent reads the maps back from it too (calibration_of_shared),
    so both use the same rounded values."""
    return {"calibrated": {f"{a}>{b}": [float(x) for x in v] for (a, b), v in calibrated.items()},
            "maps": {f"{k[0]}>{k[1]} {k[2]}": [None if not np.isfinite(v) else round(float(v), 7) for v in m]
                     for k, m in maps_m.items()}}


def calibration_of_shared(shared: dict) -> tuple[dict, dict]:
    """(calibrated {(first, second): (3,) m}, maps {(first, second, signal): (n_bins,) m, NaN on empty bins}) of
    shared_of's document."""
    calibrated = {tuple(k.split(">")): np.asarray(v, float) for k, v in shared["calibrated"].items()}
    maps = {}
    for key, values in shared["maps"].items():
        bl, sig = key.rsplit(" ", 1)
        maps[tuple(bl.split(">")) + (sig,)] = np.array([np.nan if v is None else v for v in values], float)
    return calibrated, maps


def final_of_set(s, options: CampaignOptions, shared: dict, held_out: HeldOutAttitude | None = None) -> dict:
    """Pass 2 of one set: {"final": SetFinal (gnssatt.calibration.campaign.set_final), "seconds", "cpu_s"} or
    {"input_error": ...}. `shared`: shared_of's document; `held_out` given for the held-out set only (then the
    SetFinal's attitude is held_out_attitude.json: the attitude filter without and with the calibration)."""
    t0, c0 = time.perf_counter(), time.process_time()
    data, err = load_campaign_set(s, options)
    if err:
        return err
    calibrated, maps = calibration_of_shared(shared)
    final = set_final(data, calibrated, maps, options, held_out=held_out is not None)
    if held_out is not None:
        final.attitude = held_out_attitude(s, calibrated, maps, options.grid, held_out, final.attitude)
    return {"final": final, "seconds": time.perf_counter() - t0, "cpu_s": time.process_time() - c0}


def run_task(fan: FanOut, task: SetTask, sets, options: CampaignOptions) -> dict:
    """The result of one task of `fan` in this process (what a map function returns for it)."""
    s = find_set(sets, task.set_id)
    if fan.pass_number == 1:
        return statistics_of_set(s, options)
    return final_of_set(s, options, fan.shared, fan.held_out if task.held_out else None)
