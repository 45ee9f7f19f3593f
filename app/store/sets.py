"""Validate a staged upload as an observation set, then keep it: blobs first, rows in one transaction."""
from __future__ import annotations

from dataclasses import dataclass

from sqlalchemy.orm import Session

from app.problems import ProblemError
from app.store.uploads import StagedUpload
from core.blobs import BlobStore
from core.models import ObservationSet, SetFile
from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.platform import match_observation_files, parse_platform
from gnssatt.gnss.io.sniff import identify


@dataclass
class ValidatedFile:
    name: str
    kind: str
    summary: dict
    sha256: str
    size_bytes: int
    path: object


def _parse_problem(exc: ParseError) -> ProblemError:
    return ProblemError(422, "parse-error", f"{exc.path} could not be read", str(exc),
                        file=exc.path, line=exc.line_no, expected=exc.expected)


def validate_staged(staged: StagedUpload) -> tuple[list[ValidatedFile], dict]:
    """Identify and check every file, and the set as a whole; 422 naming file (and line) otherwise."""
    files: list[ValidatedFile] = []
    for f in staged.files:
        try:
            kind, summary = identify(f.path, f.name)
        except ParseError as exc:
            raise _parse_problem(exc) from exc
        except (OSError, EOFError, ValueError) as exc:  # damaged compression, odd encodings
            raise ProblemError(422, "unreadable-file", f"{f.name} could not be read", f"{f.name}: {exc}",
                               file=f.name) from exc
        files.append(ValidatedFile(f.name, kind, summary, f.sha256, f.size_bytes, f.path))
    obs = {f.name: f.summary.get("marker_name") for f in files if f.kind == "rinex_obs"}
    if not obs:
        raise ProblemError(422, "no-observations", "No observation file",
                           "An observation set needs at least one RINEX observation file (one per antenna); "
                           f"the upload holds: {', '.join(sorted(f.name + ' (' + f.kind + ')' for f in files))}.",
                           field="files")
    platforms = [f for f in files if f.kind == "platform"]
    if len(platforms) > 1:
        raise ProblemError(422, "several-platforms", "More than one platform.json",
                           f"An observation set describes one platform; found {[p.name for p in platforms]}.",
                           file=platforms[1].name)
    summary: dict = {"n_files": len(files), "kinds": sorted({f.kind for f in files}), "warnings": []}
    if platforms:
        pf = platforms[0]
        try:
            platform = parse_platform(pf.path.read_bytes(), pf.name)
            matched = match_observation_files(platform, obs, pf.name)
        except ParseError as exc:
            raise _parse_problem(exc) from exc
        summary.update(platform=platform.name, platform_kind=platform.kind, antennas=matched,
                       baselines=[f"{a}>{b}" for a, b in platform.baselines])
        unused = sorted(set(obs) - set(matched.values()))
        if unused:
            summary["warnings"].append({"code": "unused-observation-file",
                                        "message": f"observation files not matched to any antenna: {unused}"})
    else:
        summary["warnings"].append({"code": "no-platform", "message": "no platform.json: the set can be inspected, "
                                    "but attitude and calibration jobs need one"})
    obs_summaries = [f.summary for f in files if f.kind == "rinex_obs"]
    summary["time_first"] = min(s["time_first"] for s in obs_summaries)
    summary["time_last"] = max(s["time_last"] for s in obs_summaries)
    for f in files:
        for w in f.summary.get("warnings", []) or []:
            summary["warnings"].append({"file": f.name, **w})
    return files, summary


def store_set(session: Session, blobs: BlobStore, team_id: str, name: str | None,
              files: list[ValidatedFile], summary: dict) -> ObservationSet:
    """Move the staged files into the blob store, then insert the set and its files in one transaction."""
    for f in files:
        blobs.put_file(f.path, f.sha256)
    obs_set = ObservationSet(team_id=team_id, name=name, platform_name=summary.get("platform"),
                             total_bytes=sum(f.size_bytes for f in files), summary=summary)
    obs_set.files = [SetFile(name=f.name, kind=f.kind, sha256=f.sha256, size_bytes=f.size_bytes,
                             summary=f.summary) for f in files]
    session.add(obs_set)
    session.commit()
    session.refresh(obs_set)
    return obs_set
