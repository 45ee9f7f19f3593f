"""Calibration campaigns (seed 000 sec. 3): in-flight antenna baselines and differential phase-centre-variation
maps from many observation sets with a reference attitude. Pure numpy/scipy/erfa (no web imports).

Modules: reference (reference attitude at epochs: slerp, gaps, frames), baselines (body-frame averaging with
batch-means sigma, Table 3 products), binning (generic 2-D bins with count/sigma/min-count), pcv (residuals,
linear map statistics, iteration), kinematic (reference-aided integer fixing and epoch-wise baselines), extract
(the one adapter from an observation set to fixed phases), checks (campaign refusals), campaign (per-set tasks
and the reduction).
"""
