"""Plain RINEX bytes of a file that may be gzipped, Unix-compressed, zipped, bzip2'ed and/or Hatanaka-compressed.

The layers are recognised by their MAGIC BYTES, never by the file name alone (uploads are renamed, `.Z` files
are often gzip and `.gz` files are sometimes plain), and are peeled in any order and combination
(`.crx.gz`, `.??d.Z`, a `.zip` holding a `.crx`, ...) until plain text remains.

| layer          | magic                                            | decoder                                         |
|----------------|--------------------------------------------------|-------------------------------------------------|
| gzip           | `1f 8b` (RFC 1952 sec. 2.3.1)                    | `gzip` (stdlib), multi-member aware             |
| Unix compress  | `1f 9d` (LZW, `compress(1)`)                     | `ncompress` (PyPI, C extension, in-process)     |
| zip            | `PK\\x03\\x04` (PKWARE APPNOTE 4.3.7)              | `zipfile` (stdlib); exactly one member          |
| bzip2          | `BZh`                                            | `bz2` (stdlib)                                  |
| Hatanaka       | `CRINEX VERS   / TYPE` label in cols 61-80 of    | `hatanaka.crx2rnx` (Compact RINEX 1.0 and 3.0)  |
|                | line 1 (Hatanaka 1996; CRINEX 3.0 of 2007)       |                                                 |

`ncompress` is the LZW decoder that the `hatanaka` package itself depends on (small C extension, maintained,
BSD); it runs in this process. `hatanaka.crx2rnx` runs the RNXCMP `CRX2RNX` program that ships compiled
*inside the wheel* (not a system binary): the bytes go through a pipe, no file is written.

Every failure becomes `ParseError` naming the file. The decompressed size is capped (`max_bytes`) so that a
decompression bomb in an upload cannot exhaust the worker's memory.
"""
from __future__ import annotations

import bz2
import io
import zipfile
import zlib
from pathlib import Path

from gnssatt.gnss.io.errors import ParseError

__all__ = ["read_text_bytes", "detect_layer", "DEFAULT_MAX_BYTES"]

#: Largest plain RINEX accepted after decompression (bytes). A 24 h, 1 Hz, multi-GNSS RINEX 3 file is ~1 GB.
DEFAULT_MAX_BYTES = 4 * 1024**3
#: Most layers peeled before giving up (a file compressed in a loop is not RINEX).
_MAX_LAYERS = 6

_GZIP_MAGIC = b"\x1f\x8b"
_LZW_MAGIC = b"\x1f\x9d"
_ZIP_MAGIC = b"PK\x03\x04"
_BZ2_MAGIC = b"BZh"
_CRINEX_LABEL = b"CRINEX VERS   / TYPE"


def detect_layer(data: bytes) -> str | None:
    """Name of the outermost compression layer of `data` ('gzip', 'lzw', 'zip', 'bzip2', 'hatanaka'), or None.

    Args:
        data: the first bytes of a file (at least 80 for the Hatanaka test; more is fine).
    """
    head = data[:4]
    if head.startswith(_GZIP_MAGIC):
        return "gzip"
    if head.startswith(_LZW_MAGIC):
        return "lzw"
    if head.startswith(_ZIP_MAGIC):
        return "zip"
    if head.startswith(_BZ2_MAGIC) and len(data) > 3 and data[3:4].isdigit():
        return "bzip2"
    first_line = data[:200].split(b"\n", 1)[0]
    if _CRINEX_LABEL in first_line:
        return "hatanaka"
    return None


def _gunzip(data: bytes, max_bytes: int) -> bytes:
    # zlib with wbits=31 handles one gzip member; loop for concatenated members (gzip -c a b > ab.gz).
    out = bytearray()
    while data:
        d = zlib.decompressobj(wbits=31)
        out += d.decompress(data, max_bytes + 1 - len(out))
        if len(out) > max_bytes:
            raise _TooLarge()
        if not d.eof:
            if d.unconsumed_tail:
                raise _TooLarge()
            raise EOFError("gzip stream ends before its end-of-stream marker (truncated file)")
        data = d.unused_data.lstrip(b"\x00")
        if data and not data.startswith(_GZIP_MAGIC):
            break  # trailing garbage after the last member: gzip(1) ignores it with a warning; so do we
    return bytes(out)


def _unlzw(data: bytes) -> bytes:
    import ncompress

    return ncompress.decompress(data)


def _unzip(data: bytes) -> bytes:
    with zipfile.ZipFile(io.BytesIO(data)) as zf:
        members = [m for m in zf.infolist() if not m.is_dir()]
        if len(members) != 1:
            raise ValueError(f"zip archive must hold exactly one file, holds {len(members)}")
        return zf.read(members[0])


def _uncrx(data: bytes) -> bytes:
    import hatanaka

    return hatanaka.crx2rnx(data)


class _TooLarge(Exception):
    pass


def read_text_bytes(path_or_bytes, name: str | None = None, *, max_bytes: int = DEFAULT_MAX_BYTES) -> bytes:
    """Plain (uncompressed, non-Hatanaka) bytes of a RINEX/SP3/... file, whatever layers wrap it.

    Args:
        path_or_bytes: a path (str or Path) or the file content (bytes, bytearray, memoryview).
        name: the file's name as the user knows it (for messages); defaults to the path's name or "<bytes>".
        max_bytes: cap on the size of any decompressed layer (bytes), against decompression bombs.

    Returns:
        The innermost plain bytes (not decoded; RINEX is ASCII, decode latin-1 if text is needed).

    Raises:
        ParseError: unreadable file, damaged or truncated compressed stream, zip with != 1 member,
            Hatanaka decoding failure, too many nested layers, or a decompressed size above `max_bytes`.

    Implements: magic numbers of RFC 1952 (gzip), compress(1) LZW, PKWARE APPNOTE (zip), bzip2; Compact RINEX
    format 1.0/3.0 (Y. Hatanaka, "A Compression Format and Tools for GNSS Observation Data", Bull. GSI 55, 2008).
    """
    if isinstance(path_or_bytes, (bytes, bytearray, memoryview)):
        data = bytes(path_or_bytes)
        label = name or "<bytes>"
    else:
        path = Path(path_or_bytes)
        label = name or path.name
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise ParseError(label, None, "a readable file", f"{type(exc).__name__}: {exc}") from exc
    if len(data) > max_bytes:
        raise ParseError(label, None, f"at most {max_bytes} bytes", f"{len(data)} bytes")
    peeled: list[str] = []
    for _ in range(_MAX_LAYERS + 1):
        layer = detect_layer(data)
        if layer is None:
            return data
        if len(peeled) >= _MAX_LAYERS:
            break
        try:
            if layer == "gzip":
                data = _gunzip(data, max_bytes)
            elif layer == "lzw":
                data = _unlzw(data)
            elif layer == "zip":
                data = _unzip(data)
            elif layer == "bzip2":
                dec = bz2.BZ2Decompressor()
                data = dec.decompress(data, max_length=max_bytes + 1)
                if not dec.eof and not dec.needs_input:
                    raise _TooLarge()
                if not dec.eof:
                    raise EOFError("bzip2 stream ends before its end-of-stream marker (truncated file)")
            else:  # hatanaka
                data = _uncrx(data)
        except _TooLarge:
            raise ParseError(label, None, f"at most {max_bytes} bytes after {layer} decompression",
                             "a larger stream (decompression bomb?)") from None
        except Exception as exc:  # zlib.error, EOFError, OSError, ValueError, HatanakaException, BadZipFile ...
            raise ParseError(label, None, f"a valid {layer} stream" + (f" inside {'+'.join(peeled)}" if peeled else ""),
                             f"{type(exc).__name__}: {str(exc).strip()[:160]}") from exc
        if isinstance(data, str):  # hatanaka returns str for str input only, but be safe
            data = data.encode("latin-1")
        if len(data) > max_bytes:
            raise ParseError(label, None, f"at most {max_bytes} bytes after {layer} decompression",
                             f"{len(data)} bytes")
        peeled.append(layer)
    raise ParseError(label, None, f"at most {_MAX_LAYERS} nested compression layers", "+".join(peeled) + "+...")

