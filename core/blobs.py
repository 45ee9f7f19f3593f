"""Content-addressed file store: every upload and product lives at blobs/ab/cd/<sha256>.

A blob is written to a temp file in the same directory tree, fsynced, then renamed into place, and the
directory fsynced, so a crash leaves either no blob or a whole one, never half a file under its name.
"""
from __future__ import annotations

import fcntl
import hashlib
import os
import shutil
import tempfile
import threading
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO, Iterator

CHUNK_BYTES = 1024 * 1024


class BlobStore:
    def __init__(self, root: Path):
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        self._held = threading.local()  # this thread's depth of shared holds (lock() is re-entrant for them)

    def path(self, sha256: str) -> Path:
        if len(sha256) != 64 or any(c not in "0123456789abcdef" for c in sha256):
            raise ValueError(f"not a sha256 hex digest: {sha256!r}")
        return self.root / sha256[:2] / sha256[2:4] / sha256

    def exists(self, sha256: str) -> bool:
        return self.path(sha256).is_file()

    def put_stream(self, stream: BinaryIO) -> tuple[str, int]:
        """Store everything read from `stream`; returns (sha256, size_bytes)."""
        tmp_dir = self.root / "tmp"
        tmp_dir.mkdir(exist_ok=True)
        digest = hashlib.sha256()
        size = 0
        fd, tmp_name = tempfile.mkstemp(dir=tmp_dir, prefix="blob-")
        try:
            with os.fdopen(fd, "wb") as out:
                while chunk := stream.read(CHUNK_BYTES):
                    digest.update(chunk)
                    out.write(chunk)
                    size += len(chunk)
                out.flush()
                os.fsync(out.fileno())
            return self._commit(Path(tmp_name), digest.hexdigest()), size
        except BaseException:
            Path(tmp_name).unlink(missing_ok=True)
            raise

    def put_file(self, src: Path, sha256: str | None = None) -> tuple[str, int]:
        """Store a file (moved when its digest is given and it is on the same filesystem, else copied)."""
        src = Path(src)
        if sha256 is None:
            with open(src, "rb") as fh:
                return self.put_stream(fh)
        size = src.stat().st_size
        with open(src, "rb+") as fh:
            os.fsync(fh.fileno())
        try:
            return self._commit(src, sha256), size
        except OSError:  # another filesystem: copy
            with open(src, "rb") as fh:
                return self.put_stream(fh)

    def put_bytes(self, data: bytes) -> tuple[str, int]:
        import io
        return self.put_stream(io.BytesIO(data))

    def touch(self, sha256: str) -> bool:
        """Restart a blob's grace period (under the shared lock); False when it is not there."""
        with self.lock(exclusive=False):
            try:
                os.utime(self.path(sha256))
                return True
            except FileNotFoundError:
                return False

    def adding(self):
        """Hold the shared lock from the first blob written until the rows pointing to them commit:
        `with blobs.adding(): put...; session.commit()`. The janitor reads the references and deletes under
        the exclusive lock, so it sees either no blob touched yet or the committed rows, however long the
        upload takes between its first blob and its commit."""
        return self.lock(exclusive=False)

    def _commit(self, tmp: Path, sha256: str) -> str:
        """Move `tmp` into place (or keep the copy already there) and touch it, under the store's shared lock:
        the janitor (core/janitor.py) deletes unreferenced blobs only under the exclusive lock and only when
        untouched for its grace period, so a blob about to be referenced by a new row is never removed."""
        final = self.path(sha256)
        final.parent.mkdir(parents=True, exist_ok=True)
        with self.lock(exclusive=False):
            if final.exists():
                tmp.unlink(missing_ok=True)
                os.utime(final)
            else:
                os.replace(tmp, final)
                os.utime(final)
                dir_fd = os.open(final.parent, os.O_RDONLY)
                try:
                    os.fsync(dir_fd)
                finally:
                    os.close(dir_fd)
        return sha256

    @contextmanager
    def lock(self, exclusive: bool) -> Iterator[None]:
        """The store-wide lock (flock on blobs/.lock): shared while blobs are added, exclusive while the
        janitor deletes. A shared hold inside one of the same thread takes no second flock."""
        depth = getattr(self._held, "depth", 0)
        if not exclusive and depth:
            self._held.depth = depth + 1
            try:
                yield
            finally:
                self._held.depth = depth
            return
        fd = os.open(self.root / ".lock", os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
            if not exclusive:
                self._held.depth = 1
            yield
        finally:
            if not exclusive:
                self._held.depth = 0
            os.close(fd)  # closing releases the lock

    def copy_to(self, sha256: str, dest: Path) -> Path:
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(self.path(sha256), dest)
        return dest


def sha256_file(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        while chunk := fh.read(CHUNK_BYTES):
            digest.update(chunk)
    return digest.hexdigest()
