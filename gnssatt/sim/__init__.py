"""Truth simulator: realistic multi-antenna GNSS observation sets with exactly known attitude.

Public API: `simulate_set(scenario, out_dir, *, seed=0, **params) -> SimulatedSet` (one set, its files and truth;
gnssatt.sim.api), `simulate_scenario(scenario, out_dir, *, seed=0, overrides=None, progress=None) -> SimResult`,
`list_scenarios() -> dict[str, dict]`, the parameter dataclasses in `gnssatt.sim.scenarios`.
"""
from gnssatt.sim.scenarios import PRESETS, SimParams, list_scenarios, make_params
from gnssatt.sim.simulate import SimResult, simulate_scenario
from gnssatt.sim.api import SimulatedSet, simulate_set

__all__ = ["simulate_set", "SimulatedSet", "simulate_scenario", "list_scenarios", "SimResult", "SimParams", "PRESETS",
           "make_params"]
