"""Refuse early what cannot run: before POST /v1/jobs queues a job, the stored summaries of its observation sets
(made at upload by gnssatt/gnss/io/sniff.py, no file is read again) and its config are checked against what the
job type needs. A problem answers 422 naming the missing piece (and the set, file and field), and nothing is queued.

What each job type needs (needs_of): a platform.json; navigation data (a RINEX navigation file, or an SP3 of GNSS
satellites); every antenna of platform.json matched to an observation file that is in the set; enough antennas; a
common time span of the observation files of the baselines' antennas; the sensor logs a method reads (gyro,
accelerometer, magnetometer) overlapping the observations; a velocity (velocity.csv, or navigation data for a
Doppler velocity). Types with inputs in the config (plan, ttff) are checked in check_plan / check_ttff."""
from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime

from app.problems import ProblemError

GNSS_SYSTEMS = set("GRECJI")
#: sensor log kind -> how the refusal names it
LOGS = {"gyro": "a gyro log: a CSV with time_gps, wx_rad_s, wy_rad_s, wz_rad_s (docs/formats/gyro_csv.md)",
        "accelerometer": "an accelerometer log: accelerometer.csv with time_gps, ax_m_s2, ay_m_s2, az_m_s2 "
                         "(docs/formats/inertial_csv.md)",
        "magnetometer": "a magnetometer log: magnetometer.csv with time_gps, bx_nT, by_nT, bz_nT "
                        "(docs/formats/inertial_csv.md)"}


@dataclass(frozen=True)
class Needs:
    """What a job type needs in each of its observation sets; `what` names the job in messages."""
    what: str
    platform: bool = True
    navigation: str | None = "gnss"      # "gnss": RINEX navigation or an SP3 of GNSS satellites; "rinex_nav"
    min_antennas: int = 2
    antenna_files: bool = True           # every antenna of platform.json has its observation file in the set
    common_epochs: bool = True
    logs: tuple[str, ...] = ()
    velocity: bool = False               # velocity.csv, or a navigation file for a Doppler velocity


def needs_of(job_type: str, config) -> Needs | None:
    """The Needs of a job type (with its validated config), None for types whose sets are not checked here."""
    what = f"A {job_type} job"
    if job_type in ("attitude", "calibration", "ttff"):
        return Needs(what)
    if job_type == "gyro-fusion":       # a snapshot attitude needs two baselines (seed 002 sec. 2.1)
        return Needs(what, min_antennas=3, logs=("gyro",))
    if job_type in ("satellite-yaw", "satellite-baseline"):
        return Needs(what, platform=False)
    if job_type == "single-antenna-attitude":
        method = getattr(config, "method", None)
        what = f"A {job_type} job (method {method})"
        if method == "acceleration-magnetometer":
            return Needs(what, platform=False, navigation=None, logs=("accelerometer", "magnetometer"),
                         velocity=True)
        if method == "cn0-boresight":
            return Needs(what, platform=False, navigation="rinex_nav")
        if method == "vector-phase":
            return Needs(what, navigation="rinex_nav", min_antennas=1, antenna_files=False, common_epochs=False)
    return None


def _problem(code: str, title: str, detail: str, **where) -> ProblemError:
    return ProblemError(422, code, title, detail, **where)


def _t(text: str) -> datetime:
    return datetime.fromisoformat(str(text).replace("Z", ""))


def _label(obs_set) -> str:
    return f"observation set {obs_set.name or obs_set.id!r} ({obs_set.id})"


def _by_kind(obs_set) -> dict[str, list]:
    out: dict[str, list] = {}
    for f in obs_set.files:
        out.setdefault(f.kind, []).append(f)
    return out


def _present(obs_set) -> str:
    return ", ".join(sorted(f"{f.name} ({f.kind})" for f in obs_set.files)) or "no files"


def _has_gnss_orbits(by_kind: dict) -> bool:
    sp3 = [f for f in by_kind.get("sp3", []) if GNSS_SYSTEMS & set((f.summary or {}).get("systems") or [])]
    return bool(by_kind.get("rinex_nav") or sp3)


def check_set(job_type: str, obs_set, config=None) -> None:
    """Raise ProblemError(422) naming the first piece `obs_set` lacks for `job_type`; nothing when it has all."""
    needs = needs_of(job_type, config)
    if needs is None:
        return
    by_kind = _by_kind(obs_set)
    _check_platform_file(needs, obs_set, by_kind)
    _check_navigation(needs, obs_set, by_kind)
    _check_logs(needs, obs_set, by_kind)
    if needs.platform:
        _check_antennas(needs, obs_set, by_kind)
    _check_config_antenna(job_type, config, obs_set, by_kind)


def _check_platform_file(needs: Needs, obs_set, by_kind: dict) -> None:
    if needs.platform and not by_kind.get("platform"):
        raise _problem("missing-platform", "No platform.json in the set",
                       f"{needs.what} needs a platform.json (antenna positions in the body frame, CONVENTIONS.md "
                       f"'Input: platform.json'; /ui/new has a template and a form that writes one); "
                       f"{_label(obs_set)} holds: {_present(obs_set)}.", field="observation_set_ids")


def _check_navigation(needs: Needs, obs_set, by_kind: dict) -> None:
    if needs.navigation == "gnss" and not _has_gnss_orbits(by_kind):
        raise _problem("missing-navigation", "No navigation data in the set",
                       f"{needs.what} needs the GNSS orbits: a RINEX navigation file (broadcast ephemerides) or an "
                       f"SP3 of the GNSS satellites; {_label(obs_set)} holds: {_present(obs_set)}.",
                       field="observation_set_ids")
    if needs.navigation == "rinex_nav" and not by_kind.get("rinex_nav"):
        raise _problem("missing-navigation", "No navigation data in the set",
                       f"{needs.what} needs a RINEX navigation file (GPS broadcast ephemerides) for the receiver's "
                       f"code position; {_label(obs_set)} holds: {_present(obs_set)}.", field="observation_set_ids")


def _check_logs(needs: Needs, obs_set, by_kind: dict) -> None:
    """Each sensor log the method reads is in the set and overlaps the observations; a velocity when needed."""
    for kind in needs.logs:
        files = by_kind.get(kind)
        if not files:
            raise _problem(f"missing-{kind}-log", f"No {kind} log in the set",
                           f"{needs.what} needs {LOGS[kind]}; {_label(obs_set)} holds: {_present(obs_set)}.",
                           field="observation_set_ids")
        _check_log_overlap(needs, obs_set, files[0])
    if needs.velocity and not by_kind.get("velocity") and not by_kind.get("rinex_nav"):
        raise _problem("missing-velocity", "No GNSS velocity in the set",
                       f"{needs.what} needs the receiver's velocity: velocity.csv (docs/formats/inertial_csv.md), or "
                       f"a RINEX navigation file for a Doppler velocity from the observation file; "
                       f"{_label(obs_set)} holds: {_present(obs_set)}.", field="observation_set_ids")


def _check_log_overlap(needs: Needs, obs_set, log_file) -> None:
    s, span = log_file.summary or {}, obs_set.summary or {}
    try:
        start, stop = max(_t(s["time_first"]), _t(span["time_first"])), min(_t(s["time_last"]), _t(span["time_last"]))
    except (KeyError, TypeError, ValueError):
        return
    if start > stop:
        raise _problem("no-common-epochs", f"{log_file.name} does not overlap the observations",
                       f"{needs.what} uses the {log_file.kind} log together with the observations, but "
                       f"{log_file.name} spans {s['time_first']} to {s['time_last']} and the observation files of "
                       f"{_label(obs_set)} span {span['time_first']} to {span['time_last']} (GPS time).",
                       file=log_file.name)


def _check_antennas(needs: Needs, obs_set, by_kind: dict) -> None:
    """Enough antennas in platform.json, each with its observation file, and a common time span."""
    platform_file = by_kind["platform"][0]
    antennas = list((platform_file.summary or {}).get("antennas") or [])
    label = _label(obs_set)
    if len(antennas) < needs.min_antennas:
        one = " (one baseline)" if needs.min_antennas == 2 else \
            f" ({needs.min_antennas - 1} baselines)" if needs.min_antennas > 2 else ""
        raise _problem("too-few-antennas", "Too few antennas",
                       f"{needs.what} needs at least {needs.min_antennas} antennas{one}; "
                       f"{platform_file.name} of {label} names {len(antennas)}: {antennas}.",
                       file=platform_file.name, field="antennas")
    if not needs.antenna_files:
        return
    matched = (obs_set.summary or {}).get("antennas") or {}
    obs_by_name = {f.name: f for f in by_kind.get("rinex_obs", [])}
    for ant in antennas:
        fname = matched.get(ant)
        if fname is None or fname not in obs_by_name:
            raise _problem("missing-observation-file", f"No observation file for antenna {ant}",
                           f"{platform_file.name} names antenna {ant!r}, whose observation file "
                           f"{fname!r} is not in {label} (observation files: {sorted(obs_by_name)}).",
                           file=platform_file.name, field=f"antennas.{ant}")
    if needs.common_epochs:
        _check_common_epochs(label, platform_file, antennas, matched, obs_by_name)


def _check_common_epochs(label: str, platform_file, antennas, matched: dict, obs_by_name: dict) -> None:
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


def _check_config_antenna(job_type: str, config, obs_set, by_kind: dict) -> None:
    """A single-antenna method's configured antenna is one of platform.json's."""
    if job_type != "single-antenna-attitude" or config is None:
        return
    field, ant = {"vector-phase": ("config.vector_phase.antenna_id", config.vector_phase.antenna_id),
                  "cn0-boresight": ("config.cn0_boresight.antenna", config.cn0_boresight.antenna)}.get(
        config.method, (None, None))
    if not ant:
        return
    plats = by_kind.get("platform") or []
    antennas = list((plats[0].summary or {}).get("antennas") or []) if plats else []
    if ant not in antennas:
        where = f"{plats[0].name} of {_label(obs_set)} names {antennas}" if plats else \
            f"{_label(obs_set)} has no platform.json"
        raise _problem("unknown-antenna", f"Unknown antenna {ant}",
                       f"{field} is {ant!r}, but {where}; give one of those or leave it empty.", field=field)


def check_plan(config, obs_sets) -> None:
    """A plan job: a platform (config.platform or a set's platform.json) with a baseline, and the set file its
    orbit kind reads (an SP3 for sp3, velocity.csv for trajectory)."""
    kinds = {k: fs for s in obs_sets for k, fs in _by_kind(s).items()}
    sets = ", ".join(_label(s) for s in obs_sets) or "no observation set"
    if config.platform is None:
        plats = kinds.get("platform")
        if not plats:
            raise _problem("missing-platform", "No platform for the plan",
                           f"A plan job needs the platform's antennas: give config.platform (a platform.json object) "
                           f"or a set with a platform.json (/ui/new has a template); the job has {sets}.",
                           field="config.platform")
        antennas, where = list((plats[0].summary or {}).get("antennas") or []), plats[0].name
    else:
        antennas, where = list((config.platform or {}).get("antennas") or {}), "config.platform"
    if len(antennas) < 2:
        raise _problem("too-few-antennas", "Too few antennas",
                       f"A plan job needs at least 2 antennas (one baseline); {where} names {len(antennas)}: "
                       f"{antennas}.", field="config.platform" if where == "config.platform" else "antennas",
                       file=None if where == "config.platform" else where)
    need = {"sp3": ("sp3", "an SP3 file with the platform's orbit"),
            "trajectory": ("velocity", "velocity.csv with x/y/z_ecef_m columns (docs/formats/inertial_csv.md)")}
    kind, text = need.get(config.orbit.kind, (None, None))
    if kind and not kinds.get(kind):
        raise _problem(f"missing-{kind}", f"No {kind} file for orbit.kind {config.orbit.kind}",
                       f"config.orbit.kind {config.orbit.kind} reads {text} from the job's set; the job has {sets}.",
                       field="config.orbit.kind")


def check_ttff(config, obs_sets) -> None:
    """A ttff job: sets to study, uploaded or simulated."""
    if not obs_sets and config.simulate is None:
        raise _problem("nothing-to-study", "Nothing to study",
                       "A ttff job needs observation sets: give observation_set_ids, or a config.simulate block "
                       "(random starts simulated on the fly, docs/ttff.md).", field="config.simulate")


def check_job(job_type: str, config, obs_sets) -> None:
    """Every check of a job before it is queued: the config-level ones, then each set in the order given."""
    if job_type == "plan":
        check_plan(config, obs_sets)
    elif job_type == "ttff":
        check_ttff(config, obs_sets)
    for s in obs_sets:
        check_set(job_type, s, config)

