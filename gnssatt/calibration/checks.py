"""Campaign checks before any heavy work: a calibration is refused, with a message naming the set, rather than
silently averaging data that do not belong together.

Refused:
- a set without platform.json or without a reference attitude;
- a set of another platform: platform name, antenna ids, antenna positions (a priori, to 1 um), boresights or
  baselines differ from the campaign's first set (a different a priori would make "calibrated minus a priori"
  meaningless, and a map is per platform);
- a set whose reference attitude does not cover its observations: the reference must span the observation span
  and every step between reference rows inside it must be <= max_reference_gap_s (the fraction of epochs then
  covered is checked again after reading, against min_reference_coverage);
- sets overlapping in time. Decision: refuse, not de-duplicate. Two sets of one platform sharing epochs are a
  duplicated or re-cut upload; averaging both counts the same errors twice (and the batch-means sigma would
  treat them as independent). Which copy to keep is the user's call; the message names both sets and the
  overlap. Sets that only touch (one ends where the next begins) are accepted.

Implements: issue 8 "Done when" (refusals); CONVENTIONS.md platform.json and reference attitude formats.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnssatt.gnss.time import GpsTime

POSITION_TOLERANCE_M = 1e-6


class CampaignError(Exception):
    """A campaign that cannot be calibrated; `set_label` names the set at fault (and `file` the file).
    `about_sets` is False when the refusal is about what the sets gave together (no usable epoch), not about
    the choice of sets."""

    def __init__(self, title: str, detail: str, set_label: str | None = None, file: str | None = None,
                 about_sets: bool = True):
        super().__init__(detail)
        self.title = title
        self.detail = detail
        self.set_label = set_label
        self.file = file
        self.about_sets = about_sets


@dataclass
class SetInfo:
    """What the checks need of one set, from the upload summaries and platform.json (no RINEX parsing)."""

    id: str
    label: str
    platform: dict | None  # platform.json as parsed JSON
    obs_first: GpsTime | None
    obs_last: GpsTime | None
    reference_file: str | None
    reference_times: GpsTime | None = None  # rows of the reference attitude (parsed when checking coverage)
    notes: list = field(default_factory=list)


def platform_signature(doc: dict) -> dict:
    """The parts of a platform.json that must agree across a campaign (name, antennas, baselines)."""
    ants = doc.get("antennas") or {}
    master = doc.get("master") or (sorted(ants)[0] if ants else None)
    baselines = doc.get("baselines") or [[master, a] for a in ants if a != master]
    return {"name": doc.get("name", "unnamed platform"), "antennas": sorted(ants),
            "positions": {a: np.asarray(v.get("position_m", [np.nan] * 3), float) for a, v in ants.items()},
            "boresights": {a: np.asarray(v.get("boresight", [0, 0, -1]), float) for a, v in ants.items()},
            "baselines": [tuple(b) for b in baselines]}


def _platform_difference(a: dict, b: dict) -> str | None:
    if a["name"] != b["name"]:
        return f'platform name {b["name"]!r} instead of {a["name"]!r}'
    if a["antennas"] != b["antennas"]:
        return f"antennas {b['antennas']} instead of {a['antennas']}"
    for ant in a["antennas"]:
        d = np.abs(a["positions"][ant] - b["positions"][ant])
        if not np.all(d <= POSITION_TOLERANCE_M):
            return (f"a priori position of {ant} {b['positions'][ant].tolist()} m instead of "
                    f"{a['positions'][ant].tolist()} m")
        ba, bb = a["boresights"][ant], b["boresights"][ant]
        if not np.allclose(ba / np.linalg.norm(ba), bb / np.linalg.norm(bb), atol=1e-9):
            return f"boresight of {ant} {bb.tolist()} instead of {ba.tolist()}"
    if a["baselines"] != b["baselines"]:
        return f"baselines {b['baselines']} instead of {a['baselines']}"
    return None


def reference_gaps(ref_times: GpsTime, first: GpsTime, last: GpsTime, max_gap_s: float) -> list[tuple[str, str, float]]:
    """(start ISO, end ISO, length s) of the spans of [first, last] the reference rows do not cover: before its
    first row, after its last, and steps longer than max_gap_s between rows inside the span."""
    out = []
    if len(ref_times) == 0:
        return [(first.iso(), last.iso(), float(last - first))]
    if float(ref_times[0] - first) > 0:
        out.append((first.iso(), ref_times[0].iso(), float(ref_times[0] - first)))
    steps = np.diff(ref_times.s).astype(np.float64) + np.diff(ref_times.frac)
    for k in np.flatnonzero(steps > max_gap_s):
        a, b = ref_times[int(k)], ref_times[int(k) + 1]
        if float(b - first) > 0 and float(last - a) > 0:
            out.append((a.iso(), b.iso(), float(steps[k])))
    if float(last - ref_times[-1]) > 0:
        out.append((ref_times[-1].iso(), last.iso(), float(last - ref_times[-1])))
    return out


def check_campaign(infos: list[SetInfo], *, max_reference_gap_s: float, held_out: str | None = None) -> list[str]:
    """Notes (strings) about an acceptable campaign; raises CampaignError for the refusals of the module doc."""
    if not infos:
        raise CampaignError("No observation sets", "a calibration campaign needs observation sets")
    sig0 = None
    for info in infos:
        if info.platform is None:
            raise CampaignError("Set without platform.json", f"set {info.label!r} has no platform.json",
                                set_label=info.label)
        if info.reference_file is None:
            raise CampaignError("Set without reference attitude",
                                f"set {info.label!r} has no reference attitude (CSV time_gps,frame,qw,qx,qy,qz); "
                                "calibration rotates baselines into the body frame with it", set_label=info.label)
        if info.obs_first is None or info.obs_last is None:
            raise CampaignError("Set without observations", f"set {info.label!r} has no RINEX observations",
                                set_label=info.label)
        sig = platform_signature(info.platform)
        if sig0 is None:
            sig0 = sig
            first_label = info.label
        else:
            diff = _platform_difference(sig0, sig)
            if diff:
                raise CampaignError("Set of another platform",
                                    f"set {info.label!r} does not belong to the campaign's platform (set "
                                    f"{first_label!r}): {diff}", set_label=info.label)
        if info.reference_times is not None:
            gaps = reference_gaps(info.reference_times, info.obs_first, info.obs_last, max_reference_gap_s)
            if gaps:
                shown = "; ".join(f"{a} to {b} ({s:.1f} s)" for a, b, s in gaps[:5])
                raise CampaignError("Reference attitude does not cover the observations",
                                    f"set {info.label!r}: its reference attitude ({info.reference_file}) leaves "
                                    f"{len(gaps)} span(s) of the observations {info.obs_first.iso()} to "
                                    f"{info.obs_last.iso()} uncovered (gaps over {max_reference_gap_s:g} s): "
                                    f"{shown}", set_label=info.label, file=info.reference_file)
    order = sorted(range(len(infos)), key=lambda i: (int(infos[i].obs_first.s), float(infos[i].obs_first.frac)))
    for prev, cur in zip(order, order[1:]):
        a, b = infos[prev], infos[cur]
        overlap = float(a.obs_last - b.obs_first)
        if overlap > 0:
            raise CampaignError("Sets overlap in time",
                                f"sets {a.label!r} ({a.obs_first.iso()} to {a.obs_last.iso()}) and {b.label!r} "
                                f"({b.obs_first.iso()} to {b.obs_last.iso()}) overlap by {overlap:.1f} s; the same "
                                "epochs would be averaged twice. Remove one of them or trim them apart.",
                                set_label=b.label)
    notes = []
    if held_out is not None:
        labels = {i.id for i in infos} | {i.label for i in infos}
        if held_out not in labels:
            raise CampaignError("Unknown held-out set", f"held_out_set {held_out!r} is not one of the campaign's "
                                f"sets ({sorted(i.label for i in infos)})")
        if len(infos) < 2:
            raise CampaignError("Nothing left to calibrate", "the only set of the campaign is the held-out set")
    return notes


__all__ = ["CampaignError", "SetInfo", "platform_signature", "reference_gaps", "check_campaign"]
