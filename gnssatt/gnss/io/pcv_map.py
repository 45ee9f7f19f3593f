"""Differential phase-centre-variation maps: the JSON of ../shared/CONVENTIONS.md and an ANTEX-style text.

A map belongs to a platform, an antenna pair (first, second) and a frequency; it lives on an azimuth x
elevation grid of bin centres in the antenna frame of the pair's first antenna; values in millimetres are
the differential carrier-phase correction to subtract from the observed single difference (second minus
first). Empty bins hold null (NaN here), never an invented value.

ANTEX-style text: the record layout of ANTEX 1.4 (labels in columns 61-80; one antenna block per map,
TYPE / SERIAL NO = "DIFF <first>><second>" / platform; ZEN1 / ZEN2 / DZEN and DAZI over the bin centres
(zenith = 90 - elevation); a frequency block G01/G02/G05 with a NOAZI row and one row per azimuth bin
centre), with two documented gnssatt extensions so that nothing is lost on a round trip: values are
written as F10.4 (not F8.2), and `START OF FREQ RMS` carries sigma_mm while a `START OF FREQ COUNT` block
carries the sample counts.

Grids: bin centres with at most 3 decimals in azimuth and 2 in elevation (0.01 deg) survive the text.

Implements: ANTEX 1.4 (IGS, 2010) record layout; CONVENTIONS.md "Output: phase-centre-variation maps".
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np

from gnssatt.gnss.io.errors import ParseError

FREQ_CODES = {"L1": "G01", "L2": "G02", "L5": "G05"}
FREQ_NAMES = {v: k for k, v in FREQ_CODES.items()}
VALUE_DECIMALS = 4  # values are kept to 0.1 um: far below any PCV accuracy, and exact through the text


@dataclass
class PcvMap:
    platform: str
    first: str
    second: str
    frequency: str
    azimuth_deg: np.ndarray  # (n_az,) bin centres
    elevation_deg: np.ndarray  # (n_el,) bin centres
    values_mm: np.ndarray  # (n_el, n_az) NaN where empty
    count: np.ndarray  # (n_el, n_az) int
    sigma_mm: np.ndarray  # (n_el, n_az) NaN where empty

    def to_json(self) -> dict:
        """The CONVENTIONS.md JSON object (null for empty bins)."""
        def grid(a, cast):
            return [[None if (isinstance(v, float) and math.isnan(v)) else cast(v) for v in row] for row in a.tolist()]
        return {"platform": self.platform, "pair": [self.first, self.second], "frequency": self.frequency,
                "azimuth_deg": [float(v) for v in self.azimuth_deg], "elevation_deg": [float(v) for v in self.elevation_deg],
                "values_mm": grid(self.values_mm, float), "count": [[int(v) for v in row] for row in self.count.tolist()],
                "sigma_mm": grid(self.sigma_mm, float)}

    def equals(self, other: "PcvMap") -> bool:
        same_meta = (self.platform, self.first, self.second, self.frequency) == \
            (other.platform, other.first, other.second, other.frequency)
        return same_meta and all(np.array_equal(a, b, equal_nan=True) for a, b in (
            (self.azimuth_deg, other.azimuth_deg), (self.elevation_deg, other.elevation_deg),
            (self.values_mm, other.values_mm), (self.count, other.count), (self.sigma_mm, other.sigma_mm)))


def _grid_field(doc: dict, key: str, shape: tuple[int, int], name: str, allow_null: bool) -> np.ndarray:
    rows = doc.get(key)
    if not isinstance(rows, list) or len(rows) != shape[0] or not all(isinstance(r, list) and len(r) == shape[1]
                                                                      for r in rows):
        raise ParseError(name, None, f'"{key}" as {shape[0]} rows (one per elevation) of {shape[1]} values '
                         "(one per azimuth)", json.dumps(rows)[:120] if rows is not None else "missing")
    out = np.full(shape, np.nan)
    for i, row in enumerate(rows):
        for j, v in enumerate(row):
            if v is None and allow_null:
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ParseError(name, None, f'finite numbers{" or null" if allow_null else ""} in "{key}"',
                                 f"{key}[{i}][{j}] = {v!r}")
            out[i, j] = v
    return out


def parse_pcv_map(doc: dict | str | bytes, name: str = "pcv map") -> PcvMap:
    """A PcvMap from its CONVENTIONS.md JSON (object or text); ParseError naming the field otherwise."""
    if isinstance(doc, (str, bytes)):
        try:
            doc = json.loads(doc)
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ParseError(name, getattr(exc, "lineno", None), "a JSON object", str(exc)) from exc
    if not isinstance(doc, dict):
        raise ParseError(name, None, "a JSON object", type(doc).__name__)
    pair = doc.get("pair")
    if not (isinstance(pair, list) and len(pair) == 2 and all(isinstance(p, str) and p for p in pair)
            and pair[0] != pair[1]):
        raise ParseError(name, None, '"pair": [first antenna id, second antenna id]', repr(pair)[:100])
    freq = doc.get("frequency")
    if freq not in FREQ_CODES:
        raise ParseError(name, None, f'"frequency" one of {sorted(FREQ_CODES)}', repr(freq))
    platform = doc.get("platform")
    if not isinstance(platform, str) or not platform:
        raise ParseError(name, None, '"platform": the platform name', repr(platform))
    axes = {}
    for key, lo, hi in (("azimuth_deg", 0.0, 360.0), ("elevation_deg", -90.0, 90.0)):
        values = doc.get(key)
        if (not isinstance(values, list) or not values
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)):
            raise ParseError(name, None, f'"{key}": a non-empty list of bin centres', repr(values)[:100])
        arr = np.asarray(values, dtype=np.float64)
        if np.any(np.diff(arr) <= 0) or arr.min() < lo or arr.max() > hi:
            raise ParseError(name, None, f'"{key}" increasing, within [{lo:g}, {hi:g}]', repr(values)[:100])
        axes[key] = arr
    shape = (len(axes["elevation_deg"]), len(axes["azimuth_deg"]))
    values = _grid_field(doc, "values_mm", shape, name, allow_null=True)
    count = _grid_field(doc, "count", shape, name, allow_null=False) if "count" in doc else \
        np.where(np.isnan(values), 0, 1).astype(float)
    sigma = _grid_field(doc, "sigma_mm", shape, name, allow_null=True) if "sigma_mm" in doc else np.full(shape, np.nan)
    if np.any(count < 0) or np.any(count != np.round(count)):
        raise ParseError(name, None, '"count": non-negative integers', "")
    return PcvMap(platform, pair[0], pair[1], freq, axes["azimuth_deg"], axes["elevation_deg"],
                  np.round(values, VALUE_DECIMALS), count.astype(np.int64), np.round(sigma, VALUE_DECIMALS))


# --- ANTEX-style text -------------------------------------------------------------------------------

def _label(text: str, label: str) -> str:
    return f"{text:<60.60}{label:<20}"


def _num(v: float) -> str:
    return f"{'NaN':>10}" if math.isnan(v) else f"{v:10.{VALUE_DECIMALS}f}"


def write_pcv_antex(maps: list[PcvMap]) -> str:
    """ANTEX-style text holding one antenna block per map (see the module docstring)."""
    lines = [_label(f"{1.4:8.1f}{'':12}M", "ANTEX VERSION / SYST"),
             _label("R", "PCV TYPE / REFANT"),
             _label("gnssatt differential PCV maps, values and RMS F10.4 mm", "COMMENT"),
             _label("extension: FREQ COUNT blocks hold sample counts", "COMMENT"),
             _label("zenith = 90 - elevation of the bin centres; azimuth in the", "COMMENT"),
             _label("antenna frame of the first antenna of the pair", "COMMENT"),
             _label("", "END OF HEADER")]
    for m in maps:
        zen = 90.0 - m.elevation_deg[::-1]  # increasing zenith
        dzen = float(zen[1] - zen[0]) if len(zen) > 1 else 0.0
        dazi = float(m.azimuth_deg[1] - m.azimuth_deg[0]) if len(m.azimuth_deg) > 1 else 0.0
        lines += [_label("", "START OF ANTENNA"),
                  _label(f"{'DIFF ' + m.first + '>' + m.second:<20.20}{m.platform:<20.20}", "TYPE / SERIAL NO"),
                  _label(f"{'':2}{dazi:6.1f}", "DAZI"),
                  _label(f"{'':2}{zen[0]:6.2f}{zen[-1]:6.2f}{dzen:6.2f}", "ZEN1 / ZEN2 / DZEN"),
                  _label(f"{1:6d}", "# OF FREQUENCIES"),
                  _label(f"{'':3}PAIR {json.dumps([m.first, m.second])}", "COMMENT"),
                  _label(f"{'':3}PLATFORM {json.dumps(m.platform)}", "COMMENT")]
        code = FREQ_CODES[m.frequency]
        for block, grid in (("FREQUENCY", m.values_mm), ("FREQ RMS", m.sigma_mm), ("FREQ COUNT", m.count)):
            g = grid[::-1].T.astype(np.float64)  # (n_az, n_zen)
            lines.append(_label(f"{'':3}{code}", f"START OF {block}"))
            if block == "FREQUENCY":
                lines.append(_label(f"{0.0:10.2f}{0.0:10.2f}{0.0:10.2f}", "NORTH / EAST / UP"))
            with np.errstate(all="ignore"):
                noazi = np.where(np.all(np.isnan(g), axis=0), np.nan, np.nanmean(g, axis=0))
            lines.append("   NOAZI" + "".join(_num(v) for v in np.round(noazi, VALUE_DECIMALS)))
            for a, row in zip(m.azimuth_deg, g):
                lines.append(f"{a:8.3f}" + "".join(_num(v) for v in row))
            lines.append(_label(f"{'':3}{code}", f"END OF {block}"))
        lines.append(_label("", "END OF ANTENNA"))
    return "\n".join(lines) + "\n"


def read_pcv_antex(text: str, name: str = "pcv.atx") -> list[PcvMap]:
    """The maps of an ANTEX-style text written by write_pcv_antex; ParseError with the line otherwise."""
    lines = text.splitlines()
    maps: list[PcvMap] = []
    i = 0
    n = len(lines)

    def label(k: int) -> str:
        return lines[k][60:80].strip() if len(lines[k]) > 60 else ""

    if not lines or label(0) != "ANTEX VERSION / SYST":
        raise ParseError(name, 1, "'ANTEX VERSION / SYST' in columns 61-80 of the first line", lines[0] if lines else "")
    while i < n and label(i) != "END OF HEADER":
        i += 1
    if i == n:
        raise ParseError(name, n, "an END OF HEADER line", "end of file")
    i += 1
    while i < n:
        if not lines[i].strip():
            i += 1
            continue
        if label(i) != "START OF ANTENNA":
            raise ParseError(name, i + 1, "START OF ANTENNA", lines[i])
        start = i
        meta: dict = {}
        blocks: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        freq = None
        i += 1
        while i < n and label(i) != "END OF ANTENNA":
            lab, line = label(i), lines[i]
            try:
                if lab == "COMMENT" and line[3:8] == "PAIR ":
                    meta["pair"] = json.loads(line[8:60])
                elif lab == "COMMENT" and line[3:12] == "PLATFORM ":
                    meta["platform"] = json.loads(line[12:60])
                elif lab.startswith("START OF "):
                    block = lab[len("START OF "):]
                    freq = FREQ_NAMES.get(line[3:6].strip())
                    if freq is None:
                        raise ValueError(f"unknown frequency code {line[3:6]!r}")
                    i += 1
                    if block == "FREQUENCY" and label(i) == "NORTH / EAST / UP":
                        i += 1
                    if not lines[i].startswith("   NOAZI"):
                        raise ValueError("NOAZI row expected")
                    zen_count = (len(lines[i]) - 8) // 10
                    i += 1
                    az, rows = [], []
                    while i < n and not label(i).startswith("END OF "):
                        row = lines[i]
                        az.append(float(row[0:8]))
                        rows.append([float(row[8 + 10 * k:18 + 10 * k]) for k in range(zen_count)])
                        i += 1
                    blocks[block] = (np.asarray(az), np.asarray(rows, dtype=np.float64))
                elif lab == "ZEN1 / ZEN2 / DZEN":
                    meta["zen"] = (float(line[2:8]), float(line[8:14]), float(line[14:20]))
            except (ValueError, IndexError, json.JSONDecodeError) as exc:
                raise ParseError(name, i + 1, "an ANTEX-style PCV map record as written by gnssatt",
                                 f"{lines[i]} ({exc})") from exc
            i += 1
        if i >= n:
            raise ParseError(name, start + 1, "END OF ANTENNA closing this block", "end of file")
        i += 1
        if "FREQUENCY" not in blocks or "pair" not in meta or "platform" not in meta or "zen" not in meta:
            raise ParseError(name, start + 1, "a FREQUENCY block and PAIR / PLATFORM comments", "incomplete block")
        az, values = blocks["FREQUENCY"]
        zen1, zen2, dzen = meta["zen"]
        n_zen = values.shape[1]
        zen = zen1 + dzen * np.arange(n_zen) if n_zen > 1 else np.array([zen1])
        elevation = np.round(90.0 - zen[::-1], 10)
        sig = blocks.get("FREQ RMS", (az, np.full_like(values, np.nan)))[1]
        cnt = blocks.get("FREQ COUNT", (az, np.where(np.isnan(values), 0.0, 1.0)))[1]
        maps.append(PcvMap(meta["platform"], meta["pair"][0], meta["pair"][1], freq, az, elevation,
                           values.T[::-1].copy(), cnt.T[::-1].astype(np.int64), sig.T[::-1].copy()))
    return maps
