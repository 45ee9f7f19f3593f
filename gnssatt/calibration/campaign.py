"""A calibration campaign as two fan-out passes over the sets and two reductions (seed 000 sec. 3).

Pass 1, one task per set (`set_statistics`): fix and solve the set with the a priori baselines; epoch-wise
baselines in the body frame reduced to batch sums (gnssatt.calibration.baselines) and, per baseline and signal,
the additive statistics of the PCV iteration (gnssatt.calibration.pcv.MapNormal).
Reduction 1 (`reduce_baselines`, `reduce_maps`): weighted mean baselines (Table 3), then the maps iterated with
the calibrated baselines until the map changes by < tolerance RMS or after max_iterations.
Pass 2, one task per set (`set_final`): residual statistics before (a priori, no map) and after (calibrated +
maps); per-bin counts and cluster-robust sigmas of the final maps; on the held-out set, epoch-wise attitude
(QUEST over the baselines) against the reference with and without the calibration.
Reduction 2 (`finish_maps`, `combine_residual_stats`).

Everything is summed in set order, so the result does not depend on which worker finished first.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnssatt.calibration.baselines import (BatchSums, BaselineRow, batch_sums, body_from_ecef, combine,
                                          gate_epochs)
from gnssatt.calibration.binning import BinSums, Grid2D, finalize
from gnssatt.calibration.decomposition import apply_split, bin_los_body, observed_sky, offset_split, split_weights
from gnssatt.calibration.smoothing import smooth_map
from gnssatt.calibration.extract import ExtractOptions, SetData, extract
from gnssatt.calibration.pcv import (MapNormal, iterate_map, map_lookup, map_normal, residual_bin_sums,
                                    residuals_m, solve_map)
from gnssatt.gnss.rotations import quat_conjugate, quat_multiply, quat_to_rotvec, quest

WINDOW_S = 60.0


@dataclass
class CampaignOptions:
    """What a campaign is run with; the defaults are the calibration job's (seed 000 Tables 1-2 extraction,
    2.5 deg x 1 deg bins over elevations 0-90 deg)."""

    extract: ExtractOptions = field(default_factory=ExtractOptions)
    grid: Grid2D = field(default_factory=Grid2D.regular)
    min_count: int = 10
    tolerance_mm: float = 0.1
    max_iterations: int = 10
    batch_s: float = 300.0
    max_deviation_m: float = 0.05
    min_reference_coverage: float = 0.9
    smoothing_order: int = 8   # Zernike order of the map fit (gnssatt.calibration.smoothing); 0 = bin means


def _apriori(platform) -> dict:
    return {tuple(bl): platform.baseline_body_m(*bl) for bl in platform.baselines}


@dataclass
class SetStats:
    label: str
    n_epochs: int
    coverage: float
    batches: dict  # (first, second) -> BatchSums
    normals: dict  # (first, second, signal) -> MapNormal
    n_epochs_used: dict  # (first, second) -> int
    position_source: str = ""  # where the platform position came from (its SP3 or single point positioning)


def _usable_epochs(ex, bi: int, apriori_body: np.ndarray, max_deviation_m: float):
    fix = ex.fixes[bi]
    b_body, cov_body = body_from_ecef(fix.b_ecef_m, fix.cov_ecef_m2, ex.reference.R_body_from_ecef)
    ok = fix.ok & ex.reference.ok & gate_epochs(b_body, apriori_body, max_deviation_m)
    return b_body, cov_body, ok


def set_statistics(data: SetData, options: CampaignOptions) -> SetStats:
    """Pass 1 of one set (see the module docstring)."""
    apriori = _apriori(data.platform)
    ex = extract(data, apriori, options.extract)
    t_s = ex.epochs - ex.epochs[0]
    batches, normals, used = {}, {}, {}
    for bi, bl in enumerate(ex.baselines):
        bl = tuple(bl)
        b_body, cov_body, ok = _usable_epochs(ex, bi, apriori[bl], options.max_deviation_m)
        sigma = np.sqrt(np.einsum("eii->ei", np.where(ok[:, None, None], cov_body, np.nan)))
        batches[bl] = batch_sums(t_s[ok], b_body[ok], sigma[ok], options.batch_s)
        used[bl] = int(ok.sum())
        good_epochs = np.flatnonzero(ok)
        for sig in data.signals:
            fp = ex.fixed_phases[(bi, sig)]
            fp = fp.subset(np.isin(fp.epoch, good_epochs))
            normals[bl + (sig,)] = map_normal(options.grid, fp)
    return SetStats(data.label, len(ex.epochs), data.reference.coverage, batches, normals, used,
                    data.position_source)


def reduce_baselines(stats: list[SetStats], platform) -> list[BaselineRow]:
    """Table 3 rows: weighted mean of every baseline over all sets (in set order)."""
    apriori = _apriori(platform)
    rows = []
    for bl in platform.baselines:
        bl = tuple(bl)
        parts = [s.batches[bl] for s in stats]
        est = combine(BatchSums.concatenate(parts))
        rows.append(BaselineRow(bl[0], bl[1], apriori[bl], est, n_sets=sum(1 for p in parts if len(p.n_epochs))))
    return rows


@dataclass
class MapResult:
    first: str
    second: str
    signal: str
    map_m: np.ndarray  # (n_bins,) NaN on empty bins
    changes_mm: list
    converged: bool
    count_pass1: np.ndarray
    baseline_m: np.ndarray | None = None  # (3,) the baseline this map goes with (after the split, if made)
    shift_m: np.ndarray | None = None     # (3,) baseline change made by the split (decomposition.py)
    observed: dict | None = None          # the part of the split's sky this map covers (decomposition.observed_sky)


def reduce_maps(stats: list[SetStats], calibrated: dict, signals: list, options: CampaignOptions,
                boresights: dict | None = None) -> list[MapResult]:
    """Iterated maps per baseline and signal with the calibrated baselines ((first, second) -> (3,) m).

    With `boresights` (antenna id -> body boresight), the baseline/map split of CONVENTIONS.md is then made
    explicit (gnssatt.calibration.decomposition: solid-angle weights over the bins with a value): every MapResult of a baseline carries the split
    baseline (`baseline_m`, use it with these maps) and the change (`shift_m`); without, baseline_m is the input.
    """
    out = []
    n = options.grid.n_bins
    az_c, el_c = np.meshgrid(options.grid.x_centres_deg, options.grid.y_centres_deg)
    for bl, b in calibrated.items():
        g = bin_los_body(options.grid, boresights[bl[0]]) if boresights is not None else None
        mine = []
        for sig in signals:
            normal = MapNormal.total([s.normals[tuple(bl) + (sig,)] for s in stats], n)
            active = normal.count >= max(int(options.min_count), 1)
            # exact fixed point (CG), then the seed 000 iteration from it: its steps show what is left
            it = iterate_map(normal, b, active, tolerance_mm=options.tolerance_mm,
                             max_iterations=options.max_iterations, initial_m=solve_map(normal, b, active))
            if options.smoothing_order > 0:
                it.map_m = smooth_map(it.map_m, normal.count.astype(float), az_c.ravel(), el_c.ravel(),
                                      options.smoothing_order, g)
            mine.append(MapResult(bl[0], bl[1], sig, it.map_m, it.changes_mm, it.converged, normal.count,
                                  np.asarray(b, dtype=np.float64), np.zeros(3)))
        if g is not None and mine:
            db, a = offset_split([r.map_m for r in mine], [split_weights(options.grid, r.map_m) for r in mine], g)
            b_new, maps_new = apply_split(b, [r.map_m for r in mine], g, db, a)
            for r, m in zip(mine, maps_new):
                r.map_m, r.baseline_m, r.shift_m = m, b_new, db
                r.observed = observed_sky(options.grid, m)
        out += mine
    return out


def split_baselines(rows: list[BaselineRow], results: list[MapResult]) -> dict:
    """Calibrated baselines ((first, second) -> (3,) m) in the maps' split; the rows' means updated in place
    (their sigmas stay the batch-means sigmas of the epoch-wise baselines)."""
    out = {}
    for r in rows:
        mine = [m for m in results if (m.first, m.second) == (r.first, r.second)]
        mr = mine[0] if mine else None
        if mr is not None and mr.baseline_m is not None:
            r.estimate.mean_m = np.asarray(mr.baseline_m, dtype=np.float64)
            if mr.observed is not None:
                r.split = {"definition": "CONVENTIONS.md: the maps have no least-squares c0_f + c . e part, solid-"
                                         "angle weighted over the antenna-frame elevations -10 to 90 deg; bins "
                                         "without a value extended by that fitted model",
                           "observed": {m.signal: m.observed for m in mine}}
        out[(r.first, r.second)] = r.estimate.mean_m
    return out


@dataclass
class ResidualSums:
    """Additive residual statistics: n, sum (m), sum of squares (m^2)."""

    n: int = 0
    s: float = 0.0
    s2: float = 0.0

    @classmethod
    def of(cls, r: np.ndarray) -> "ResidualSums":
        r = np.asarray(r, dtype=np.float64)
        r = r[np.isfinite(r)]
        return cls(int(r.size), float(r.sum()), float((r * r).sum()))

    def __add__(self, o: "ResidualSums") -> "ResidualSums":
        return ResidualSums(self.n + o.n, self.s + o.s, self.s2 + o.s2)

    def to_dict(self) -> dict:
        if self.n == 0:
            return {"n": 0, "mean_mm": None, "std_mm": None, "rms_mm": None}
        mean = self.s / self.n
        return {"n": self.n, "mean_mm": round(mean * 1e3, 4),
                "std_mm": round(float(np.sqrt(max(self.s2 / self.n - mean * mean, 0.0))) * 1e3, 4),
                "rms_mm": round(float(np.sqrt(self.s2 / self.n)) * 1e3, 4)}


@dataclass
class SetFinal:
    label: str
    before: dict  # (first, second, signal) -> ResidualSums
    after: dict
    bins: dict  # (first, second, signal) -> BinSums (map + residual, mm)
    attitude: dict | None = None
    held_out: bool = False


def _maps_as_corrections(grid: Grid2D, maps: dict) -> dict:
    """(first, second, signal) -> callable(az_deg, el_deg) -> mm, of flat maps in metres."""
    return {key: (lambda az, el, m=m: map_lookup(grid, m * 1e3, az, el)) for key, m in maps.items()}


def set_final(data: SetData, calibrated: dict, maps: dict, options: CampaignOptions, held_out: bool) -> SetFinal:
    """Pass 2 of one set: residuals before/after, final map bin sums (not for the held-out set), and for the
    held-out set the attitude comparison.

    Args:
        calibrated: (first, second) -> (3,) body-frame baseline, m.
        maps: (first, second, signal) -> (n_bins,) map, m (NaN on empty bins).
    """
    apriori = _apriori(data.platform)
    ex = extract(data, apriori, options.extract)
    before, after, bins = {}, {}, {}
    for bi, bl in enumerate(ex.baselines):
        bl = tuple(bl)
        _, _, ok = _usable_epochs(ex, bi, apriori[bl], options.max_deviation_m)
        good = np.flatnonzero(ok)
        for sig in data.signals:
            key = bl + (sig,)
            fp = ex.fixed_phases[(bi, sig)]
            fp = fp.subset(np.isin(fp.epoch, good))
            before[key] = ResidualSums.of(residuals_m(fp, apriori[bl], None))
            m = maps.get(key)
            applied = None if m is None else map_lookup(options.grid, m, fp.az_deg, fp.el_deg)
            after[key] = ResidualSums.of(residuals_m(fp, calibrated[bl], applied))
            if not held_out:
                bins[key] = residual_bin_sums(options.grid, fp, calibrated[bl], m)
    att = attitude_comparison(data, apriori, calibrated, maps, options) if held_out else None
    return SetFinal(data.label, before, after, bins, att, held_out)


def _quest_series(ex, body: dict) -> tuple[np.ndarray, np.ndarray]:
    """(q_body_from_ecef (n_ep, 4), ok) by QUEST over the epoch-wise baselines, weights |b|^2 (by length)."""
    n_ep = len(ex.epochs)
    v_body = np.stack([np.broadcast_to(body[tuple(bl)], (n_ep, 3)) for bl in ex.baselines], axis=1)
    v_ref = np.stack([f.b_ecef_m for f in ex.fixes], axis=1)
    lengths = np.linalg.norm(v_body, axis=-1)
    ok = np.all([f.ok for f in ex.fixes], axis=0) & ex.reference.ok
    q = np.full((n_ep, 4), np.nan)
    if np.any(ok) and len(ex.baselines) >= 2:
        q[ok], _ = quest(v_body[ok], v_ref[ok], weights=lengths[ok] ** 2)
    ok &= np.isfinite(q).all(-1)
    return q, ok


def attitude_errors_deg(q_est: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
    """(n, 3) small-angle attitude errors about body x, y, z (deg): the rotation vector of R(q_est) R(q_ref)^T.
    For an Earth-pointing platform these are the roll, pitch and yaw errors."""
    d = quat_multiply(q_est, quat_conjugate(q_ref))
    return np.degrees(quat_to_rotvec(d))


def _error_summary(err: np.ndarray) -> dict:
    names = ("x_roll", "y_pitch", "z_yaw")
    out = {"n_epochs": int(len(err))}
    for k, nm in enumerate(names):
        e = err[:, k]
        out[nm] = {"bias_deg": round(float(np.mean(e)), 5), "std_deg": round(float(np.std(e)), 5)} if len(e) else None
    out["angle_rms_deg"] = round(float(np.sqrt(np.mean(np.sum(err ** 2, axis=1)))), 5) if len(err) else None
    return out


def attitude_comparison(data: SetData, apriori: dict, calibrated: dict, maps: dict, options: CampaignOptions) -> dict:
    """Epoch-wise attitude of the set against its reference, without (a priori baselines, no maps) and with the
    calibration (calibrated baselines, maps subtracted from the phases); bias and std per body axis, and the cut.
    Needs two or more baselines; otherwise {'skipped': reason}."""
    if len(data.platform.baselines) < 2:
        return {"skipped": "one baseline gives no full attitude"}
    ex0 = extract(data, apriori, options.extract)
    ex1 = extract(data, calibrated, options.extract, corrections=_maps_as_corrections(options.grid, maps))
    q0, ok0 = _quest_series(ex0, apriori)
    q1, ok1 = _quest_series(ex1, calibrated)
    ok = ok0 & ok1
    qr = data.reference.q_body_from_ecef
    e0 = attitude_errors_deg(q0[ok], qr[ok])
    e1 = attitude_errors_deg(q1[ok], qr[ok])
    s0, s1 = _error_summary(e0), _error_summary(e1)
    # 60 s means: white noise averages down, what the calibration removes (offsets, PCV along slow lines of
    # sight) stays; the seed 000 filter in dynamic mode smooths over a similar span
    t_s = (ex0.epochs - ex0.epochs[0])[ok]
    win = np.floor(t_s / WINDOW_S).astype(np.int64)
    if len(win):
        uniq, inv = np.unique(win, return_inverse=True)
        cnt = np.bincount(inv)
        full = cnt >= 0.5 * WINDOW_S / max(float(np.median(np.diff(t_s))) if len(t_s) > 1 else 1.0, 1e-9)
        m0 = np.stack([np.bincount(inv, weights=e0[:, k]) / cnt for k in range(3)], -1)[full]
        m1 = np.stack([np.bincount(inv, weights=e1[:, k]) / cnt for k in range(3)], -1)[full]
        s0["window_60s"], s1["window_60s"] = _error_summary(m0), _error_summary(m1)
    cut = {}
    for nm in ("x_roll", "y_pitch", "z_yaw"):
        if s0[nm] and s1[nm]:
            b0, b1 = abs(s0[nm]["bias_deg"]), abs(s1[nm]["bias_deg"])
            d0, d1 = s0[nm]["std_deg"], s1[nm]["std_deg"]
            cut[nm] = {"bias_cut_percent": round(100 * (1 - b1 / b0), 1) if b0 > 0 else None,
                       "std_cut_percent": round(100 * (1 - d1 / d0), 1) if d0 > 0 else None}
            w0, w1 = s0.get("window_60s", {}).get(nm), s1.get("window_60s", {}).get(nm)
            if w0 and w1 and w0["std_deg"] > 0:
                cut[nm]["std_60s_cut_percent"] = round(100 * (1 - w1["std_deg"] / w0["std_deg"]), 1)
    return {"set": data.label, "method": "epoch-wise kinematic baselines + QUEST (weights by baseline length)",
            "without_calibration": s0, "with_calibration": s1, "cut": cut}


def finish_maps(results: list[MapResult], finals: list[SetFinal], options: CampaignOptions):
    """(values_mm, count, sigma_mm) per (first, second, signal), each (n_y, n_x): values from the iteration,
    count and sigma from the final pass (bins without enough samples stay empty)."""
    out = {}
    n = options.grid.n_bins
    for r in results:
        key = (r.first, r.second, r.signal)
        sums = BinSums.total([f.bins[key] for f in finals if key in f.bins], n)
        fin = finalize(options.grid, sums, options.min_count)
        values = (r.map_m * 1e3).reshape(options.grid.shape)
        valid = np.isfinite(values) & np.isfinite(fin.value)
        out[key] = (np.where(valid, values, np.nan), fin.count, np.where(valid, fin.sigma, np.nan),
                    np.where(valid, fin.value - values, np.nan))
    return out


def combine_residual_stats(finals: list[SetFinal], include_held_out: bool = False) -> dict:
    """{'before': {key: stats}, 'after': {...}} over the calibration sets (or the held-out set)."""
    out = {"before": {}, "after": {}}
    for which in ("before", "after"):
        acc: dict = {}
        for f in finals:
            if f.held_out != include_held_out:
                continue
            for key, rs in getattr(f, which).items():
                acc[key] = acc.get(key, ResidualSums()) + rs
        out[which] = {f"{k[0]}>{k[1]} {k[2]}": v.to_dict() for k, v in acc.items()}
    return out


__all__ = ["CampaignOptions", "SetStats", "set_statistics", "reduce_baselines", "MapResult", "reduce_maps",
           "split_baselines", "ResidualSums", "SetFinal", "set_final", "attitude_comparison", "attitude_errors_deg", "finish_maps",
           "combine_residual_stats"]
