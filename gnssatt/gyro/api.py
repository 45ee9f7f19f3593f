"""GPS + gyro fusion in one call, without a server: `fuse(files, settings)` reads an observation set (RINEX
observation files of three or more antennas, navigation, platform.json, optionally the platform SP3) and a gyro
log (docs/formats/gyro_csv.md), runs seed 002's snapshot attitude with the exclusion bank and the quaternion EKF
with the delayed propagators (gnssatt.gyro.fusion), and returns a FusionResult whose write_products(out_dir)
writes the gyro-fusion job's text products (docs/gyro_fusion.md).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gnssatt.gyro.settings import FusionSettings

__all__ = ["fuse", "FusionResult", "FusionInputError", "split_files"]


class FusionInputError(ValueError):
    """Inputs that cannot give a fused attitude; carries title, detail, file, field for the job's problem."""

    def __init__(self, title: str, detail: str, file: str | None = None, field: str | None = None):
        super().__init__(detail)
        self.title, self.detail, self.file, self.field = title, detail, file, field


@dataclass
class FusionResult:
    """What a fusion run gives: settings, gps (gnssatt.gyro.gps_data.GpsData), gyro (GyroLog), run
    (gnssatt.gyro.fusion.FusionRun: the arrays), summary (summary.json)."""

    settings: FusionSettings
    gps: object
    gyro: object
    run: object
    summary: dict

    def products(self) -> dict:
        """Product name -> content (gnssatt.gyro.products.fusion_products)."""
        from gnssatt.gyro.products import fusion_products

        return fusion_products(self)

    def write_products(self, out_dir: str | Path) -> dict[str, Path]:
        """The job's text products in out_dir (plots and report.html are the job's); product name -> path."""
        from gnssatt.product_files import write_product_files

        return write_product_files(self.products(), out_dir)


def split_files(files: list) -> tuple[list, tuple | None]:
    """((name, kind, path) of the observation set, (name, path) of the gyro log or None). Files are paths or
    (name, kind, path) triples; a CSV whose header names the gyro columns is the gyro log (gnssatt.gyro.gyro_csv),
    whatever kind it was given."""
    from gnssatt.gnss.io.sniff import identify
    from gnssatt.gyro.gyro_csv import is_gyro_header

    out, gyro = [], None
    for f in files:
        name, kind, path = (f if isinstance(f, tuple) else (Path(f).name, None, Path(f)))
        with open(path, "rb") as fh:
            first = fh.readline(4096).decode("latin-1").strip()
        if kind == "gyro" or is_gyro_header(first):
            gyro = (name, Path(path))
            continue
        out.append((name, kind or identify(Path(path), name)[0], Path(path)))
    return out, gyro


def _summary(res_run, gps, gyro, settings) -> dict:
    t_ep = gps.time - gps.time[0]
    gaps = np.flatnonzero(np.diff(t_ep) > 1.5 * np.median(np.diff(t_ep))) if len(t_ep) > 2 else []
    outages = []
    t_g = gyro.time - gps.time[0]
    sig = np.sqrt(np.diagonal(res_run.P_att, axis1=1, axis2=2))
    for g in gaps:
        a, b = float(t_ep[g]), float(t_ep[g + 1])
        ia, ib = int(np.searchsorted(t_g, a + 1e-6)), int(np.searchsorted(t_g, b - 1e-6)) - 1
        outages.append({"start_gps": gps.time[g].iso(3), "end_gps": gps.time[g + 1].iso(3), "length_s": b - a,
                        "sigma_start_deg": np.degrees(sig[ia]).round(4).tolist(),
                        "sigma_end_deg": np.degrees(sig[ib]).round(4).tolist()})
    n_ep = len(t_ep)
    return {"platform": gps.platform.name, "antennas": gps.antennas, "gps_epochs": n_ep,
            "gps_epochs_with_attitude": int(np.isfinite(res_run.gps_q_body_from_ecef[:, 0]).sum()),
            "gyro_samples": len(t_g), "gyro_samples_with_attitude": int(res_run.has.sum()),
            "fused_fraction": float(res_run.fused.mean()), "gps_faults_detected": len(res_run.gps_events),
            "gyro_fault_events": len(res_run.gyro_events), "outages": outages,
            "kappa": settings.gps_fdi.kappa, "n_propagators": settings.gyro_fdi.n_propagators,
            "propagator_delays_s": [settings.gyro_fdi.delay_step_s * (j + 1)
                                    for j in range(settings.gyro_fdi.n_propagators)],
            "gyro_test_reference": settings.gyro_fdi.reference,
            "frames": "GCRF from ECEF by IAU 2006/2000A, zero EOP", "warnings": gps.warnings}


def _R_body_from_gyro(obs_files: list) -> np.ndarray:
    """platform.json's sensors.gyro.R_body_from_sensor (CONVENTIONS.md "Inputs: sensor logs"), else identity."""
    import json

    for name, kind, path in obs_files:
        if kind != "platform":
            continue
        doc = json.loads(Path(path).read_text())
        R = (doc.get("sensors") or {}).get("gyro", {}).get("R_body_from_sensor")
        if R is None:
            return np.eye(3)
        R = np.asarray(R, float)
        if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
            raise FusionInputError("Bad gyro alignment", f"{name}: sensors.gyro.R_body_from_sensor must be a 3x3 "
                                   "rotation matrix (orthonormal, det +1)", file=name, field="sensors.gyro")
        return R
    return np.eye(3)


def fuse(files: list, settings: FusionSettings | dict | None = None, progress=None) -> FusionResult:
    """FusionResult of an observation set plus a gyro log (paths or (name, kind, path) triples)."""
    from gnssatt.attitude.process import InputProblem
    from gnssatt.gyro.fusion import run_fusion
    from gnssatt.gyro.gps_data import load_gps
    from gnssatt.gyro.gyro_csv import read_gyro_csv

    s = settings if isinstance(settings, FusionSettings) else FusionSettings.from_dict(settings)
    obs_files, gyro_file = split_files(files)
    if gyro_file is None:
        raise FusionInputError("No gyro log", "gyro fusion needs a gyro CSV (time_gps, wx_rad_s, wy_rad_s, "
                               "wz_rad_s; docs/formats/gyro_csv.md)", field="gyro")
    gyro = read_gyro_csv(gyro_file[1].read_bytes(), gyro_file[0])
    if len(gyro.time) < 2:
        raise FusionInputError("Gyro log too short", f"{gyro_file[0]}: at least two samples", file=gyro_file[0])
    try:
        gps = load_gps(obs_files)
    except InputProblem as exc:
        raise FusionInputError(exc.title, exc.detail, exc.file, exc.field) from exc
    gyro.rate_rad_s = gyro.rate_rad_s @ _R_body_from_gyro(obs_files).T
    run = run_fusion(gps, gyro, s, progress)
    if not run.has.any():
        raise FusionInputError("No attitude", "no GPS epoch gave a snapshot attitude to start the filter (too few "
                               "satellites above the mask, or the gyro log does not overlap the observations)")
    return FusionResult(s, gps, gyro, run, _summary(run, gps, gyro, s))
