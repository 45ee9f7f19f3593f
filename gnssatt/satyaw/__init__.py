"""GNSS satellite yaw from two transmitting antennas seen by a ground network (seed 004). Pure numpy/scipy/erfa.

Modules: attitude_models (nominal yaw steering, orbit normal, QZS-2/-4 pseudo-yaw steering, QZS-1 switching:
the reusable attitude law), triple_frequency (eq. 3-8, Table 2, Appendix A), differential (the differential
observation model and geometry), yaw_estimator (eq. 9 per epoch or as an offset, with sigma and observability),
yaw_smoother (rate-limited RTS), baseline_estimator (Table 1 baselines with the differential PCV map, Fig. 3),
mode_switch (Fig. 5, 8), orbex (IGS ORBEX ATT records), states (Sun and satellite states), inputs (satellite
descriptions with Table 1 built in, stations, RINEX -> differential rows), api (the entry points), products (job
files and plots).
"""
from gnssatt._lazy import lazy_exports

_EXPORTS = {"estimate_satellite_yaw": "api", "estimate_satellite_baseline": "api", "SatYawOptions": "api",
            "nominal_yaw_deg": "attitude_models", "model_yaw_deg": "attitude_models",
            "pseudo_yaw_steering_deg": "attitude_models", "read_orbex": "orbex", "write_orbex": "orbex",
            "SatYawInputError": "inputs"}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
