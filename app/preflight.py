"""Refuse early what cannot run: before POST /v1/jobs queues a job, the stored summaries of its observation sets
(made at upload by gnssatt/gnss/io/sniff.py, no file is read again) are checked against what the job type needs.
A problem answers 422 naming the missing piece (and the set, file and field), and nothing is queued.

Checks per job type (PREFLIGHT): a platform.json; navigation data (a RINEX navigation file, or an SP3 of GNSS
satellites); every antenna of platform.json matched to an observation file that is in the set; at least two
antennas (one baseline); and a common time span of the observation files of the baselines' antennas."""
from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime

from app.problems import ProblemError


@dataclass(frozen=True)
class Needs:
    """What a job type needs in each of its observation sets."""
    platform: bool = True
    navigation: bool = True
    min_antennas: int = 2
    common_epochs: bool = True


#: job type -> its needs; types not named here (inspect, simulate, selftest, ...) are not checked
PREFLIGHT: dict[str, Needs] = {"attitude": Needs(), "calibration": Needs()}
GNSS_SYSTEMS = set("GRECJI")


def _problem(code: str, title: str, detail: str, **where) -> ProblemError:
    return ProblemError(422, code, title, detail, **where)


def _t(text: str) -> datetime:
    return datetime.fromisoformat(str(text).replace("Z", ""))


def check_set(job_type: str, obs_set) -> None:
    """Raise ProblemError(422) naming the first piece `obs_set` lacks for `job_type`; nothing when it has all."""
    needs = PREFLIGHT.get(job_type)
    if needs is None:
        return
    label = f"observation set {obs_set.name or obs_set.id!r} ({obs_set.id})"
    files = list(obs_set.files)
    by_kind: dict[str, list] = {}
    for f in files:
        by_kind.setdefault(f.kind, []).append(f)
    present = ", ".join(sorted(f"{f.name} ({f.kind})" for f in files)) or "no files"
    if needs.platform and not by_kind.get("platform"):
        raise _problem("missing-platform", "No platform.json in the set",
                       f"A {job_type} job needs a platform.json (antenna positions in the body frame, CONVENTIONS.md "
                       f"'Input: platform.json'; /ui/new has a template and a form that writes one); {label} holds: "
                       f"{present}.", field="observation_set_ids")
    if needs.navigation:
        sp3_gnss = [f for f in by_kind.get("sp3", []) if GNSS_SYSTEMS & set((f.summary or {}).get("systems") or [])]
        if not by_kind.get("rinex_nav") and not sp3_gnss:
            raise _problem("missing-navigation", "No navigation data in the set",
                           f"A {job_type} job needs the GNSS orbits: a RINEX navigation file (broadcast ephemerides) "
                           f"or an SP3 of the GNSS satellites; {label} holds: {present}.",
                           field="observation_set_ids")
    summary = obs_set.summary or {}
    if not needs.platform:
        return
    platform_file = by_kind["platform"][0]
    antennas = list((platform_file.summary or {}).get("antennas") or [])
    if len(antennas) < needs.min_antennas:
        raise _problem("too-few-antennas", "Too few antennas",
                       f"A {job_type} job needs at least {needs.min_antennas} antennas (one baseline); "
                       f"{platform_file.name} of {label} names {len(antennas)}: {antennas}.",
                       file=platform_file.name, field="antennas")
    matched = summary.get("antennas") or {}
    obs_by_name = {f.name: f for f in by_kind.get("rinex_obs", [])}
    for ant in antennas:
        fname = matched.get(ant)
        if fname is None or fname not in obs_by_name:
            raise _problem("missing-observation-file", f"No observation file for antenna {ant}",
                           f"{platform_file.name} names antenna {ant!r}, whose observation file "
                           f"{fname!r} is not in {label} (observation files: {sorted(obs_by_name)}).",
                           file=platform_file.name, field=f"antennas.{ant}")
    if needs.common_epochs:
        baselines = [b.split(">") for b in (platform_file.summary or {}).get("baselines") or []]
        used = sorted({a for bl in baselines for a in bl}) or antennas
        spans = {a: obs_by_name[matched[a]].summary for a in used}
        try:
            start = max(_t(s["time_first"]) for s in spans.values())
            stop = min(_t(s["time_last"]) for s in spans.values())
        except (KeyError, TypeError, ValueError):
            return
        if start > stop:
            detail = "; ".join(f"{a} ({matched[a]}): {s['time_first']} to {s['time_last']}" for a, s in spans.items())
            raise _problem("no-common-epochs", "No common epochs",
                           f"The observation files of the antennas of {label} do not overlap in time, so no single "
                           f"difference can be formed: {detail}.", field="observation_set_ids")


def check_sets(job_type: str, obs_sets) -> None:
    """check_set for each set, in the order given."""
    for s in obs_sets:
        check_set(job_type, s)
