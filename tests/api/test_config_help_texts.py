"""Every config field of every job type has a real help text in the schema /v1/job-types serves (issue 24, item
8): what it does, its unit where it has one and, for a choice, every allowed value; the numeric range is the
schema's own minimum/maximum (test_config_bounds.py). The schemas are built in process, as the route builds them."""
from __future__ import annotations

import re

from worker.jobs.registry import job_types

MIN_CHARS = 15

# Unit suffix of a field name -> the unit its help text must name.
SUFFIX_UNITS = {"_deg": "deg", "_deg_s": "deg/s", "_deg_s2": "deg/s^2", "_m": "m", "_mm": "mm", "_s": "s",
                "_hz": "Hz", "_dbhz": "dB-Hz", "_cyc": "cycles", "_nT": "nT", "_m_s": "m/s", "_m_s2": "m/s^2",
                "_mb": "MB", "_db": "dB", "_tecu": "TECU", "_deg_s_per_sqrt_s": "deg/s per sqrt(s)",
                "_m_per_sqrt_s": "m per sqrt(s)", "_rad_s": "rad/s", "_rad_sqrt_s": "rad/sqrt(s)"}
# A unit named in a help text: a word such as deg, m, s, dB-Hz, cycles (alone or in a compound like deg/s).
UNIT_WORD = re.compile(r"(?<![\w-])(deg|m|mm|s|h|Hz|dB-Hz|dB|cycles?|nT|MB|TECU|m/s|deg/s)(?![\w-])")
# A count's unit is what it counts.
COUNT_WORD = re.compile(r"\b(satellites|epochs|updates|samples|iterations|passes|attempts|propagators|ambiguities|"
                        r"tasks|channels|sets|starts|bins)\b", re.IGNORECASE)


def _names_unit(desc: str, unit: str) -> bool:
    return re.search(r"(?<![\w-])" + re.escape(unit) + r"(?![\w-])", desc) is not None

# Numbers without a unit, each with the reason.
DIMENSIONLESS = {
    "innovation_gate_sigma": "a multiple of the innovation's own sigma",
    "min_ratio": "a ratio of two quadratic forms",
    "min_ratio_constrained": "a ratio of two quadratic forms",
    "min_ratio_constrained_joint": "a ratio of two quadratic forms",
    "min_ratio_first_fix": "a ratio of two quadratic forms",
    "l2_min_ratio_first_fix": "a ratio of two quadratic forms",
    "multipath_correlation_factor": "a factor on a variance",
    "noise_floor": "a fraction of a Table 1 rate",
    "noise_gain": "a factor on alpha alpha^T dt, which carries the units",
    "accel_noise_k": "a multiple of a median",
    "quiet_jerk_share": "a share of a configured rate",
    "noise_em_bound": "a factor on the configured floor",
    "threshold": "a log-likelihood ratio",
    "mix_at": "a log-likelihood ratio",
    "kappa": "a multiple of sqrt(2 mu) of a chi-square statistic",
    "min_reference_coverage": "a fraction of epochs",
    "smoothing_order": "a polynomial order",
    "seed": "a random seed",
    "gyro_threshold_sigma": "a multiple of the residual's theoretical sigma",
    "initial_q_body_from_ecef": "a unit quaternion",
    "q_body_from_ecef": "a unit quaternion",
    "e": "an eccentricity",
}


def _walk(schema: dict, defs: dict, path: str, desc: str | None, out: list) -> None:
    """Append (path, name, leaf schema, description) of every leaf field below `schema`."""
    if "$ref" in schema:
        _walk(defs[schema["$ref"].split("/")[-1]], defs, path, schema.get("description") or desc, out)
        return
    desc = schema.get("description") or desc
    subs = [s for key in ("anyOf", "oneOf", "allOf") for s in schema.get(key, [])]
    nested = [s for s in subs + [schema.get("items") or {}] if "$ref" in s or s.get("properties")]
    if schema.get("properties"):
        for name, sub in schema["properties"].items():
            _walk(sub, defs, f"{path}.{name}", None, out)
    elif not nested:
        out.append((path, path.rsplit(".", 1)[-1], schema, desc))
    for sub in nested:
        _walk(sub, defs, path, desc, out)


def _leaves() -> list:
    out: list = []
    for name, jt in job_types().items():
        schema = jt.config_model.model_json_schema()
        _walk(schema, schema.get("$defs", {}), name, None, out)
    return out


def _types(schema: dict) -> set:
    kinds = {schema.get("type")} | {s.get("type") for s in schema.get("anyOf", [])}
    items = [schema.get("items") or {}] + [s.get("items") or {} for s in schema.get("anyOf", [])]
    return kinds | {i.get("type") for i in items if i} - {None}


def _enum(schema: dict) -> list:
    """The allowed values of a choice field, or of the items of a list of choices."""
    alts = [schema] + schema.get("anyOf", [])
    alts += [a["items"] for a in alts if isinstance(a.get("items"), dict)]
    return [v for a in alts for v in a.get("enum", [])]


def test_every_config_field_has_a_help_text():
    leaves = _leaves()
    assert len(leaves) > 150, "the walk lost the nested settings groups"
    short = [f"{path}: {desc!r}" for path, _, _, desc in leaves if len((desc or "").strip()) < MIN_CHARS]
    assert not short, "config fields without a help text of at least %d characters (add description= to the " \
                      "Field or the settings metadata): %s" % (MIN_CHARS, short)
    # The UI shows one field's text alone: none may lean on its neighbour's ("... and", "The same for").
    leaning = [f"{path}: {desc!r}" for path, _, _, desc in leaves if desc.startswith(("...", "+", "The same", "Its "))]
    assert not leaning, f"help texts that only make sense after the previous field's: {leaning}"


def test_every_choice_field_names_its_allowed_values():
    missing = [f"{path}: {[v for v in _enum(s) if str(v) not in (d or '')]}" for path, _, s, d in _leaves()
               if _enum(s) and any(str(v) not in (d or "") for v in _enum(s))]
    assert not missing, f"choice fields whose help text leaves out allowed values: {missing}"


def test_every_numeric_config_field_names_its_unit_or_is_listed_dimensionless():
    flagged = []
    for path, name, schema, desc in _leaves():
        if not {"number", "integer"} & _types(schema):
            continue
        suffix = max((s for s in SUFFIX_UNITS if name.endswith(s)), key=len, default=None)
        if suffix is not None:
            if not _names_unit(desc or "", SUFFIX_UNITS[suffix]):
                flagged.append(f"{path}: name says {SUFFIX_UNITS[suffix]!r}, help text does not")
        elif not (UNIT_WORD.search(desc or "") or COUNT_WORD.search(desc or "")) and name not in DIMENSIONLESS:
            flagged.append(f"{path}: no unit in {desc!r} and not in DIMENSIONLESS")
    assert not flagged, "numeric config fields without their unit: " + "; ".join(flagged)


def test_dimensionless_list_has_no_stale_or_unit_bearing_names():
    names = {name for _, name, schema, _ in _leaves() if {"number", "integer"} & _types(schema)}
    assert not set(DIMENSIONLESS) - names, f"DIMENSIONLESS names no such numeric field: {set(DIMENSIONLESS) - names}"
    assert not [n for n in DIMENSIONLESS if any(n.endswith(s) for s in SUFFIX_UNITS)]
