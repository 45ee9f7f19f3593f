"""Mutated real files through the real upload path (uvicorn subprocess): RINEX 2/3 observation and navigation,
Hatanaka, SP3, ANTEX, reference attitude CSV and platform.json from ../shared/data, with bytes flipped, lines
cut, repeated or stretched, numbers replaced by extremes, NUL bytes, compression layers added. Every answer is
201 or a 4xx problem document (never a 5xx), each within 10 s, and the API's resident memory stays under 250 MB
throughout. On both backends (SQLite + Huey, PostgreSQL + Redis). The run is seeded and bounded: 15 s of
uploads (about 30 s in all per backend)."""
from __future__ import annotations

import bz2
import gzip
import json
import random
import re
import threading
import time
from pathlib import Path

import psutil
import pytest

from bench.real_sets import REAL_DATA_DIR
from gnssatt.sim.sample_set import platform_doc
from tests.conftest import missing

pytestmark = pytest.mark.e2e

THIRD_PARTY = REAL_DATA_DIR.parent / "third_party" / "files"
SEEDS = [
    REAL_DATA_DIR / "geonet_0759_3040_3km_2005" / "07590920.05o",
    REAL_DATA_DIR / "geonet_0759_3040_3km_2005" / "07590920.05n",
    REAL_DATA_DIR / "leo_grace_a_2007080" / "GRAA_07_080.sp3.gz",
    REAL_DATA_DIR / "leo_grace_a_2007080" / "brdc0800.07n.gz",
    THIRD_PARTY / "georust+rinex" / "test_resources" / "OBS" / "V3" / "VLNS0630.22O",
    THIRD_PARTY / "georust+rinex" / "test_resources" / "OBS" / "V2" / "zegv0010.21o",
    THIRD_PARTY / "georust+rinex" / "test_resources" / "SP3" / "emr08874.sp3",
    THIRD_PARTY / "georust+rinex" / "test_resources" / "CRNX" / "V1" / "npaz3550.21d",
    THIRD_PARTY / "georust+rinex" / "test_resources" / "ATX" / "V1" / "TROSAR25.R4__LEIT_2020_09_23.atx",
]
BUDGET_S = 15.0
MAX_REQUEST_S = 10.0
MAX_RSS_MB = 250.0


def _plain(path: Path) -> bytes:
    data = path.read_bytes()
    return gzip.decompress(data) if data[:2] == b"\x1f\x8b" else data


def _reference_csv() -> bytes:
    rows = [f"2024-06-24T08:{i // 60:02d}:{i % 60:02d}.000,GCRF,1,0,0,0" for i in range(600)]
    return ("time_gps,frame,qw,qx,qy,qz\n" + "\n".join(rows) + "\n").encode()


_NUMBER = re.compile(rb"-?\d+\.\d+(?:[eEdD][-+]?\d+)?")
EXTREMES = [b"1.0e+300", b"-1e308", b"nan", b"inf", b"99999999999999999999", b"1.00000e+18", b"-0", b""]


def _mutate_text(rng: random.Random, data: bytes) -> bytes:
    lines = data.split(b"\n")
    kind = rng.randrange(10)
    if kind == 0:  # flip bytes
        buf = bytearray(data)
        for _ in range(rng.randint(1, 20)):
            buf[rng.randrange(len(buf))] = rng.randrange(256)
        return bytes(buf)
    if kind == 1:  # truncate
        return data[: rng.randrange(len(data))]
    if kind == 2:  # repeat a line
        i = rng.randrange(len(lines))
        return b"\n".join(lines[:i] + [lines[i]] * rng.randint(2, 3000) + lines[i:])
    if kind == 3:  # stretch a line
        i = rng.randrange(len(lines))
        lines[i] = lines[i] + b"x" * rng.choice([100, 5000, 200_000])
        return b"\n".join(lines)
    if kind == 4:  # NUL somewhere after the first 4 KB
        at = rng.randrange(min(len(data), 4096), len(data)) if len(data) > 4096 else rng.randrange(len(data))
        return data[:at] + b"\x00" + data[at:]
    if kind == 5:  # extreme numbers
        matches = list(_NUMBER.finditer(data))
        if not matches:
            return data
        m = rng.choice(matches)
        value = rng.choice(EXTREMES).rjust(len(m.group()))[-max(len(m.group()), 1):]
        return data[:m.start()] + value + data[m.end():]
    if kind == 6:  # delete lines
        i = rng.randrange(len(lines))
        return b"\n".join(lines[:i] + lines[i + rng.randint(1, 50):])
    if kind == 7:  # blank a line (e.g. an empty satellite record)
        lines[rng.randrange(len(lines))] = b""
        return b"\n".join(lines)
    if kind == 8:  # shuffle a block
        i = rng.randrange(len(lines))
        block = lines[i:i + 20]
        rng.shuffle(block)
        return b"\n".join(lines[:i] + block + lines[i + 20:])
    return data.replace(b"\n", b"\r\n") if rng.random() < 0.5 else data.upper()


def _mutate_json(rng: random.Random, doc) -> bytes:
    doc = json.loads(json.dumps(doc))
    choices = [["x"], [["GPS-2"], ["GPS-0"]], 1e308, -1e308, None, "", {}, [], 7, "GPS-2", True, "x" * 400]
    for _ in range(rng.randint(1, 4)):
        target = doc
        path = []
        while isinstance(target, (dict, list)) and target and rng.random() < 0.7:
            key = rng.choice(list(target)) if isinstance(target, dict) else rng.randrange(len(target))
            path.append((target, key))
            target = target[key]
        if path:
            parent, key = path[-1]
            parent[key] = rng.choice(choices)
    text = json.dumps(doc)
    if rng.random() < 0.2:
        text = text[: rng.randrange(len(text))]
    if rng.random() < 0.1:
        text = "[" * rng.choice([50, 5000, 100_000]) + text
    return text.encode()


def _case(rng: random.Random, seeds: list[tuple[str, bytes]]) -> tuple[str, bytes]:
    pick = rng.randrange(len(seeds) + 2)
    if pick == len(seeds):
        return "platform.json", _mutate_json(rng, platform_doc())
    if pick == len(seeds) + 1:
        return "reference.csv", _mutate_text(rng, _reference_csv())
    name, data = seeds[pick]
    data = _mutate_text(rng, data)
    layer = rng.randrange(6)
    if layer == 0:
        return name + ".gz", gzip.compress(data, compresslevel=1)
    if layer == 1:
        return name + ".bz2", bz2.compress(data, compresslevel=1)
    return name, data


class _RssSampler(threading.Thread):
    def __init__(self, pid: int):
        super().__init__(daemon=True)
        self.proc = psutil.Process(pid)
        self.peak_mb = 0.0
        self.stop = threading.Event()

    def run(self) -> None:
        while not self.stop.wait(0.05):
            try:
                self.peak_mb = max(self.peak_mb, self.proc.memory_info().rss / 2**20)
            except psutil.Error:
                return


def test_mutated_real_files_get_201_or_4xx_in_bounded_time_and_memory(service, tmp_path):
    absent = [p for p in SEEDS if not p.is_file()]
    if absent:
        missing(f"fuzz seed files not found: {[str(p) for p in absent]}")
    seeds = [(p.name.removesuffix(".gz"), _plain(p)) for p in SEEDS]
    svc = service
    rng = random.Random(20261202)
    statuses: dict[int, int] = {}
    svc.start_api()
    key = svc.create_key("fuzz")
    sampler = _RssSampler(svc.api.pid)
    sampler.start()
    start = time.monotonic()
    slowest = 0.0
    with svc.client(key) as c:
        while time.monotonic() - start < BUDGET_S:
            name, data = _case(rng, seeds)
            t0 = time.monotonic()
            resp = c.post("/v1/observation-sets", files=[("files", (name, data, "application/octet-stream"))],
                          timeout=MAX_REQUEST_S + 20)
            took = time.monotonic() - t0
            slowest = max(slowest, took)
            statuses[resp.status_code] = statuses.get(resp.status_code, 0) + 1
            assert resp.status_code == 201 or 400 <= resp.status_code < 500, (name, resp.status_code,
                                                                               resp.text[:400])
            if resp.status_code != 201:
                assert resp.headers["content-type"].startswith("application/problem+json")
                assert "Traceback" not in resp.text
            assert took < MAX_REQUEST_S, f"{name}: {took:.1f} s"
    sampler.stop.set()
    sampler.join(timeout=2)
    n = sum(statuses.values())
    print(f"fuzz: {n} uploads in {BUDGET_S:g} s, statuses {statuses}, slowest {slowest:.2f} s, "
          f"API peak RSS {sampler.peak_mb:.0f} MB")
    assert n >= 30, statuses
    assert sampler.peak_mb < MAX_RSS_MB
    staging = [p for p in (tmp_path / "var" / "staging").rglob("*")]
    assert not staging, f"a rejected upload left {staging[:3]} in staging"
