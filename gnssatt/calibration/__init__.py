"""Calibration campaigns (seed 000 sec. 3): in-flight antenna baselines and differential phase-centre-variation
maps from many observation sets with a reference attitude. Pure numpy/scipy/erfa (no web imports).

Modules: api (run_campaign: the whole campaign in one call -> CampaignResult), reference (reference attitude at
epochs: slerp, gaps, frames), baselines (body-frame averaging with batch-means sigma, Table 3 products), binning
(generic 2-D bins with count/sigma/min-count), pcv (residuals, linear map statistics, iteration), kinematic
(reference-aided integer fixing and epoch-wise baselines), extract (the one adapter from an observation set to
fixed phases), checks (campaign refusals), campaign (per-set passes and the reductions), tasks (one fan-out task:
a set's pass with its checks, as a picklable result), held_out (the held-out set through the attitude filter),
products (the job's files from a CampaignResult).
"""
from gnssatt._lazy import lazy_exports

#: public entry point (imported on first use): run_campaign(sets, platform, options, ...) -> CampaignResult, and
#: result.write_products(out_dir); see gnssatt.calibration.api and docs/library.md
_EXPORTS = {"run_campaign": "api", "CampaignResult": "api", "CampaignOptions": "campaign",
            "HeldOutAttitude": "held_out", "CampaignError": "checks"}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
