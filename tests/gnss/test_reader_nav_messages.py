"""Navigation of every system: NavIC ephemerides, SBAS state vectors (RINEX 3 and 4) and the RINEX 4 messages
(CNAV/CNV1-3 ephemerides, STO, EOP, ION) read into typed records from real files, with values against the raw
lines, RTKLIB's readrnx, and NavIC orbits usable by the ephemeris layer."""
from __future__ import annotations

import gzip
import numpy as np
import pytest

from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.rinex_nav import read_rinex_nav
from gnssatt.gnss.orbits.broadcast import kepler_position_ecef
from tests.conftest import require_module
from tests.corpus.third_party import third_party_file

BRDM_V3 = "Stanford-NavLab+gnss_lib_py/data/unit_test/rinex/nav/BRDM00DLR_S_20230730000_01D_MN.rnx"
KMS_V4 = "georust+rinex/test_resources/NAV/V4/KMS300DNK_R_20221591000_01H_MN.rnx.gz"
BRD_V4 = "georust+rinex/test_resources/NAV/V4/BRD400DLR_S_20230710000_01D_MN.rnx.gz"


def test_rinex3_navic_and_sbas_records_read():
    """RINEX 3.04 mixed file (DLR): I02/I03 and S records are read (no unsupported-record), values of the raw
    lines; the NavIC orbit radius is the GEO/IGSO one (42,164 km +- 200 km, IRNSS ICD sec. 6.2)."""
    path = third_party_file(BRDM_V3)
    nav = read_rinex_nav(path)
    assert not any(w.code.startswith("UNSUPPORTED") for w in nav.warnings)
    k = nav.kepler["I"]
    assert sorted(set(k.sat)) == ["I02", "I03"] and len(k) == 6 and k.time_system == "IRNWT"
    lines = path.read_text().splitlines()
    first = lines[int(k.line_no[0]) - 1]
    assert first.startswith(str(k.sat[0])) and float(first[23:42]) == k.af0_s[0]
    sqrt_a_line = lines[int(k.line_no[0]) + 1]
    assert float(sqrt_a_line[4 + 3 * 19:4 + 4 * 19]) == k.sqrt_a_sqrt_m[0]
    r = kepler_position_ecef(k, np.arange(len(k)), k.toe_gpst())[0]
    assert np.all(np.abs(np.linalg.norm(r, axis=1) - 42_164e3) < 200e3)
    s = nav.sbas
    assert len(s) == 6 and all(x.startswith("S") for x in s.sat)
    row = lines[int(s.line_no[0])]   # BROADCAST ORBIT - 1: X (km), Xdot, Xacc, health
    assert s.position_m[0, 0] == float(row[4:23]) * 1000.0 and s.health[0] == int(float(row[61:80]))


def test_rinex3_navic_and_sbas_agree_with_rtklib():
    """RTKLIB readrnx on the same file: every NavIC record (A = sqrtA^2 to 1 ulp, e, toe, af0) and every SBAS
    record (position, af0, health, epoch) equal ours."""
    rk = require_module("pyrtklib", "RTKLIB reference reader")
    path = third_party_file(BRDM_V3)
    nav = read_rinex_nav(path)
    obs, rnav, sta = rk.obs_t(), rk.nav_t(), rk.sta_t()
    assert rk.readrnx(str(path), 1, "", obs, rnav, sta) == 1
    gps0 = 315964800   # 1980-01-06 in Unix seconds
    k = nav.kepler["I"]
    theirs = {(rnav.eph[i].sat, rnav.eph[i].toes): rnav.eph[i] for i in range(rnav.n)}
    for r in range(len(k)):
        e = theirs[(rk.satid2no(str(k.sat[r])), k.toe_sow[r])]
        assert (e.e, e.f0, e.week) == (k.e[r], k.af0_s[r], k.week[r])
        assert abs(e.A - k.sqrt_a_sqrt_m[r] ** 2) <= 4.5e-16 * e.A
    s = nav.sbas
    assert rnav.ns == len(s)
    for i in range(rnav.ns):
        t = rnav.seph[i]
        assert t.sat == rk.satid2no(str(s.sat[i])) and t.t0.time == int(s.toc.s[i]) + gps0
        assert [t.pos[a] for a in range(3)] == s.position_m[i].tolist()
        assert (t.af0, t.svh) == (s.af0_s[i], s.health[i])


def test_rinex4_sbas_sto_ion_read_as_typed_records():
    """RINEX 4.00 (KMS300DNK): '> EPH S48 SBAS' is an SBAS state vector; STO and ION are NavMessages with the
    RINEX 4.01 names; nothing is skipped."""
    path = third_party_file(KMS_V4)
    nav = read_rinex_nav(path)
    assert nav.skipped == {} and nav.warnings == []
    s = nav.sbas
    j = list(s.sat).index("S48")
    # raw lines 1408-1411 of the file: X 3.047423624000E+04 km, Xdot -4.518750000000E-04 km/s, health 31
    assert s.position_m[j, 0] == 3.047423624000e+04 * 1000.0 and s.velocity_m_s[j, 0] == -4.518750000000e-04 * 1e3
    assert s.health[j] == 31 and s.transmission_sow[j] == 2.951920000000e+05
    sto = [m for m in nav.messages if m.kind == "STO" and m.label.startswith("GPUT")]
    assert len(sto) == 1 and sto[0].sat == "G26" and sto[0].label == "GPUT UTC(USNO)"
    assert sto[0].named() == {"t_tm_sow": 2.952840000000e+05, "a0_s": 9.313225746155e-10,
                              "a1_s_s": 2.664535259100e-15, "a2_s_s2": 0.0}
    ion = next(m for m in nav.messages if m.kind == "ION" and m.msg_type == "LNAV")
    assert ion.sat == "G29" and ion.named()["alpha0_s"] == 1.024454832077e-08
    assert ion.named()["beta3_s_sc3"] == -5.898240000000e+05 and ion.epoch.iso(0).startswith("2022-06-08T09:59:48")
    gal = next(m for m in nav.messages if m.kind == "ION" and m.msg_type == "IFNV")
    assert gal.named()["ai0_sfu"] == 7.85e+01


def test_rinex4_unknown_record_kind_still_refused():
    """An unknown '>' record kind is ambiguous (its layout is not defined): an error naming the line."""
    text = gzip.decompress(third_party_file(KMS_V4).read_bytes()).decode("latin-1")
    bad = text.replace("> STO G26 LNAV", "> XYZ G26 LNAV", 1)
    with pytest.raises(ParseError, match="RINEX 4 record line"):
        read_rinex_nav(bad.encode("latin-1"), name="bad.rnx")
    # a kept (CNAV-type) record whose first line names another satellite than its '>' line is refused too
    cnav = gzip.decompress(third_party_file(BRD_V4).read_bytes()).decode("latin-1")
    k = cnav.index("> EPH G05 CNAV\nG05")
    with pytest.raises(ParseError, match="satellite G05 as announced"):
        read_rinex_nav((cnav[:k] + "> EPH G05 CNAV\nG06" + cnav[k + 18:]).encode("latin-1"), name="bad.rnx")


def test_sbas_state_vector_propagation_agrees_with_rtklib():
    """SbasEphemeris.position_at (r + v dt + a dt^2/2, RTCA DO-229 A.4.4.11) equals RTKLIB's seph2pos 60 s and
    300 s after each record's epoch within 1 mm (RTKLIB evaluates the same polynomial; float rounding only)."""
    rk = require_module("pyrtklib", "RTKLIB reference reader")
    path = third_party_file(BRDM_V3)
    s = read_rinex_nav(path).sbas
    obs, rnav, sta = rk.obs_t(), rk.nav_t(), rk.sta_t()
    assert rk.readrnx(str(path), 1, "", obs, rnav, sta) == 1 and rnav.ns == len(s)
    for i in range(len(s)):
        for dt in (60.0, 300.0):
            rs, dts, var = rk.Arr1Ddouble(3), rk.Arr1Ddouble(1), rk.Arr1Ddouble(1)
            rk.seph2pos(rk.timeadd(rnav.seph[i].t0, dt), rnav.seph[i], rs, dts, var)
            ours = s.position_at(i, s.toc[i] + dt)
            np.testing.assert_allclose(ours, [rs[k] for k in range(3)], rtol=0, atol=1e-3)


def test_rinex4_every_record_of_a_day_kept():
    """DLR's 1-day RINEX 4.00 broadcast file: NavIC LNAV are ephemerides, SBAS state vectors, and the 2 300
    CNAV/CNV1/CNV2/STO/EOP/ION records are messages (none skipped); the first G05 CNAV record's numbers are those
    of its raw lines (file order, blanks NaN)."""
    nav = read_rinex_nav(third_party_file(BRD_V4))
    assert nav.skipped == {} and nav.warnings == []
    assert len(nav.kepler["I"]) == 283 and len(nav.sbas) == 9072
    kinds: dict = {}
    for m in nav.messages:
        kinds[(m.kind, m.msg_type)] = kinds.get((m.kind, m.msg_type), 0) + 1
    assert kinds[("EPH", "CNAV")] == 432 and kinds[("EPH", "CNV1")] == 634 and kinds[("EPH", "CNV2")] == 1024
    g05 = next(m for m in nav.messages if m.sat == "G05" and m.msg_type == "CNAV")
    assert g05.values[:4].tolist() == [-1.191107148770e-04, -1.470823463023e-12, 0.0, -6.441593170166e-03]
    assert g05.values.size == 3 + 4 * 8
    assert g05.values[-4:-2].tolist() == [1.2e+01, 2.252e+03] and np.isnan(g05.values[-2:]).all()
