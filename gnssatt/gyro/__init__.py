"""GPS + MEMS gyro attitude with autonomous fault detection and isolation (seed 002).

Modules, one idea each: gyro_csv (the gyro log reader), settings (Table 1 models and the FDI control parameters),
snapshot (double-difference snapshot attitude, eq. 1-2), exclusion_bank (the per-satellite processors and the
threshold mu + kappa sigma, sec. 3.1), ekf (the multiplicative quaternion EKF, sec. 2.2), propagators (the bank
of delayed attitude propagators, sec. 3.2), fusion (the run over a pass), products (the job's files), truth
(scoring against the simulator's truth) and api (`fuse`, the entry point).
"""
from gnssatt._lazy import lazy_exports

#: public entry point (imported on first use): fuse(files, settings) -> FusionResult; result.write_products(dir)
_EXPORTS = {"fuse": "api", "FusionResult": "api", "FusionSettings": "settings", "read_gyro_csv": "gyro_csv",
            "GyroLog": "gyro_csv"}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
