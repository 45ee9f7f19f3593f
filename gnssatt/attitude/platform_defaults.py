"""Defaults by platform kind (issue 21 item 4): what the attitude job uses when the user leaves the signals and the
weighting as they are.

GLONASS (R, FDMA: per-satellite wavelengths, gnssatt.attitude.observations) is among them: on Nagoya with G/E/C/J/R
the defaults give 0.24 mm, 0.030 deg azimuth and 0.064 deg elevation off the known values.

Spacecraft keep seed 000 Tables 1-2 (GPS L1 C/A + L2, no weighting: the paper's configuration and the figures it
publishes). Terrestrial platforms get every system of the `systems` preset (G, E, C, J: the first two frequencies
of each, gnssatt.gnss.signals.SYSTEM_SIGNALS) that every antenna's file carries, and elevation weights: on the real
Nagoya 0.99 m baseline (docs/attitude.md "Real data") GPS L1/L2 without weights gives the length 3.4 mm and the
elevation 0.23 deg off the known values, G/E/C/J with elevation weights 0.3 mm / 0.03 deg (dynamic mode). A
terrestrial antenna sees the ground's multipath at low elevation, which the elevation weights tame, and more
satellites make the short-baseline geometry (and so the elevation of the baseline) better; a spacecraft's
antennas see no ground and the paper's weighting-free model is the one its figures were measured with.

A default is applied only to what the user did not set: `systems` None and `signals` the default GPS L1/L2, and
noise.weighting "none" (the settings' default); `platform_defaults: false` switches it off. The table is data:
the job type lists it in its config schema (/v1/job-types, "x-platform-defaults"); it lives in
gnssatt.attitude.settings, which the service may import without the numerics.
"""
from __future__ import annotations

from dataclasses import replace

from gnssatt.attitude.settings import PLATFORM_DEFAULTS, AttitudeSettings

__all__ = ["PLATFORM_DEFAULTS", "apply_platform_defaults"]

DEFAULT_SIGNALS = ["L1", "L2"]
TERRESTRIAL_SYSTEMS = ("G", "E", "C", "J", "R")

GLONASS_MIXED_REASON = ("GLONASS left out: the antennas' receivers are of different models ({models}), so their "
                        "GLONASS inter-channel biases (cm-level per frequency channel) do not cancel in the single "
                        "differences and the FDMA integers could be fixed wrongly; same-model receivers have none")


def _receiver_models(obs_by_antenna: dict) -> set[str]:
    """The receiver types (REC # / TYPE / VERS) of the files, blank ones left out."""
    out = set()
    for o in obs_by_antenna.values():
        rt = getattr(getattr(o, "header", None), "receiver_type", None)
        if rt and rt.strip():
            out.add(rt.strip().upper())
    return out


def _systems_in_files(obs_by_antenna: dict) -> list[str]:
    """The systems of TERRESTRIAL_SYSTEMS with at least one satellite in every antenna's observation file."""
    out = []
    for x in TERRESTRIAL_SYSTEMS:
        if obs_by_antenna and all(any(s[0] == x for s in o.sats) for o in obs_by_antenna.values()):
            out.append(x)
    return out


def apply_platform_defaults(settings: AttitudeSettings, kind: str, obs_by_antenna: dict
                            ) -> tuple[AttitudeSettings, list[dict]]:
    """(settings with the platform kind's defaults applied where the user left the setting as it was, the defaults
    applied as [{"setting", "value", "reason"}]); unchanged when settings.platform_defaults is False."""
    if not settings.platform_defaults or kind != "terrestrial":
        return settings, []
    applied = []
    out = settings
    table = PLATFORM_DEFAULTS["terrestrial"]
    if out.systems is None and list(out.signals) == DEFAULT_SIGNALS:
        systems = _systems_in_files(obs_by_antenna)
        models = _receiver_models(obs_by_antenna)
        if "R" in systems and len(models) > 1:       # mixed receivers: GLONASS inter-channel biases (issue 21)
            systems = [x for x in systems if x != "R"]
            applied.append({"setting": "systems", "value": "without R",
                            "reason": GLONASS_MIXED_REASON.format(models=", ".join(sorted(models)))})
        if systems and systems != ["G"]:
            out = replace(out, systems=systems)
            applied.append({"setting": "systems", "value": systems, "reason": table["systems"]["reason"]})
    if out.noise.weighting == "none":
        out = out.override(noise={"weighting": "elevation"})
        applied.append({"setting": "noise.weighting", "value": "elevation",
                        "reason": table["noise.weighting"]["reason"]})
    return out, applied
