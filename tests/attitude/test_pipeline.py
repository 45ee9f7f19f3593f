"""The attitude job through its plug-in: registry entry, config validation, pipeline run(ctx, config) on a
JobContext like the runner builds, products written, input errors as JobInputError."""
from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest
from pydantic import ValidationError

from tests.attitude.conftest import set_files
from worker.context import InputFile, InputSet, JobContext
from worker.errors import JobInputError
from worker.jobs.attitude import AttitudeConfig
from worker.jobs.registry import job_types


def _ctx(tmp_path, files):
    def store(path):
        data = path.read_bytes()
        return hashlib.sha256(data).hexdigest(), len(data)

    s = InputSet(id="set-1", name="sim", files=[InputFile(n, k, p, {}) for n, k, p in files], summary={})
    ctx = JobContext(job_id="job-1", attempt=1, sets=[s], workdir=tmp_path, _store_blob=store)
    calls = []
    ctx._flush_progress = lambda f, stage: calls.append((f, stage))
    ctx.progress_interval_s = 0.0
    return ctx, calls


def test_registry_and_config():
    jt = job_types()["attitude"]
    assert jt.pipeline == "worker.pipelines.attitude:run" and jt.min_sets == 1 and jt.max_sets == 1
    cfg = AttitudeConfig()
    st = cfg.to_settings()
    assert st.mode == "dynamic" and st.table2.cn0_mask_dbhz == {"L1": 35.0, "L2": 30.0} and st.table2.elevation_mask_antenna_deg == 0.0 and st.table1.sigma_phase_m == 0.003
    with pytest.raises(ValidationError):
        AttitudeConfig(signals=["L5"])
    with pytest.raises(ValidationError):
        AttitudeConfig(mode="static")
    cal = AttitudeConfig(calibrated_baselines={"platform": "x", "frames": "body", "baselines": [
        {"from": "GPS-2", "to": "GPS-0", "a_priori_m": [1, 0, 0], "calibrated_m": [1.001, 0, 0]}]}).to_settings()
    assert cal.calibration.calibrated_baselines[("GPS-2", "GPS-0")] == [1.001, 0, 0]


def test_pipeline_writes_products(tmp_path, clean_pass):
    from worker.pipelines.attitude import run

    ctx, calls = _ctx(tmp_path, set_files(clean_pass))
    run(ctx, AttitudeConfig(mode="kinematic"))
    assert {"attitude.csv", "baselines.csv", "residuals.csv", "events.csv", "summary.json",
            "attitude.aem"} <= set(ctx.products)
    summary = json.loads((tmp_path / "products" / "summary.json").read_text())
    assert summary["observation_set_id"] == "set-1" and summary["fix_rate"] > 0.9
    fractions = [f for f, _ in calls]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0 and len(calls) > 5


def test_pipeline_without_platform_is_an_input_error(tmp_path, clean_pass):
    from worker.pipelines.attitude import run

    files = [f for f in set_files(clean_pass) if f[1] != "platform"]
    ctx, _ = _ctx(tmp_path, files)
    with pytest.raises(JobInputError) as exc:
        run(ctx, AttitudeConfig())
    assert exc.value.field == "platform"


def test_pipeline_cancellation_happens_at_progress(tmp_path, clean_pass):
    from worker.errors import JobCancelled
    from worker.pipelines.attitude import run

    ctx, _ = _ctx(tmp_path, set_files(clean_pass))
    ctx.cancel_requested.set()
    with pytest.raises(JobCancelled):
        run(ctx, AttitudeConfig())


def test_product_tables_are_the_csv_products_as_columns(clean_pass):
    """The plots are drawn from product_tables (no re-parsing of residuals.csv): same columns, rows, names and
    times as the CSV texts read back, numbers equal to the texts' rounding, empty cells where NaN."""
    from tests.attitude.conftest import set_files
    from gnssatt.attitude.process import load_inputs, process
    from gnssatt.attitude.products import all_products, product_tables
    from gnssatt.plots.common import gps_time, read_csv_table

    sol = process(load_inputs(set_files(clean_pass)), AttitudeConfig(mode="kinematic").to_settings())
    texts, tables = all_products(sol), product_tables(sol)
    assert set(tables) == {"attitude.csv", "baselines.csv", "residuals.csv"}
    for name, table in tables.items():
        csv = read_csv_table(texts[name])
        assert list(table) == list(csv), name
        assert len(csv["time_gps"]) > 100
        assert np.array_equal(gps_time(table), gps_time(csv)), name
        for col, values in table.items():
            if col == "time_gps":
                continue
            if csv[col].dtype.kind == "f":
                assert values.dtype.kind == "f", (name, col)
                assert np.array_equal(np.isnan(values), np.isnan(csv[col])), (name, col)
                ok = np.isfinite(values)
                assert np.allclose(values[ok], csv[col][ok], rtol=0, atol=0.051), (name, col)
            else:
                assert values.tolist() == csv[col].tolist(), (name, col)
