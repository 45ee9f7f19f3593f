"""Held-out attitude comparison with the attitude filter (issue 6): the held-out set of a calibration campaign
processed as an attitude job would process it, once with the a priori baselines and no maps and once with the
calibrated baselines and the calibration's maps (applied by the filter, gnssatt.attitude.pcv_correction), each
compared with the set's reference attitude; bias and standard deviation of the errors per Euler angle over the
fixed epochs, and the cut (issue 8 "Done when": bias cut >= 80 %, std cut >= 30 %).

Implements: seed 000 sec. 3 (calibrated baselines + differential PCV maps in the filter) and sec. 4 (the filter's
attitude against the star tracker); the statistics are those of the attitude job's summary.json "reference".
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gnssatt.calibration.binning import Grid2D

if TYPE_CHECKING:
    from gnssatt.attitude.settings import AttitudeSettings

ANGLES = ("yaw", "pitch", "roll")

#: default processing of the held-out comparison: the attitude filter's lowest-noise documented processing (the
#: fixed-interval smoother, docs/attitude.md) on every tracked phase (no seed 000 Table 2 C/N0 or antenna-frame
#: masks: they drop the low antenna elevations where the differential PCV is largest); the calibration job's
#: default held_out_attitude_config {"preset": HELD_OUT_PRESET} (worker.jobs.calibration.HELD_OUT_ATTITUDE_DEFAULT)
HELD_OUT_PRESET = "all-phases-smoother"

__all__ = ["ANGLES", "HELD_OUT_PRESET", "HeldOutAttitude", "map_documents", "filter_errors", "cut_percent",
           "filter_comparison", "held_out_attitude"]


@dataclass
class HeldOutAttitude:
    """How the held-out set's attitude is computed: the attitude filter's settings
    (gnssatt.attitude.settings.AttitudeSettings) and their record written into held_out_attitude.json as
    "attitude_config" (the calibration job writes its held_out_attitude_config there)."""

    settings: "AttitudeSettings"
    config: dict = field(default_factory=dict)

    @classmethod
    def preset(cls, name: str = HELD_OUT_PRESET) -> "HeldOutAttitude":
        """The attitude settings preset `name` (AttitudeSettings.preset), recorded as {"preset": name}."""
        from gnssatt.attitude.settings import AttitudeSettings

        return cls(AttitudeSettings.preset(name), {"preset": name})


def map_documents(grid: Grid2D, maps_m: dict) -> dict:
    """(first, second, signal) -> map dict (CONVENTIONS layout: bin centres, values in mm rounded to 0.1 um as
    published, None where empty) of flat maps in metres (NaN empty), for AttitudeSettings.calibration.pcv_maps."""
    out = {}
    for key, m in maps_m.items():
        v = np.round(np.asarray(m, float).reshape(grid.shape) * 1e3, 4)
        out[tuple(key)] = {"azimuth_deg": [float(x) for x in grid.x_centres_deg],
                           "elevation_deg": [float(y) for y in grid.y_centres_deg],
                           "values_mm": [[None if not np.isfinite(x) else float(x) for x in row] for row in v]}
    return out


def filter_errors(inputs, settings) -> dict:
    """Run the attitude filter (gnssatt.attitude.process) and return its errors against the set's reference over
    the fixed epochs: {"fixed_epochs", "epochs", "wrong_fix_epochs", "over_1deg_epochs" (gnssatt.attitude.wrong_fix),
    per angle {"bias_deg", "std_deg", "rms_deg", "predicted_sigma_deg"}, "cpu_s"}; {"skipped": reason} when the
    set has no reference or no fixed epoch."""
    from gnssatt.attitude.process import process

    c0 = time.process_time()
    sol = process(inputs, settings)
    ref = sol.summary.get("reference")
    if not ref or not ref.get("fixed_epochs_compared"):
        return {"skipped": "no fixed epoch compared with the reference attitude"}
    out = {"fixed_epochs": int(ref["fixed_epochs_compared"]), "epochs": int(ref["epochs_compared"]),
           "wrong_fix_epochs": int(ref.get("wrong_fix_epochs", 0)),
           "over_1deg_epochs": int(ref.get("over_1deg_epochs", 0))}
    for name in ANGLES:
        s = ref["fixed"].get(name)
        if s:
            out[name] = {"bias_deg": round(s["bias_deg"], 5), "std_deg": round(s["sigma_deg"], 5),
                         "rms_deg": round(s["rms_deg"], 5), "predicted_sigma_deg": round(s["predicted_sigma_deg"], 5)}
    out["cpu_s"] = round(time.process_time() - c0, 3)
    return out


def cut_percent(before: dict, after: dict) -> dict:
    """Per angle the cut of |bias| and of the std, % (100 (1 - after / before)); None where before is 0."""
    cut = {}
    for name in ANGLES:
        b, a = before.get(name), after.get(name)
        if not (b and a):
            continue
        b0, b1 = abs(b["bias_deg"]), abs(a["bias_deg"])
        d0, d1 = b["std_deg"], a["std_deg"]
        cut[name] = {"bias_cut_percent": round(100 * (1 - b1 / b0), 1) if b0 > 0 else None,
                     "std_cut_percent": round(100 * (1 - d1 / d0), 1) if d0 > 0 else None}
    return cut


def filter_comparison(inputs, settings, calibrated: dict, map_docs: dict) -> dict:
    """The held-out comparison: the filter with `settings` (an attitude job's settings) as given (a priori
    baselines of platform.json, no maps) and with `calibrated` ((first, second) -> body baseline, m) and
    `map_docs` (map_documents) replacing them. Same inputs, same settings otherwise.

    Note: the filter is sensitive to sub-micrometre input changes (a fix a few epochs earlier or later moves the
    statistics in the 4th decimal), hence the exact published rounding."""
    base = settings.override(calibrated_baselines={}, pcv_maps={})
    # the published values (baselines.json rounds to 0.1 um), so the figures are those of an attitude job
    cal = settings.override(calibrated_baselines={k: [round(float(x), 7) for x in v] for k, v in calibrated.items()},
                  pcv_maps=dict(map_docs))
    without = filter_errors(inputs, base)
    with_cal = filter_errors(inputs, cal)
    out = {"without_calibration": without, "with_calibration": with_cal}
    if "skipped" not in without and "skipped" not in with_cal:
        out["cut"] = cut_percent(without, with_cal)
    return out


def held_out_attitude(input_set, calibrated: dict, maps_m: dict, grid: Grid2D, held_out: HeldOutAttitude,
                      epoch_wise: dict | None) -> dict:
    """held_out_attitude.json: the attitude filter (the attitude job's processing with `held_out.settings`) on the
    held-out set without and with the calibration (filter_comparison), and the epoch-wise QUEST comparison
    (gnssatt.calibration.campaign.attitude_comparison, `epoch_wise`) as a secondary block.

    Args:
        input_set: the held-out set (id, name, files with name, kind, path; gnssatt.gnss.io.observation_set).
        calibrated: (first, second) -> (3,) body-frame baseline, m.
        maps_m: (first, second, signal) -> (n_bins,) map on `grid`, m (NaN on empty bins).
    """
    from gnssatt.attitude.process import InputProblem, load_inputs

    out = {"set": input_set.name or input_set.id,
           "method": f"attitude filter ({held_out.settings.mode} mode, the attitude job's processing) against the "
                     "set's reference attitude, over the fixed epochs: a priori baselines without maps vs calibrated "
                     "baselines + the calibration's maps (applied as with pcv_map_ids)",
           "attitude_config": held_out.config}
    try:
        inputs = load_inputs([(f.name, f.kind, f.path) for f in input_set.files])
        out.update(filter_comparison(inputs, held_out.settings, calibrated, map_documents(grid, maps_m)))
    except InputProblem as exc:
        out["skipped"] = f"{exc.title}: {exc.detail}"
    if epoch_wise is not None:
        out["epoch_wise"] = epoch_wise
    return out
