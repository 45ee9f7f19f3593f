"""antenna_pattern.json: a receive antenna's vector effective length (docs/formats/antenna_vector_length.md,
CONVENTIONS.md "Inputs: receive-antenna pattern"), read into a model of gnssatt.vector_phase.antenna and written
back. Errors are ParseError naming the file, the JSON line (syntax) or the key at fault, and what was expected.
"""
from __future__ import annotations

import json
import math

import numpy as np

from gnssatt.gnss.io.errors import ParseError
from gnssatt.vector_phase.antenna import AsymmetricPatch, RhcpPatch, ShortDipole, TableAntenna

__all__ = ["parse_antenna_pattern", "antenna_pattern_doc", "MODELS"]

MODELS = ("table", "short-dipole", "rhcp-patch", "asymmetric-patch")
_LAYOUT = ('{"frequency": "L1", "model": "table", "theta_deg": [0, 2, ...], "phi_deg": [0, 2, ..., 358], '
           '"h_theta_m": [[[re, im], ...], ...], "h_phi_m": [[[re, im], ...], ...]} or {"model": "short-dipole" | '
           '"rhcp-patch" | "asymmetric-patch", ...parameters}')


def _number(name, key, value, lo=-math.inf, hi=math.inf):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or not lo <= value <= hi:
        raise ParseError(name, None, f'"{key}" a finite number in [{lo}, {hi}]', json.dumps(value)[:80])
    return float(value)


def _grid(name, key, value, lo, hi):
    if not isinstance(value, list) or len(value) < 2:
        raise ParseError(name, None, f'"{key}" a list of at least two numbers in [{lo}, {hi}]', json.dumps(value)[:80])
    arr = np.array([_number(name, f"{key}[{i}]", v, lo, hi) for i, v in enumerate(value)])
    if np.any(np.diff(arr) <= 0):
        raise ParseError(name, None, f'"{key}" strictly increasing', json.dumps(value)[:80])
    return arr


def _complex_table(name, key, value, shape):
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ParseError(name, None, f'"{key}" a {shape[0]} x {shape[1]} array of [re, im] pairs', str(exc)) from exc
    if arr.shape != (*shape, 2):
        raise ParseError(name, None, f'"{key}" of shape {shape[0]} x {shape[1]} x 2 (theta x phi x [re, im])',
                         f"shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ParseError(name, None, f'"{key}" finite numbers', "NaN or infinite values")
    return arr[..., 0] + 1j * arr[..., 1]


def _table(doc: dict, name: str) -> TableAntenna:
    theta = _grid(name, "theta_deg", doc.get("theta_deg"), 0.0, 180.0)
    phi = _grid(name, "phi_deg", doc.get("phi_deg"), -360.0, 360.0)
    step = 360.0 / len(phi)
    if np.max(np.abs(phi - phi[0] - step * np.arange(len(phi)))) > 1e-6:
        raise ParseError(name, None, '"phi_deg" a uniform grid covering 360 deg without repeating the first value '
                         f"(step 360 / {len(phi)} = {step:g} deg)", json.dumps(doc.get("phi_deg"))[:80])
    shape = (len(theta), len(phi))
    return TableAntenna(theta, phi, _complex_table(name, "h_theta_m", doc.get("h_theta_m"), shape),
                        _complex_table(name, "h_phi_m", doc.get("h_phi_m"), shape))


def parse_antenna_pattern(source, name: str = "antenna_pattern.json"):
    """The antenna model of an antenna_pattern.json text/bytes or an already decoded object (dict)."""
    if isinstance(source, dict):
        doc = source
    else:
        try:
            doc = json.loads(source)
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ParseError(name, getattr(exc, "lineno", None), f"a JSON object like {_LAYOUT}", str(exc),
                             column=getattr(exc, "colno", None)) from exc
    if not isinstance(doc, dict):
        raise ParseError(name, None, f"a JSON object like {_LAYOUT}", type(doc).__name__)
    model = doc.get("model")
    if model not in MODELS:
        raise ParseError(name, None, f'"model" one of {list(MODELS)}', repr(model))
    freq = doc.get("frequency", "L1")
    if freq != "L1":
        raise ParseError(name, None, '"frequency": "L1" (the only carrier the vector-phase method uses)', repr(freq))
    length = _number(name, "length_m", doc.get("length_m", 0.1), 1e-6, 10.0)
    if model == "table":
        return _table(doc, name)
    if model == "short-dipole":
        return ShortDipole(length)
    if model == "rhcp-patch":
        return RhcpPatch(length)
    harmonic = doc.get("harmonic", 2)
    if not isinstance(harmonic, int) or isinstance(harmonic, bool) or not 1 <= harmonic <= 8:
        raise ParseError(name, None, '"harmonic" an integer 1-8', repr(harmonic))
    return AsymmetricPatch(length, _number(name, "asymmetry", doc.get("asymmetry", 0.5), 0.0, 0.95), harmonic,
                           _number(name, "phase_deg", doc.get("phase_deg", 0.0), -360.0, 360.0))


def antenna_pattern_doc(antenna) -> dict:
    """The antenna_pattern.json object of a model (tables as [re, im] pairs)."""
    if isinstance(antenna, TableAntenna):
        pairs = lambda z: np.stack([z.real, z.imag], -1).round(12).tolist()  # noqa: E731
        return {"frequency": "L1", "model": "table", "theta_deg": antenna.theta_deg.tolist(),
                "phi_deg": antenna.phi_deg.tolist(), "h_theta_m": pairs(antenna.h_theta_m),
                "h_phi_m": pairs(antenna.h_phi_m)}
    doc = {"frequency": "L1", "model": antenna.name, "length_m": antenna.length_m}
    if isinstance(antenna, AsymmetricPatch):
        doc.update(asymmetry=antenna.asymmetry, harmonic=antenna.harmonic, phase_deg=antenna.phase_deg)
    return doc
