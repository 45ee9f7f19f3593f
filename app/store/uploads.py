"""Receiving an observation-set upload: stream the multipart body to a staging directory, never whole in
memory, within the size limit; expand .zip/.tar(.gz) bundles with guards against path tricks and bombs.

Everything lands under <data_dir>/staging/<id>/ first; the caller validates it and either moves the
files into the blob store in one go, or deletes the staging directory: nothing of a rejected upload is kept.
"""
from __future__ import annotations

import hashlib
import re
import shutil
import stat
import tarfile
import uuid
import zipfile
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

from python_multipart.multipart import MultipartParser, parse_options_header
from starlette.concurrency import run_in_threadpool
from starlette.requests import Request

from app.problems import ProblemError
from core.settings import Settings

COPY_CHUNK = 1024 * 1024
MAX_NAME_CHARS = 500  # set_files.name


@dataclass
class StagedFile:
    name: str  # relative POSIX path inside the set
    path: Path
    size_bytes: int
    sha256: str


@dataclass
class StagedUpload:
    root: Path
    files: list[StagedFile] = field(default_factory=list)
    fields: dict[str, str] = field(default_factory=dict)
    total_bytes: int = 0

    def discard(self) -> None:
        shutil.rmtree(self.root, ignore_errors=True)


def _too_large(limit: int) -> ProblemError:
    return ProblemError(413, "upload-too-large", "Upload too large",
                        f"The upload exceeds the limit of {limit} bytes (GNSSATT_MAX_UPLOAD_BYTES). "
                        "Split the observation set or ask the operator to raise the limit.")


def safe_member_name(raw: str, *, where: str) -> str:
    """A relative POSIX path with no '..', no absolute root, no drive letter; else a 422 problem."""
    name = raw.replace("\\", "/")
    parts = [p for p in name.split("/") if p not in ("", ".")]
    if len(raw) > MAX_NAME_CHARS:
        raise ProblemError(422, "name-too-long", "File name too long",
                           f"{where}: a file name of {len(raw)} characters; at most {MAX_NAME_CHARS} are kept.",
                           file=raw[:100])
    if name.startswith("/") or re.match(r"^[A-Za-z]:", name) or ".." in parts or not parts:
        raise ProblemError(422, "unsafe-path", "Unsafe file name",
                           f"{where}: the name {raw!r} is empty, absolute or climbs out of the set with '..'; "
                           "bundle members must be relative paths inside the bundle.", file=raw)
    return "/".join(parts)


async def receive_multipart(request: Request, settings: Settings) -> StagedUpload:
    """Stream a multipart/form-data body into staging; form field `files` (repeated) and optional `name`.

    The parser runs on the event loop but only queues work: writing and hashing the bytes happen in the
    threadpool, a megabyte at a time, so a huge or slow upload never delays other requests."""
    ctype = request.headers.get("content-type", "")
    mime, params = parse_options_header(ctype)
    if mime != b"multipart/form-data" or b"boundary" not in params:
        raise ProblemError(415, "unsupported-media-type", "Unsupported media type",
                           "Send the observation set as multipart/form-data with one or more `files` fields "
                           "(e.g. curl -F files=@GPS-2.rnx -F files=@platform.json ...).")
    limit = settings.max_upload_bytes
    declared = request.headers.get("content-length")
    if declared and declared.isdigit() and int(declared) > limit + 64 * 1024:
        raise _too_large(limit)

    settings.staging_dir.mkdir(parents=True, exist_ok=True)
    staged = StagedUpload(root=settings.staging_dir / uuid.uuid4().hex)
    staged.root.mkdir()
    writer = _PartWriter(staged, settings)
    parser = MultipartParser(params[b"boundary"], writer.callbacks(), max_header_size=16 * 1024)
    received = 0
    try:
        async for chunk in request.stream():
            received += len(chunk)
            if received > limit + 64 * 1024:
                raise _too_large(limit)
            parser.write(chunk)
            if writer.pending_bytes >= COPY_CHUNK or writer.must_flush:
                await run_in_threadpool(writer.flush)
        parser.finalize()
        await run_in_threadpool(writer.flush)
    except ProblemError:
        await run_in_threadpool(writer.abort)
        raise
    except Exception as exc:  # malformed multipart framing
        await run_in_threadpool(writer.abort)
        raise ProblemError(400, "bad-multipart", "Malformed multipart body",
                           f"The multipart/form-data body could not be parsed: {exc}") from exc
    staged.total_bytes = sum(f.size_bytes for f in staged.files)
    if staged.total_bytes > limit:
        staged.discard()
        raise _too_large(limit)
    if not staged.files:
        staged.discard()
        raise ProblemError(422, "no-files", "No files uploaded",
                           "The upload holds no `files` field; send the RINEX files, navigation data and "
                           "platform.json as repeated `files` fields, or one .zip/.tar.gz bundle.", field="files")
    return staged


class _PartWriter:
    """The multipart parser's callbacks: they decide (names, counts, field sizes) on the event loop and queue
    the file operations, which `flush` performs in a worker thread (open, write + hash, close)."""

    def __init__(self, staged: StagedUpload, settings: Settings):
        self.staged, self.settings = staged, settings
        self.headers: dict[str, bytes] = {}
        self.hfield, self.hvalue = b"", b""
        self.names: set[str] = set()
        self.parts = 0
        self.field: str | None = None
        self.buf: bytearray | None = None
        self.open_part: StagedFile | None = None
        self.ops: list[tuple] = []
        self.pending_bytes = 0
        self.must_flush = False
        self._fh = None
        self._digest = None

    def callbacks(self) -> dict:
        return {"on_header_field": self.on_header_field, "on_header_value": self.on_header_value,
                "on_header_end": self.on_header_end, "on_headers_finished": self.on_headers_finished,
                "on_part_data": self.on_part_data, "on_part_end": self.on_part_end}

    def on_header_field(self, data: bytes, start: int, end: int) -> None:
        self.hfield += data[start:end]

    def on_header_value(self, data: bytes, start: int, end: int) -> None:
        self.hvalue += data[start:end]

    def on_header_end(self) -> None:
        if len(self.headers) >= 16:
            raise ProblemError(400, "bad-multipart", "Malformed multipart body",
                               "A multipart part has more than 16 headers.")
        self.headers[self.hfield.decode("latin-1").lower()] = self.hvalue
        self.hfield, self.hvalue = b"", b""

    def on_headers_finished(self) -> None:
        self.parts += 1
        max_files = self.settings.max_upload_files
        if self.parts > max_files + 16:
            raise _too_many_files(max_files)
        disp, opts = parse_options_header(self.headers.get("content-disposition", b""))
        field_name = opts.get(b"name", b"").decode("utf-8", "replace")
        filename = opts.get(b"filename")
        self.field = field_name
        if filename is not None and field_name == "files":
            raw = filename.decode("utf-8", "replace")
            # Browsers and curl send a base name; keep only that for direct uploads.
            base = raw.replace("\\", "/").rsplit("/", 1)[-1]
            name = safe_member_name(base, where="upload")
            if name in self.names:
                raise ProblemError(422, "duplicate-file", "Duplicate file name",
                                   f"Two uploaded files are both called {name!r}; rename one.", file=name)
            if len(self.names) >= max_files:
                raise _too_many_files(max_files)
            self.names.add(name)
            part = StagedFile(name, self.staged.root / f"{len(self.names) - 1:04d}.part", 0, "")
            self.open_part = part
            self.ops.append(("open", part))
        elif filename is not None:
            raise ProblemError(422, "unexpected-field", "Unexpected form field",
                               f"File sent in form field {field_name!r}; use the field name `files`.",
                               field=field_name)
        else:
            self.buf = bytearray()

    def on_part_data(self, data: bytes, start: int, end: int) -> None:
        if self.open_part is not None:
            self.ops.append(("data", bytes(data[start:end])))
            self.pending_bytes += end - start
        elif self.buf is not None:
            self.buf += data[start:end]
            if len(self.buf) > 64 * 1024:
                raise ProblemError(422, "field-too-large", "Form field too large",
                                   f"Form field {self.field!r} is longer than 64 KiB.", field=self.field)

    def on_part_end(self) -> None:
        if self.open_part is not None:
            self.ops.append(("close", self.open_part))
            self.staged.files.append(self.open_part)
            self.open_part = None
            self.must_flush = True
        elif self.buf is not None:
            self.staged.fields[self.field] = self.buf.decode("utf-8", "replace")
            self.buf = None
        self.headers = {}

    def flush(self) -> None:
        """Perform the queued file operations (in a worker thread). Files are fsynced when they are moved
        into the blob store, not here."""
        ops, self.ops = self.ops, []
        self.pending_bytes, self.must_flush = 0, False
        for op in ops:
            if op[0] == "open":
                self._fh, self._digest = open(op[1].path, "wb"), hashlib.sha256()
            elif op[0] == "data":
                self._fh.write(op[1])
                self._digest.update(op[1])
            else:
                op[1].size_bytes = self._fh.tell()
                op[1].sha256 = self._digest.hexdigest()
                self._fh.close()
                self._fh = None

    def abort(self) -> None:
        self.ops = []
        if self._fh is not None:
            try:
                self._fh.close()
            except OSError:
                pass
            self._fh = None
        self.staged.discard()


def _too_many_files(max_files: int) -> ProblemError:
    return ProblemError(413, "too-many-files", "Too many files",
                        f"An upload may hold at most {max_files} files (GNSSATT_MAX_UPLOAD_FILES); bundle them "
                        "or split the set.", field="files")


# --- bundles ---------------------------------------------------------------------------------------

def archive_kind(path: Path) -> str | None:
    """'zip', 'tar' or None, by magic bytes (a gzip holding a tar counts as tar)."""
    with open(path, "rb") as fh:
        head = fh.read(512)
    if head.startswith(b"PK\x03\x04") or head.startswith(b"PK\x05\x06"):
        return "zip"
    if len(head) >= 262 and head[257:262] == b"ustar":
        return "tar"
    if head.startswith(b"\x1f\x8b") or head.startswith(b"BZh") or head.startswith(b"\xfd7zXZ"):
        try:
            with tarfile.open(path, "r:*") as tf:
                tf.next()
            return "tar"
        except (tarfile.TarError, OSError, EOFError):
            return None
    return None


def expand_bundles(staged: StagedUpload, settings: Settings) -> None:
    """Replace every .zip / .tar(.gz) in the upload by its members, guarded against traversal and bombs."""
    out: list[StagedFile] = []
    for f in staged.files:
        kind = archive_kind(f.path)
        if kind is None:
            out.append(f)
            continue
        members = _extract(f, kind, staged, settings)
        f.path.unlink(missing_ok=True)
        out.extend(members)
    if len(out) > settings.max_upload_files:
        raise _too_many_files(settings.max_upload_files)
    seen: set[str] = set()
    for m in out:
        if m.name in seen:
            raise ProblemError(422, "duplicate-file", "Duplicate file name",
                               f"The set holds more than one file called {m.name!r}.", file=m.name)
        seen.add(m.name)
    staged.files = out
    staged.total_bytes = sum(f.size_bytes for f in out)


def _bomb(bundle: str, detail: str) -> ProblemError:
    return ProblemError(422, "bundle-rejected", "Bundle rejected", f"{bundle}: {detail}", file=bundle)


def _extract(bundle: StagedFile, kind: str, staged: StagedUpload, settings: Settings) -> list[StagedFile]:
    limit = min(settings.max_upload_bytes, settings.max_expanded_bytes)
    max_out = min(limit, int(max(bundle.size_bytes, 1) * settings.max_bundle_ratio))
    dest_root = staged.root / f"x{uuid.uuid4().hex[:8]}"
    dest_root.mkdir()
    members: list[StagedFile] = []
    total = 0

    def copy(src, name: str) -> None:
        nonlocal total
        if len(members) >= settings.max_bundle_members:
            raise _bomb(bundle.name, f"more than {settings.max_bundle_members} files in the bundle")
        path = dest_root / f"{len(members):04d}.part"
        digest = hashlib.sha256()
        size = 0
        with open(path, "wb") as out:
            while chunk := src.read(COPY_CHUNK):
                size += len(chunk)
                total += len(chunk)
                if total > max_out:
                    raise _bomb(bundle.name, f"expands to more than {max_out} bytes (ratio limit "
                                f"{settings.max_bundle_ratio:g}x, size limit {limit}); a zip bomb or too large")
                digest.update(chunk)
                out.write(chunk)
        members.append(StagedFile(name, path, size, digest.hexdigest()))

    try:
        if kind == "zip":
            with zipfile.ZipFile(bundle.path) as zf:
                infos = zf.infolist()
                if len(infos) > settings.max_bundle_members:
                    raise _bomb(bundle.name, f"more than {settings.max_bundle_members} entries")
                if sum(i.file_size for i in infos) > max_out:
                    raise _bomb(bundle.name, f"declares {sum(i.file_size for i in infos)} uncompressed bytes, "
                                f"more than {max_out} (ratio limit {settings.max_bundle_ratio:g}x); a zip bomb?")
                for info in infos:
                    name = safe_member_name(info.filename, where=bundle.name)
                    if info.is_dir():
                        continue
                    mode = (info.external_attr >> 16) & 0o170000
                    if mode and not stat.S_ISREG(mode):
                        raise _bomb(bundle.name, f"member {info.filename!r} is a link or special file")
                    if _ignorable(name):
                        continue
                    with zf.open(info) as src:
                        copy(src, name)
        else:
            with tarfile.open(bundle.path, "r:*") as tf:
                entries = 0
                for info in tf:
                    entries += 1  # directories and skipped entries count too: a million of them is a bomb
                    if entries > settings.max_bundle_members:
                        raise _bomb(bundle.name, f"more than {settings.max_bundle_members} entries")
                    name = safe_member_name(info.name, where=bundle.name)
                    if info.isdir():
                        continue
                    if not info.isfile():
                        raise _bomb(bundle.name, f"member {info.name!r} is a link or special file")
                    if _ignorable(name):
                        continue
                    src = tf.extractfile(info)
                    if src is None:
                        continue
                    with src:
                        copy(src, name)
    except ProblemError:
        raise
    except (zipfile.BadZipFile, tarfile.TarError, EOFError, OSError, NotImplementedError, RuntimeError) as exc:
        raise ProblemError(422, "bundle-rejected", "Bundle rejected",
                           f"{bundle.name}: the archive is damaged or uses an unsupported feature ({exc}).",
                           file=bundle.name) from exc
    if not members:
        raise _bomb(bundle.name, "the bundle holds no files")
    return _strip_common_root(members)


def _ignorable(name: str) -> bool:
    base = name.rsplit("/", 1)[-1]
    return name.startswith("__MACOSX/") or base.startswith("._") or base in (".DS_Store", "Thumbs.db")


def _strip_common_root(members: list[StagedFile]) -> list[StagedFile]:
    """A bundle made by zipping a folder has every member under one top folder: drop it."""
    firsts = {m.name.split("/", 1)[0] for m in members}
    if len(firsts) == 1 and all("/" in m.name for m in members):
        for m in members:
            m.name = m.name.split("/", 1)[1]
    return members
