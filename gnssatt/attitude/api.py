"""The attitude capability in two calls, without a server: `solve(files, ...)` runs the attitude job's science on
files (the same `load_inputs` + `process` the worker's attitude pipeline calls) and `write_products(sol, out_dir)`
writes the job's products (attitude.csv, baselines.csv, residuals.csv, events.csv, summary.json and the AEM/NMEA
exports of gnssatt.attitude.products) into a folder.

Files are identified by content, as the service does (gnssatt.gnss.io.sniff.identify), so their names and order do
not matter. See docs/library.md for a runnable example.
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable, Iterable

from gnssatt.attitude.process import AttitudeSolution, load_inputs, process
from gnssatt.attitude.products import write_products
from gnssatt.attitude.settings import AttitudeSettings

__all__ = ["solve", "write_products", "identify_files"]

#: the kinds the attitude job reads (others, e.g. ANTEX or RINEX clock, are ignored as the service does)
ATTITUDE_KINDS = ("rinex_obs", "rinex_nav", "sp3", "platform", "reference_attitude")


def identify_files(paths: Iterable[str | Path]) -> list[tuple[str, str, Path]]:
    """(name, kind, path) of each file, kind from its content (gnssatt.gnss.io.sniff.identify); the name is the
    file name, made unique with its parent folder when two files share one (obs/GPS-0.rnx vs other/GPS-0.rnx)."""
    from gnssatt.gnss.io.sniff import identify

    out, seen = [], set()
    for p in map(Path, paths):
        name = p.name if p.name not in seen else f"{p.parent.name}/{p.name}"
        seen.add(name)
        kind, _ = identify(p, name)
        out.append((name, kind, p))
    return out


def solve(files: Iterable[str | Path], platform: str | Path | None = None, nav: str | Path | None = None,
          settings: AttitudeSettings | str | None = None,
          progress: Callable[[float, str | None], None] | None = None) -> AttitudeSolution:
    """Attitude of one observation set: the attitude job's science on local files.

    Args:
        files: paths of the set (RINEX observation files, one per antenna, and optionally the navigation file,
            SP3, platform.json, reference attitude); kinds are found from the content.
        platform: platform.json, when not among `files`.
        nav: RINEX navigation (or GNSS SP3) file, when not among `files`.
        settings: an AttitudeSettings, a preset name (AttitudeSettings.preset) or None for the attitude job's
            default, the "seed000" preset.
        progress: optional callable(fraction in [0, 1], stage or None).

    Returns the AttitudeSolution of gnssatt.attitude.process: `time` / `q_body_from_ecef` / `q_body_from_gcrf` /
    `euler_deg` / `sigma_euler_deg` / `att_fixed` (attitude rows), `baseline_table`, `fr.events`, `summary`.
    Raises gnssatt.attitude.process.InputProblem when the set cannot give an attitude.
    """
    paths = [Path(p) for p in files] + [Path(p) for p in (platform, nav) if p is not None]
    triples = [t for t in identify_files(paths) if t[1] in ATTITUDE_KINDS]
    if settings is None or isinstance(settings, str):
        settings = AttitudeSettings.preset(settings or "seed000")
    return process(load_inputs(triples), settings, progress)
