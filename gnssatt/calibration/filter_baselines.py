"""Epoch-wise baselines of a calibration set from the attitude filter's kinematic mode (seed 000 sec. 3.1: "process
noise has also been used for the baseline vector during the calibration to achieve estimates in kinematic mode and
make them statistically independent").

The set's parsed observations, orbits and (when present) the platform's SP3 go to the attitude filter
(gnssatt.attitude.process, the attitude job's processing) in kinematic mode: baseline random walk of seed 000
sec. 4.1 (1 m per 1 s), no angular velocity, the integers resolved by the filter itself (MLAMBDA + length
validation against the body baselines given), with the calibration's signals, phase sigma and Table 2 masks and
without the platform-kind defaults (calibration is GPS L1/L2). The reference attitude plays no part here: it only
rotates the filter's ECEF baselines into the body frame afterwards (gnssatt.calibration.campaign), as in seed 000.
Without an SP3 of the platform the filter takes the platform's position and velocity from single point
positioning of the master antenna (its own fallback).

Result on the set's epochs (`FilterBaselines`): per baseline the ECEF baseline and its 3x3 covariance at the epochs
where the filter has the baseline fixed, NaN elsewhere.

Implements: seed 000 sec. 2 (the EKF, kinematic alternative) and sec. 3.1 (kinematic baselines for calibration).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FilterBaselines", "kinematic_settings", "filter_baselines"]


@dataclass
class FilterBaselines:
    """Per baseline (platform order) b_ecef_m (n_ep, 3) and cov_ecef_m2 (n_ep, 3, 3) on the set's epochs, NaN where
    the filter has no fixed solution; fixed (n_ep, n_bl); where the platform position came from; filter CPU s."""

    b_ecef_m: list
    cov_ecef_m2: list
    fixed: np.ndarray
    platform_source: str
    cpu_s: float


def kinematic_settings(options, baselines_body: dict, apriori_body: dict):
    """AttitudeSettings of the calibration's kinematic run: mode kinematic, GPS signals of `options`
    (ExtractOptions), its phase sigma and masks, no platform defaults; `baselines_body` replaces the platform's a
    priori baselines where it differs from `apriori_body` (the filter's length validation uses them)."""
    from gnssatt.attitude.settings import AttitudeSettings

    calibrated = {tuple(k): [float(x) for x in v] for k, v in baselines_body.items()
                  if not np.allclose(np.asarray(v, float), np.asarray(apriori_body[tuple(k)], float), atol=1e-9)}
    masks = {sig: float(options.cn0_mask_dbhz[sig]) for sig in options.signals if sig in options.cn0_mask_dbhz}
    return AttitudeSettings.preset(
        "seed000", mode="kinematic", platform_defaults=False, signals=list(options.signals),
        table1={"sigma_phase_m": float(options.sigma_phase_m)},
        table2={"elevation_mask_antenna_deg": float(options.elevation_mask_antenna_deg), "cn0_mask_dbhz": masks},
        calibrated_baselines=calibrated)


def _tags_ms(t) -> np.ndarray:
    return np.asarray(t.s).astype(np.int64) * 1000 + np.round(np.asarray(t.frac) * 1000.0).astype(np.int64)


def filter_baselines(data, baselines_body: dict, options) -> FilterBaselines:
    """FilterBaselines of a loaded set (gnssatt.calibration.extract.SetData, which keeps the parsed files in
    `attitude_inputs`). Raises ValueError with the filter's message when the set cannot be processed."""
    import time

    from gnssatt.attitude.process import InputProblem, process

    plat = data.platform
    apriori = {tuple(bl): plat.baseline_body_m(*bl) for bl in plat.baselines}
    settings = kinematic_settings(options, baselines_body, apriori)
    c0 = time.process_time()
    try:
        sol = process(data.attitude_inputs, settings)
    except InputProblem as exc:
        raise ValueError(f"{exc.title}: {exc.detail}" + (f" ({exc.file})" if exc.file else "")) from exc
    fr = sol.fr
    n_ep = len(data.epochs)
    rows = np.searchsorted(_tags_ms(data.epochs), _tags_ms(sol.pobs.time))
    rows = np.clip(rows, 0, n_ep - 1)
    hit = _tags_ms(data.epochs)[rows] == _tags_ms(sol.pobs.time)
    index = {tuple(bl): j for j, bl in enumerate(sol.baselines)}
    bs, covs = [], []
    fixed = np.zeros((n_ep, len(plat.baselines)), bool)
    for bi, bl in enumerate(plat.baselines):
        b = np.full((n_ep, 3), np.nan)
        cov = np.full((n_ep, 3, 3), np.nan)
        j = index.get(tuple(bl))
        if j is not None:
            ok = hit & fr.ok[:, j] & fr.fixed[:, j]
            b[rows[ok]] = fr.b_ecef_m[ok, j]
            cov[rows[ok]] = fr.P_b_m2[ok][:, 3 * j:3 * j + 3, 3 * j:3 * j + 3]
            fixed[rows[ok], bi] = True
        bs.append(b)
        covs.append(cov)
    return FilterBaselines(bs, covs, fixed, sol.geom.platform_source, time.process_time() - c0)
