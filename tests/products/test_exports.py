"""Issue 24 done-when: AEM and HDT exports fit for flight dynamics: the AEM's useable span covers fixed epochs only
(float epochs left out or in a segment of their own), a real CREATION_DATE, quaternion sign continuity, parsed by
ccsds-ndm; NMEA HDT only where fixed."""
from __future__ import annotations

import csv
import io
from types import SimpleNamespace

import numpy as np
import pytest

from gnssatt.attitude.products import aem_kvn, nmea_hdt, sign_continuous


def _segments(text: str) -> list[tuple[dict, list[list[str]]]]:
    out, meta, data, where = [], {}, [], None
    for line in text.splitlines():
        s = line.strip()
        if s == "META_START":
            meta, data, where = {}, [], "meta"
        elif s == "META_STOP":
            where = None
        elif s == "DATA_START":
            where = "data"
        elif s == "DATA_STOP":
            out.append((meta, data))
            where = None
        elif where == "meta" and "=" in s and not s.startswith("COMMENT"):
            k, v = (x.strip() for x in s.split("=", 1))
            meta[k] = v
        elif where == "data" and s:
            data.append(s.split())
    return out


def test_aem_holds_fixed_epochs_only_and_parses(short_pass):
    from ccsds_ndm.ndm_io import NdmIo

    prods, sol = short_pass["products"], short_pass["sol"]
    text = prods["attitude.aem"]
    assert "CREATION_DATE = 2026-12-02T05:00:00" in text and "2000-01-01" not in text
    att = list(csv.DictReader(io.StringIO(prods["attitude.csv"])))
    fixed_times = [r["time_gps"] for r in att if r["fixed"] == "1"]
    assert 0 < len(fixed_times) < len(att), "the pass must have float epochs for this test to mean anything"
    (meta, data), = _segments(text)
    assert meta["USEABLE_START_TIME"] == fixed_times[0] == meta["START_TIME"]
    assert meta["USEABLE_STOP_TIME"] == fixed_times[-1] == meta["STOP_TIME"]
    assert [d[0] for d in data] == fixed_times
    q = np.array([[float(v) for v in d[1:5]] for d in data])
    assert np.all(np.sum(q[1:] * q[:-1], axis=1) >= 0), "sign flip between consecutive epochs"
    # each row is attitude.csv's GCRF quaternion up to the sign
    qi = np.array([[float(r[f"qi_{c}"]) for c in "wxyz"] for r in att if r["fixed"] == "1"])
    assert np.allclose(np.abs(np.sum(q * qi, axis=1)), 1.0, atol=1e-9)
    aem = NdmIo().from_string(text)
    assert type(aem).__name__.lower().startswith("aem")
    segs = aem.body.segment
    assert len(segs) == 1
    assert len(segs[0].data.attitude_state) == len(fixed_times)


def test_aem_float_segment_option(short_pass):
    from ccsds_ndm.ndm_io import NdmIo

    sol = short_pass["sol"]
    text = aem_kvn(sol, creation_date="2026-12-02T05:00:00", float_epochs="segment")
    segs = _segments(text)
    assert len(segs) == 2
    (m1, d1), (m2, d2) = segs
    assert "USEABLE_START_TIME" in m1 and "USEABLE_START_TIME" not in m2
    assert len(d1) == int(sol.att_fixed.sum()) and len(d2) == int((~sol.att_fixed).sum())
    assert "FLOAT epochs" in text
    assert len(NdmIo().from_string(text).body.segment) == 2
    with pytest.raises(ValueError, match="float_epochs"):
        aem_kvn(sol, float_epochs="keep")


def test_aem_creation_date_defaults_to_now(short_pass):
    import datetime as dt

    text = aem_kvn(short_pass["sol"])
    stamp = next(l for l in text.splitlines() if l.startswith("CREATION_DATE")).split("=")[1].strip()
    t = dt.datetime.fromisoformat(stamp).replace(tzinfo=dt.timezone.utc)
    assert abs((dt.datetime.now(dt.timezone.utc) - t).total_seconds()) < 120


def test_sign_continuity_removes_flips():
    rng = np.random.default_rng(3)
    q = np.cumsum(rng.normal(0, 0.02, (200, 4)), axis=0) + [1, 0, 0, 0]
    q /= np.linalg.norm(q, axis=1)[:, None]
    flips = rng.random(200) < 0.3
    flipped = np.where(flips[:, None], -q, q)
    assert np.any(np.sum(flipped[1:] * flipped[:-1], axis=1) < 0)
    out = sign_continuous(flipped)
    assert np.all(np.sum(out[1:] * out[:-1], axis=1) >= 0)
    assert np.allclose(np.abs(out), np.abs(q))
    assert np.array_equal(out[0], flipped[0])             # the first row keeps its sign


def _terrestrial(fixed: list[bool], one_baseline: bool):
    n = len(fixed)
    yaw = np.linspace(10.0, 20.0, n)
    bt = {"epoch": np.arange(n), "bl": np.zeros(n, int), "azimuth_deg": yaw + 30.0, "fixed": np.array(fixed)}
    return SimpleNamespace(
        inputs=SimpleNamespace(platform=SimpleNamespace(kind="terrestrial")), baseline_table=bt,
        body_baselines_m=np.array([[np.cos(np.radians(30.0)), np.sin(np.radians(30.0)), 0.0]]),
        att_epochs=None if one_baseline else np.arange(n), att_fixed=np.array(fixed),
        euler_deg=np.stack([yaw, 0 * yaw, 0 * yaw], 1)), yaw


@pytest.mark.parametrize("one_baseline", [True, False])
def test_hdt_only_where_fixed(one_baseline):
    fixed = [False, False, True, True, False, True]
    sol, yaw = _terrestrial(fixed, one_baseline)
    lines = [l for l in nmea_hdt(sol).split("\r\n") if l]
    assert len(lines) == sum(fixed)
    for line, expect in zip(lines, yaw[np.array(fixed)]):
        body, ck = line[1:].split("*")
        x = 0
        for ch in body:
            x ^= ord(ch)
        assert int(ck, 16) == x
        assert abs(float(body.split(",")[1]) - expect) < 1e-3      # 3 decimals written
    none_fixed, _ = _terrestrial([False] * 4, one_baseline)
    assert nmea_hdt(none_fixed) is None
