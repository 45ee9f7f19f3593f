"""Set-level checks and summary of one observation set (files already identified by gnssatt.gnss.io.sniff): at least
one RINEX observation file, at most one platform.json, the platform's antennas matched to observation files, the
time span and the files' warnings. Used by the upload path (app/store/sets.py) and the local runner (worker/local.py),
so a set has the same summary whichever way it came in. No I/O beyond reading the platform file."""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, NamedTuple

from gnssatt.gnss.io.platform import match_observation_files, parse_platform


#: a simulated set's answer key (gnssatt simulate writes truth/ beside obs/ and nav/): not an input of any job, so a
#: directory given as a set leaves its top-level truth/ out, as `make demo` leaves it out of the upload
ANSWER_KEY_FOLDER = "truth"


class IdentifiedFile(NamedTuple):
    name: str
    kind: str
    summary: dict
    path: Path


@dataclass(frozen=True)
class ObservationSet:
    """One observation set of local files: an id, a name and its identified files (the attributes and methods of
    the worker's InputSet, worker.context, which the calibration reads of a set)."""

    id: str
    name: str | None
    files: list[IdentifiedFile]

    def of_kind(self, kind: str) -> list[IdentifiedFile]:
        return [f for f in self.files if f.kind == kind]

    def platform(self) -> dict | None:
        """platform.json as parsed JSON, or None when the set has none."""
        files = self.of_kind("platform")
        return json.loads(Path(files[0].path).read_text()) if files else None

    @classmethod
    def of_paths(cls, paths: Iterable[str | Path], set_id: str, name: str | None = None) -> "ObservationSet":
        """The set of these files and directories, each file identified by its content (gnssatt.gnss.io.sniff);
        a directory stands for every file under it (named by its path inside the directory) except its top-level
        ANSWER_KEY_FOLDER, the simulator's answers. ParseError for a file of no known kind."""
        from gnssatt.gnss.io.sniff import identify

        files = []
        for path in map(Path, paths):
            members = sorted(p for p in path.rglob("*") if p.is_file()
                             and p.relative_to(path).parts[0] != ANSWER_KEY_FOLDER) if path.is_dir() else [path]
            for p in members:
                file_name = p.relative_to(path).as_posix() if path.is_dir() else p.name
                kind, summary = identify(p, file_name)
                files.append(IdentifiedFile(file_name, kind, summary, p))
        return cls(set_id, name, files)


class SetProblem(ValueError):
    """The set as a whole is unusable: `code` (a short slug), `title`, `detail`, and the file or field to blame."""

    def __init__(self, code: str, title: str, detail: str, *, file: str | None = None, field: str | None = None):
        super().__init__(f"{title}: {detail}")
        self.code, self.title, self.detail, self.file, self.field = code, title, detail, file, field


def set_summary(files: list[IdentifiedFile]) -> dict:
    """The set's summary (n_files, kinds, platform match, time_first/last, warnings); SetProblem if the set is
    unusable, gnssatt.gnss.io.errors.ParseError if its platform.json is."""
    obs = {f.name: f.summary.get("marker_name") for f in files if f.kind == "rinex_obs"}
    if not obs:
        raise SetProblem("no-observations", "No observation file",
                         "An observation set needs at least one RINEX observation file (one per antenna); "
                         f"the upload holds: {', '.join(sorted(f.name + ' (' + f.kind + ')' for f in files))}.",
                         field="files")
    platforms = [f for f in files if f.kind == "platform"]
    if len(platforms) > 1:
        raise SetProblem("several-platforms", "More than one platform.json",
                         f"An observation set describes one platform; found {[p.name for p in platforms]}.",
                         file=platforms[1].name)
    summary: dict = {"n_files": len(files), "kinds": sorted({f.kind for f in files}), "warnings": []}
    if platforms:
        pf = platforms[0]
        platform = parse_platform(Path(pf.path).read_bytes(), pf.name)
        matched = match_observation_files(platform, obs, pf.name)
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
    return summary
