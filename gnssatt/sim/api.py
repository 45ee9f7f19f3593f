"""The simulator in one call: `simulate_set(scenario, out_dir, seed=0, **params)` writes one simulated observation
set (gnssatt.sim.simulate_scenario with `params` as its overrides) and returns where its files and truth are, ready
for gnssatt.attitude.solve. See docs/library.md and docs/simulator.md.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from gnssatt.sim.simulate import simulate_scenario

__all__ = ["SimulatedSet", "simulate_set"]


@dataclass(frozen=True)
class SimulatedSet:
    """The files of one simulated set: what a user would upload (`files`) and the truth beside them."""

    dir: Path                                  # the set's folder (truth_dir, attitude_errors_deg take it)
    obs: dict[str, Path]                       # antenna id -> RINEX observation file
    nav: Path                                  # RINEX navigation file (broadcast GPS)
    platform: Path                             # platform.json
    reference_attitude: Path                   # reference attitude (star-camera-like, noisy truth)
    truth_dir: Path                            # truth/: attitude.csv, arcs.csv, receivers.csv, model.json
    platform_sp3: Path | None = None           # SP3 of the platform's centre of mass (when written)
    summary: dict = field(default_factory=dict)

    @property
    def files(self) -> list[Path]:
        """The observation set as the service takes it: obs files, nav, platform.json (and the platform SP3)."""
        return [*self.obs.values(), self.nav, self.platform] + ([self.platform_sp3] if self.platform_sp3 else [])


def simulate_set(scenario: str, out_dir: str | Path, *, seed: int = 0,
                 progress: Callable[[float, str], None] | None = None, **params) -> SimulatedSet:
    """Simulate one set of preset `scenario` (gnssatt.sim.list_scenarios) into out_dir.

    `params` override the preset's parameters by name (gnssatt.sim.scenarios.SimParams: duration_s, interval_s,
    start_gps, ...); an unknown name is a ValueError naming it. Same seed and parameters -> identical files.
    For several passes (count > 1) use simulate_scenario, which writes out_dir/pass_NNN/.
    """
    if int(params.get("count", 1)) != 1:
        raise ValueError("simulate_set writes one set (count 1); use gnssatt.sim.simulate_scenario for more")
    result = simulate_scenario(scenario, Path(out_dir), seed=seed, overrides=params or None, progress=progress)
    one = result.sets[0]
    files = one["files"]
    return SimulatedSet(dir=Path(one["dir"]), obs={a: Path(p) for a, p in files["obs"].items()},
                        nav=Path(files["nav"]), platform=Path(files["platform_json"]),
                        reference_attitude=Path(files["reference_attitude"]), truth_dir=Path(files["truth_dir"]),
                        platform_sp3=Path(files["sp3"]) if "sp3" in files else None, summary=one["summary"])
