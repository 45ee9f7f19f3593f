"""The content-addressed store: a blob is whole or absent, never half written under its name."""
from __future__ import annotations

import hashlib
import io

import pytest

from core.blobs import BlobStore


class Exploding(io.BytesIO):
    def __init__(self, data: bytes, fail_after: int):
        super().__init__(data)
        self.fail_after = fail_after

    def read(self, n=-1):
        if self.tell() >= self.fail_after:
            raise OSError("disk unplugged")
        return super().read(min(n, 1000) if n and n > 0 else 1000)


def test_put_is_content_addressed_and_idempotent(tmp_path):
    store = BlobStore(tmp_path)
    data = b"RINEX" * 1000
    sha, size = store.put_bytes(data)
    assert sha == hashlib.sha256(data).hexdigest() and size == len(data)
    assert store.path(sha).read_bytes() == data
    assert store.put_bytes(data) == (sha, size)
    assert [p for p in (tmp_path / "tmp").iterdir()] == []


def test_failed_write_leaves_nothing(tmp_path):
    store = BlobStore(tmp_path)
    with pytest.raises(OSError):
        store.put_stream(Exploding(b"x" * 50_000, fail_after=20_000))
    files = [p for p in tmp_path.rglob("*") if p.is_file()]
    assert files == []


def test_path_refuses_non_digests(tmp_path):
    with pytest.raises(ValueError):
        BlobStore(tmp_path).path("../../etc/passwd")


def test_database_failure_after_blobs_stores_no_set(api, settings, monkeypatch):
    """If the transaction that records a set fails, the set does not exist (its blobs are unreferenced)."""
    from sqlalchemy.orm import Session

    from tests.api.conftest import stored_state
    from tests.api.test_observation_sets import _files, sample_items

    def boom(self):
        raise RuntimeError("database went away")

    monkeypatch.setattr(Session, "commit", boom)
    resp = api.post("/v1/observation-sets", files=_files(*sample_items()))
    monkeypatch.undo()
    assert resp.status_code == 500 and resp.headers["content-type"].startswith("application/problem+json")
    state = stored_state(settings)
    assert state["sets"] == 0 and state["files"] == 0 and state["staging"] == 0
