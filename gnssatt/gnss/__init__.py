"""GNSS science: pure functions and small classes over numpy arrays.

Conventions for every module below this package:
- xyz is the last axis, shape (..., 3), as in ERFA.
- Units are in names (`position_m`, `tow_s`), frames in names of vectors and rotations
  (`r_sat_ecef_m`, `R_body_from_ecef`, `q_body_from_gcrf`), written target_from_source.
- Frames, quaternions, Euler angles and time follow ../shared/CONVENTIONS.md exactly.
- Nothing here imports the web side (fastapi, sqlalchemy, huey, app): tests/test_import_boundaries.py checks it.
"""
