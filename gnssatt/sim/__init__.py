"""Truth simulator: realistic multi-antenna GNSS observation sets with exactly known attitude.

Public API: `simulate_scenario(scenario, out_dir, *, seed=0, overrides=None, progress=None) -> SimResult`,
`list_scenarios() -> dict[str, dict]`, the parameter dataclasses in `gnssatt.sim.scenarios`.
"""
from gnssatt.sim.scenarios import PRESETS, SimParams, list_scenarios, make_params
from gnssatt.sim.simulate import SimResult, simulate_scenario

__all__ = ["simulate_scenario", "list_scenarios", "SimResult", "SimParams", "PRESETS", "make_params"]
