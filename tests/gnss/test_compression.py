"""read_text_bytes: every layer by magic bytes, in combination, and errors as ParseError naming the file."""
from __future__ import annotations

import bz2
import gzip
import io
import zipfile

import hatanaka
import ncompress
import pytest

from gnssatt.sim.sample_set import obs_v3_text
from gnssatt.gnss.io.compression import detect_layer, read_text_bytes
from gnssatt.gnss.io.errors import ParseError

RAW = obs_v3_text("ANT1", n_epochs=20).encode()


def _zip(data: bytes, names=("a.rnx",)) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for n in names:
            zf.writestr(n, data)
    return buf.getvalue()


CRX = hatanaka.rnx2crx(RAW)

CASES = {
    "plain": RAW,
    "gzip": gzip.compress(RAW),
    "lzw": ncompress.compress(RAW),
    "bzip2": bz2.compress(RAW),
    "zip": _zip(RAW),
    "crx": CRX,
    "crx.gz": gzip.compress(CRX),
    "crx.Z": ncompress.compress(CRX),
    "crx.zip": _zip(CRX),
    "crx.gz.Z": ncompress.compress(gzip.compress(CRX)),
    "two gzip members": gzip.compress(RAW[:1000]) + gzip.compress(RAW[1000:]),
}


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_every_layer_and_combination_gives_the_plain_bytes(case, tmp_path):
    data = CASES[case]
    assert read_text_bytes(data) == RAW
    # by path, with a MISLEADING extension: detection is by magic bytes
    p = tmp_path / "file.txt"
    p.write_bytes(data)
    assert read_text_bytes(p) == RAW


def test_detect_layer_names():
    assert detect_layer(CASES["gzip"]) == "gzip"
    assert detect_layer(CASES["lzw"]) == "lzw"
    assert detect_layer(CASES["zip"]) == "zip"
    assert detect_layer(CASES["bzip2"]) == "bzip2"
    assert detect_layer(CRX) == "hatanaka"
    assert detect_layer(RAW) is None


@pytest.mark.parametrize("bad", [
    gzip.compress(RAW)[:-50],  # truncated gzip
    b"\x1f\x9d\x90garbage",  # damaged LZW
    _zip(RAW, names=("a", "b")),  # two members
    b"PK\x03\x04not a zip",
    CRX[: len(CRX) // 2] + b"\x00garbage\n" * 3,  # broken Hatanaka
    bz2.compress(RAW)[:-20],
], ids=["gz-trunc", "lzw-bad", "zip-2", "zip-bad", "crx-bad", "bz2-trunc"])
def test_damaged_streams_raise_parse_error_naming_the_file(bad):
    with pytest.raises(ParseError) as err:
        read_text_bytes(bad, name="upload/ANT1.rnx.gz")
    assert err.value.path == "upload/ANT1.rnx.gz"
    assert "upload/ANT1.rnx.gz" in str(err.value)


def test_missing_file_is_parse_error(tmp_path):
    with pytest.raises(ParseError):
        read_text_bytes(tmp_path / "nope.rnx")


def test_decompression_bomb_is_capped():
    bomb = gzip.compress(b" " * 10_000_000)
    with pytest.raises(ParseError, match="at most"):
        read_text_bytes(bomb, name="bomb.gz", max_bytes=1_000_000)


def test_nested_loop_is_refused():
    data = RAW
    for _ in range(8):
        data = gzip.compress(data)
    with pytest.raises(ParseError, match="nested"):
        read_text_bytes(data)
