"""What the API (app/) and the worker (worker/) share: settings and persistence.

`settings` (GNSSATT_* environment), `db` (engine, sessions), `models` (the tables), `migrate` (Alembic at
start-up), `blobs` (the content-addressed file store) and `pcv_store` (keeping a PCV map as a blob and a row).
Both processes import this package; it imports neither of them (tests/test_import_boundaries.py).
"""
