"""Small real files held in the repository (tests/data/third_party, provenance in its PROVENANCE.md) for versions
the shared third-party corpus lacks: read, with every value equal to an independent whitespace re-read of the raw
lines, and, where RTKLIB reads the format, equal to RTKLIB's values too."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gnssatt.gnss.io.antex import read_antex
from tests.conftest import require_module

DATA = Path(__file__).resolve().parents[1] / "data" / "third_party"
ANTEX_13 = DATA / "igs05_1585_cut.atx"


def _raw_antex_blocks(text: str) -> list[dict]:
    """Independent re-read (whitespace split, no columns): per antenna its type, DAZI and per frequency the
    NORTH/EAST/UP numbers, the NOAZI row and the azimuth rows (ANTEX 1.3, sec. 'ANTEX format description')."""
    ants: list[dict] = []
    cur = freq = None
    for ln in text.splitlines():
        label = ln[60:].strip()
        if label == "START OF ANTENNA":
            cur = {"freqs": []}
            ants.append(cur)
        elif label == "TYPE / SERIAL NO":
            cur["type"] = ln[:20].strip()
        elif label == "DAZI":
            cur["dazi"] = float(ln[:60])
        elif label == "START OF FREQUENCY":
            freq = {"code": ln[3:6], "neu": None, "noazi": None, "rows": []}
            cur["freqs"].append(freq)
        elif label == "NORTH / EAST / UP":
            freq["neu"] = [float(v) for v in ln[:60].split()]
        elif label == "END OF FREQUENCY":
            freq = None
        elif freq is not None and ln.startswith("   NOAZI"):
            freq["noazi"] = [float(v) for v in ln[8:].split()]
        elif freq is not None and ln[:8].strip():   # an azimuth row (its numbers run past column 60)
            freq["rows"].append([float(v) for v in ln.split()[1:]])
    return ants


def test_antex_13_reads_with_values_of_the_raw_lines():
    """IGS igs05.atx in ANTEX 1.3 (3 satellite antennas, 1 receiver antenna with azimuth rows): no warning, and
    offsets, NOAZI rows and the 73 x 19 azimuth grid equal the raw numbers exactly."""
    warns: list = []
    pats = read_antex(ANTEX_13, warnings=warns)
    assert warns == []
    raw = _raw_antex_blocks(ANTEX_13.read_text())
    assert [p.antenna_type for p in pats] == [a["type"] for a in raw] and len(pats) == 4
    n = 0
    for p, a in zip(pats, raw):
        assert p.dazi_deg == a["dazi"] and len(p.frequencies) == len(a["freqs"])
        for f, rf in zip(p.frequencies, a["freqs"]):
            assert f.code == rf["code"]
            np.testing.assert_array_equal(f.neu_mm, rf["neu"])
            np.testing.assert_array_equal(f.noazi_mm, rf["noazi"])
            if rf["rows"]:
                np.testing.assert_array_equal(f.pcv_mm, rf["rows"])
            else:
                assert f.pcv_mm is None
            n += 3 + len(rf["noazi"]) + sum(len(r) for r in rf["rows"])
    assert pats[3].antenna_type == "AOAD/M_B        NONE" and pats[3].frequencies[0].pcv_mm.shape == (73, 19)
    assert n > 2900


def test_antex_13_agrees_with_rtklib():
    """RTKLIB's readpcv (ANTEX 1.3 is its documented version): offsets and the NOAZI row in metres equal ours
    within 1e-12 m (RTKLIB multiplies mm by 1e-3 in its own expression)."""
    rk = require_module("pyrtklib", "RTKLIB reference reader")
    pcvs = rk.pcvs_t()
    assert rk.readpcv(str(ANTEX_13), pcvs) == 1 and pcvs.n == 4
    pats = read_antex(ANTEX_13)
    for i, p in enumerate(pats):
        c = pcvs.pcv[i]
        for k in range(2):   # RTKLIB keeps L1 and L2 of these files
            f = p.frequencies[k]
            # RTKLIB stores a receiver antenna's offset as east, north, up (a satellite's as x, y, z)
            off_mm = f.neu_mm[[1, 0, 2]] if i == 3 else f.neu_mm
            np.testing.assert_allclose([c.off[(k, a)] for a in range(3)], off_mm * 1e-3, rtol=0, atol=1e-12)
            n_zen = len(f.noazi_mm)
            np.testing.assert_allclose([c.var[(k, z)] for z in range(n_zen)], f.noazi_mm * 1e-3, rtol=0,
                                       atol=1e-12)
