"""Bounds on what one uploaded file may cost, checked while it streams, before any reader sees it.

Every compression layer (gzip, bzip2, Unix compress, zip, Hatanaka; in any order and nesting, a zip in a zip
too) is peeled to a file in the upload's staging directory, a megabyte at a time, counting its output against
one budget per upload (`ExpansionBudget`: GNSSATT_MAX_EXPANDED_BYTES in all, GNSSATT_MAX_BUNDLE_RATIO per
layer). The innermost plain text is then scanned for lines longer than GNSSATT_MAX_LINE_BYTES, NUL bytes, a
RINEX/ANTEX header without END OF HEADER within GNSSATT_MAX_HEADER_BYTES, and size limits of the small
kinds (reference attitude CSV, platform.json, whose nesting depth is checked too). So the sniffers in
gnssatt/gnss/io/sniff.py only ever read plain files of bounded lines from disk, never a bomb.
"""
from __future__ import annotations

import bz2
import subprocess
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path

from app.limits import json_depth_exceeds
from app.problems import ProblemError
from core.settings import Settings

CHUNK = 1024 * 1024
MAX_LAYERS = 6
MAX_PLATFORM_BYTES = 1024**2
MAX_PLATFORM_DEPTH = 16


def _rejected(name: str, detail: str, status: int = 422, **extra) -> ProblemError:
    return ProblemError(status, "file-rejected", f"{name} rejected", f"{name}: {detail}", file=name, **extra)


@dataclass
class ExpansionBudget:
    """Bytes that decompression may still produce for this upload, and the per-layer ratio limit."""

    settings: Settings
    used: int = 0

    def take(self, name: str, layer: str, produced: int, layer_in: int, layer_out: int) -> None:
        """Count `produced` more bytes of a layer that read `layer_in` bytes and has made `layer_out` so far."""
        self.used += produced
        limit = self.settings.max_expanded_bytes
        if self.used > limit:
            raise _rejected(name, f"expands to more than {limit} bytes in all (GNSSATT_MAX_EXPANDED_BYTES) "
                            f"while peeling its {layer} layer; a decompression bomb or too large", status=413)
        ratio = self.settings.max_bundle_ratio
        if layer_out > max(layer_in * ratio, CHUNK):
            raise _rejected(name, f"its {layer} layer expands more than {ratio:g} times "
                            "(GNSSATT_MAX_BUNDLE_RATIO); a decompression bomb?")


class _LayerAccount:
    """What one layer has produced, reported to the upload's budget as it grows."""

    def __init__(self, budget: ExpansionBudget, name: str, layer: str, layer_in: int):
        self.budget, self.name, self.layer, self.layer_in, self.out = budget, name, layer, layer_in, 0

    def __call__(self, produced: int) -> None:
        self.out += produced
        self.budget.take(self.name, self.layer, produced, self.layer_in, self.out)


def detect_layer(head: bytes) -> str | None:
    if head.startswith(b"\x1f\x8b"):
        return "gzip"
    if head.startswith(b"\x1f\x9d"):
        return "lzw"
    if head.startswith(b"PK\x03\x04"):
        return "zip"
    if head.startswith(b"BZh") and head[3:4].isdigit():
        return "bzip2"
    if b"CRINEX VERS   / TYPE" in head[:200].split(b"\n", 1)[0]:
        return "hatanaka"
    return None


def plain_file(path: Path, name: str, budget: ExpansionBudget, workdir: Path) -> tuple[Path, list[str]]:
    """The file's innermost plain content on disk (the file itself when it has no layer), and its layers."""
    layers: list[str] = []
    current = path
    for depth in range(MAX_LAYERS + 1):
        with open(current, "rb") as fh:
            head = fh.read(512)
        layer = detect_layer(head)
        if layer is None:
            return current, layers
        if depth == MAX_LAYERS:
            break
        out = workdir / f"{path.name}.l{depth}"
        account = _LayerAccount(budget, name, layer, current.stat().st_size)
        try:
            _PEEL[layer](current, out, account)
        except ProblemError:
            out.unlink(missing_ok=True)
            raise
        except (OSError, EOFError, ValueError, zlib.error, zipfile.BadZipFile, RuntimeError) as exc:
            out.unlink(missing_ok=True)
            raise _rejected(name, f"its {layer} layer is damaged or truncated ({type(exc).__name__}: "
                            f"{str(exc)[:160]})") from exc
        if current != path:
            current.unlink(missing_ok=True)
        layers.append(layer)
        current = out
    raise _rejected(name, f"more than {MAX_LAYERS} nested compression layers ({'+'.join(layers)})")


class _Counted:
    """A write-only file that reports every megabyte written (so a budget can stop the writer)."""

    def __init__(self, fh, account):
        self.fh, self.account, self.size, self.reported = fh, account, 0, 0

    def write(self, data) -> int:
        self.size += len(data)
        if self.size - self.reported >= CHUNK:
            self.account(self.size - self.reported)
            self.reported = self.size
        return self.fh.write(data)

    def close(self) -> None:
        self.account(self.size - self.reported)
        self.reported = self.size


def _peel_gzip(src: Path, out: Path, account) -> None:
    """gzip, concatenated members too (RFC 1952 sec. 2.2), inflated a megabyte at a time."""
    with open(src, "rb") as fin, open(out, "wb") as fout:
        sink = _Counted(fout, account)
        dec = None
        while data := fin.read(CHUNK):
            while data:
                if dec is None:
                    data = data.lstrip(b"\x00")
                    if not data.startswith(b"\x1f\x8b"):
                        break  # trailing padding or garbage after the last member: gzip(1) ignores it
                    dec = zlib.decompressobj(wbits=31)
                sink.write(dec.decompress(data, CHUNK))
                data = dec.unconsumed_tail
                if dec.eof:
                    data, dec = dec.unused_data, None
        sink.close()
        if dec is not None:
            raise EOFError("the gzip stream ends before its end-of-stream marker (truncated file)")


def _peel_bzip2(src: Path, out: Path, account) -> None:
    """bzip2, concatenated streams too, a megabyte of output at a time."""
    with open(src, "rb") as fin, open(out, "wb") as fout:
        sink = _Counted(fout, account)
        dec = None
        while data := fin.read(CHUNK):
            while data or (dec is not None and not dec.needs_input):
                if dec is None:
                    data = data.lstrip(b"\x00")
                    if not data:
                        break
                    dec = bz2.BZ2Decompressor()
                sink.write(dec.decompress(data, CHUNK))
                data = b""
                if dec.eof:
                    data, dec = dec.unused_data, None
        sink.close()
        if dec is not None:
            raise EOFError("the bzip2 stream ends before its end-of-stream marker (truncated file)")


def _peel_lzw(src: Path, out: Path, account) -> None:
    import ncompress

    with open(src, "rb") as fin, open(out, "wb") as fout:
        sink = _Counted(fout, account)
        ncompress.decompress(fin, sink)
        sink.close()


def _peel_zip(src: Path, out: Path, account) -> None:
    with zipfile.ZipFile(src) as zf:
        members = [m for m in zf.infolist() if not m.is_dir()]
        if len(members) != 1:
            raise ValueError(f"a compressed zip must hold exactly one file, this one holds {len(members)} "
                             "(a bundle of several files is expanded only at the top level)")
        with zf.open(members[0]) as fin, open(out, "wb") as fout:
            sink = _Counted(fout, account)
            while chunk := fin.read(CHUNK):
                sink.write(chunk)
            sink.close()


def _peel_hatanaka(src: Path, out: Path, account) -> None:
    """CRX2RNX (the program inside the `hatanaka` wheel) through pipes; stopped as soon as the budget says so."""
    from hatanaka.hatanaka import executables

    exe = str(executables.joinpath("crx2rnx"))
    with open(src, "rb") as fin, open(out, "wb") as fout:
        proc = subprocess.Popen([exe, "-"], stdin=fin, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        try:
            sink = _Counted(fout, account)
            while chunk := proc.stdout.read(CHUNK):
                sink.write(chunk)
            sink.close()
            err = proc.stderr.read(4096).decode("ascii", "replace").strip()
            code = proc.wait(timeout=60)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
            proc.stdout.close()
            proc.stderr.close()
    if code not in (0, 2):
        raise ValueError(" ".join(err.split())[:200] or f"CRX2RNX exited with status {code}")


_PEEL = {"gzip": _peel_gzip, "bzip2": _peel_bzip2, "lzw": _peel_lzw, "zip": _peel_zip, "hatanaka": _peel_hatanaka}


def scan_plain(path: Path, name: str, settings: Settings) -> bool:
    """Line length, NUL bytes, header size and small-kind limits of a plain file, in one streaming pass.
    Returns whether the file is of a kind summarised by a full reader (navigation, SP3, clock, ANTEX)."""
    max_line = settings.max_line_bytes
    max_header = settings.max_header_bytes
    with open(path, "rb") as fh:
        head = fh.read(CHUNK)
        first = head.split(b"\n", 1)[0]
        label = first[60:80].strip()
        has_header = label in (b"RINEX VERSION / TYPE", b"ANTEX VERSION / SYST", b"CRINEX VERS   / TYPE")
        full_read = (label == b"RINEX VERSION / TYPE" and first[20:21] != b"O") or label == b"ANTEX VERSION / SYST" \
            or (first[:1] == b"#" and first[1:2] in (b"a", b"b", b"c", b"d"))
        stripped = head.lstrip()
        kind_limit = None
        if stripped[:1] in (b"{", b"["):
            kind_limit = ("platform.json", MAX_PLATFORM_BYTES)
        elif first.replace(b" ", b"").startswith(b"time_gps,"):
            kind_limit = ("reference attitude CSV", settings.max_reference_csv_bytes)
        offset, line_no, run = 0, 1, 0
        header_open = has_header
        tail = b""
        chunk = head
        while chunk:
            if b"\x00" in chunk:
                at = chunk.index(b"\x00")
                where = line_no + chunk.count(b"\n", 0, at)
                raise _rejected(name, f"binary data (a NUL byte) at byte {offset + at}, line {where}; "
                                "expected a text file", line=where)
            first_nl = chunk.find(b"\n")
            if first_nl < 0:
                run += len(chunk)
            else:
                parts = chunk.split(b"\n")
                if max(run + first_nl, max(map(len, parts))) > max_line:
                    where = line_no + next((i for i, p in enumerate(parts) if len(p) > max_line), 0)
                    raise _rejected(name, f"a line longer than {max_line} bytes at line {where} "
                                    "(GNSSATT_MAX_LINE_BYTES); expected a text file of short lines", line=where)
                run = len(chunk) - chunk.rfind(b"\n") - 1
            if run > max_line:
                where = line_no + chunk.count(b"\n")
                raise _rejected(name, f"a line longer than {max_line} bytes at line {where} "
                                "(GNSSATT_MAX_LINE_BYTES); expected a text file of short lines", line=where)
            if header_open:
                end_at = (tail + chunk).find(b"END OF HEADER")
                if 0 <= end_at and offset - len(tail) + end_at <= max_header:
                    header_open = False
                elif offset + len(chunk) > max_header:
                    raise _rejected(name, f"no END OF HEADER within the first {max_header} bytes "
                                    "(GNSSATT_MAX_HEADER_BYTES); the header is too long or damaged")
            line_no += chunk.count(b"\n")
            offset += len(chunk)
            if kind_limit is not None and offset > kind_limit[1]:
                raise _rejected(name, f"a {kind_limit[0]} larger than {kind_limit[1]} bytes", status=413)
            tail = chunk[-16:]
            chunk = fh.read(CHUNK)
    if kind_limit is not None and kind_limit[0] == "platform.json":
        if json_depth_exceeds(path.read_bytes(), MAX_PLATFORM_DEPTH):
            raise _rejected(name, f"platform.json nests deeper than {MAX_PLATFORM_DEPTH} levels")
    return full_read
