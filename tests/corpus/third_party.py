"""Where the third-party GNSS test files live (../shared/data/third_party/files/<owner>+<repo>/<path>, copied
byte for byte from public projects' repositories, provenance in its README.md); never copied into this repo."""
from __future__ import annotations

from pathlib import Path

from bench.real_sets import REAL_DATA_DIR
from tests.conftest import missing

THIRD_PARTY_DIR = REAL_DATA_DIR.parent / "third_party" / "files"


def third_party_file(rel: str) -> Path:
    """Path of one third-party file ('owner+repo/path'); `missing` (skip, or fail under CI=true) when absent."""
    path = THIRD_PARTY_DIR / rel
    if not path.is_file():
        missing(f"third-party file {rel!r} not found under {THIRD_PARTY_DIR} (../shared/data/third_party)")
    return path
