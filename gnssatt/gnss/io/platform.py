"""`platform.json`: the platform's antennas in the body frame, checked against ../shared/CONVENTIONS.md.

Implements: CONVENTIONS.md "Inputs: an observation set" (name, kind, antennas with position_m and
boresight, master, baselines defaulting to master-to-each-other-antenna, observation_files defaulting
to the RINEX MARKER NAME) and docs/formats/platform_antenna_uncertainty.md (an antenna's optional declared
pco_sigma_mm / pcv_rms_mm).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from gnssatt.gnss.io.errors import ParseError

KINDS = ("spacecraft", "terrestrial")
_LAYOUT = ('{"name": ..., "kind": "spacecraft"|"terrestrial", "antennas": {"ID": {"position_m": [x, y, z], '
           '"boresight": [x, y, z]}, ...}, "master": "ID", "baselines": [["ID1", "ID2"], ...], '
           '"observation_files": {"ID": "file name"}}')


@dataclass
class Antenna:
    id: str
    position_body_m: np.ndarray  # (3,)
    boresight_body: np.ndarray  # (3,) unit vector
    # declared uncertainty of the phase centre (docs/formats/platform_antenna_uncertainty.md): None = not declared;
    # a number (mm) for every signal or {signal: mm}
    pco_sigma_mm: float | dict | None = None
    pcv_rms_mm: float | dict | None = None


@dataclass
class Platform:
    name: str
    kind: str
    antennas: dict[str, Antenna]
    master: str
    baselines: list[tuple[str, str]]
    observation_files: dict[str, str] = field(default_factory=dict)  # antenna id -> file name, as given

    def baseline_body_m(self, first: str, second: str) -> np.ndarray:
        """Body-frame vector from the first antenna's to the second antenna's position."""
        return self.antennas[second].position_body_m - self.antennas[first].position_body_m


def _err(name: str, expected: str, found: str = "") -> ParseError:
    return ParseError(name, None, expected, found)


def _vec3(name: str, where: str, value) -> np.ndarray:
    if (not isinstance(value, (list, tuple)) or len(value) != 3
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)):
        raise _err(name, f"{where} as a list of three finite numbers", json.dumps(value)[:100])
    return np.asarray(value, dtype=np.float64)


def _sigma_mm(name: str, where: str, value):
    """A declared sigma: None, a non-negative number, or {signal: non-negative number}."""
    def ok(v):
        return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v >= 0
    if value is None or ok(value):
        return None if value is None else float(value)
    if isinstance(value, dict) and value and all(isinstance(k, str) and ok(v) for k, v in value.items()):
        return {k: float(v) for k, v in value.items()}
    raise _err(name, f"{where} as a non-negative number (mm) or an object signal -> mm", json.dumps(value)[:100])


def parse_platform(text: str | bytes, name: str = "platform.json") -> Platform:
    """The Platform described by a platform.json text; ParseError naming the field at fault otherwise."""
    try:
        doc = json.loads(text)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        line = getattr(exc, "lineno", None)
        raise ParseError(name, line, f"a JSON object like {_LAYOUT}", str(exc)) from exc
    if not isinstance(doc, dict):
        raise _err(name, f"a JSON object like {_LAYOUT}", type(doc).__name__)
    antennas_doc = doc.get("antennas")
    if not isinstance(antennas_doc, dict) or not antennas_doc:
        raise _err(name, '"antennas": an object with at least one antenna id', json.dumps(antennas_doc)[:100])
    kind = doc.get("kind", "spacecraft")
    if kind not in KINDS:
        raise _err(name, '"kind": "spacecraft" or "terrestrial"', repr(kind))
    antennas: dict[str, Antenna] = {}
    for ant_id, spec in antennas_doc.items():
        if not isinstance(spec, dict):
            raise _err(name, f'antennas["{ant_id}"] as an object with position_m and boresight', repr(spec)[:100])
        pos = _vec3(name, f'antennas["{ant_id}"].position_m', spec.get("position_m"))
        bore = _vec3(name, f'antennas["{ant_id}"].boresight', spec.get("boresight", [0, 0, -1]))
        norm = float(np.linalg.norm(bore))
        if norm < 1e-9:
            raise _err(name, f'antennas["{ant_id}"].boresight to be a non-zero vector', str(bore.tolist()))
        unc = {k: _sigma_mm(name, f'antennas["{ant_id}"].{k}', spec.get(k)) for k in ("pco_sigma_mm", "pcv_rms_mm")}
        antennas[str(ant_id)] = Antenna(str(ant_id), pos, bore / norm, **unc)
    master = doc.get("master", next(iter(antennas)))
    if master not in antennas:
        raise _err(name, f'"master" to name one of the antennas {sorted(antennas)}', repr(master))
    raw_baselines = doc.get("baselines")
    if raw_baselines is None:
        baselines = [(master, a) for a in antennas if a != master]
    else:
        if not isinstance(raw_baselines, list):
            raise _err(name, '"baselines": a list of [first, second] antenna id pairs', repr(raw_baselines)[:100])
        baselines = []
        for pair in raw_baselines:
            if (not isinstance(pair, (list, tuple)) or len(pair) != 2 or pair[0] not in antennas
                    or pair[1] not in antennas or pair[0] == pair[1]):
                raise _err(name, f'each baseline as [first, second], two different ids of {sorted(antennas)}',
                           repr(pair)[:100])
            baselines.append((pair[0], pair[1]))
    for first, second in baselines:
        if np.linalg.norm(antennas[second].position_body_m - antennas[first].position_body_m) < 1e-3:
            raise _err(name, f"baseline {first}>{second} to be longer than 1 mm in the body frame", "")
    files = doc.get("observation_files", {})
    if not isinstance(files, dict) or not all(isinstance(v, str) and k in antennas for k, v in files.items()):
        raise _err(name, f'"observation_files": an object mapping antenna ids {sorted(antennas)} to file names',
                   repr(files)[:100])
    plat_name = doc.get("name", "unnamed platform")
    if not isinstance(plat_name, str):
        raise _err(name, '"name": a string', repr(plat_name))
    return Platform(plat_name, kind, antennas, master, baselines, dict(files))


def match_observation_files(platform: Platform, obs_files: dict[str, str | None],
                            name: str = "platform.json") -> dict[str, str]:
    """Antenna id -> observation file name in the set.

    Args:
        obs_files: file name in the set -> its RINEX MARKER NAME (or None).
    Rule: `observation_files` entries match a file by exact relative path, else by base name; antennas
    without an entry match the file whose MARKER NAME equals the antenna id. Every antenna needs a file.
    """
    by_base: dict[str, list[str]] = {}
    for fname in obs_files:
        by_base.setdefault(fname.rsplit("/", 1)[-1], []).append(fname)
    result: dict[str, str] = {}
    for ant_id in platform.antennas:
        wanted = platform.observation_files.get(ant_id)
        if wanted is not None:
            if wanted in obs_files:
                result[ant_id] = wanted
                continue
            cands = by_base.get(wanted.replace("\\", "/").rsplit("/", 1)[-1], [])
            if len(cands) == 1:
                result[ant_id] = cands[0]
                continue
            raise _err(name, f'observation_files["{ant_id}"] = {wanted!r} to name an observation file of the set '
                       f'({sorted(obs_files)})', wanted)
        markers = [f for f, marker in obs_files.items() if marker and marker.strip() == ant_id]
        if len(markers) == 1:
            result[ant_id] = markers[0]
            continue
        raise _err(name, f"an observation file for antenna {ant_id!r}: either an observation_files entry or a "
                   f"RINEX file whose MARKER NAME is {ant_id!r} (files: {sorted(obs_files)})",
                   "none" if not markers else f"{len(markers)} files with that MARKER NAME")
    used = list(result.values())
    if len(set(used)) != len(used):
        raise _err(name, "each antenna to have its own observation file", json.dumps(result))
    return result
