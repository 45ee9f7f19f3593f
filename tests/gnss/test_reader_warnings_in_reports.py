"""The readers' quirk warnings reach the attitude and calibration jobs' summary.json and report.html
(docs/reader_policy.md: a quirk is read with a structured warning in the set's summary and the job's report)."""
from __future__ import annotations

import re
from types import SimpleNamespace

from bench.corpus_check import load_manifest
from gnssatt.gnss.io.errors import ParseWarning

from gnssatt.gnss.io.reader_warnings import reader_warnings
from gnssatt.gnss.io.sniff import identify
from gnssatt.report import html_report
from tests.corpus.third_party import third_party_file

ROVN = "georust+rinex/test_resources/OBS/V2/rovn0010.21o"   # truncated last epoch (a quirk)


def _set_of(*rels: str, name: str = "set-a"):
    files = []
    for rel in rels:
        base = rel.rsplit("/", 1)[1]
        kind, summary = identify(third_party_file(rel), base)
        files.append(SimpleNamespace(name=base, kind=kind, summary=summary))
    return SimpleNamespace(id="id-1", name=name, files=files)


def test_reader_warnings_of_a_set_with_a_quirky_file():
    """The upload summary's warnings become rows naming set, file, code, line and text; a file without
    warnings adds none."""
    rows = reader_warnings([_set_of(ROVN)])
    codes = {r["code"] for r in rows}
    assert "truncated-last-epoch" in codes
    trunc = next(r for r in rows if r["code"] == "truncated-last-epoch")
    assert trunc["set"] == "set-a" and trunc["file"] == "rovn0010.21o" and isinstance(trunc["line"], int)
    assert "last epoch" in trunc["message"]
    clean = SimpleNamespace(name="b", files=[SimpleNamespace(name="x.21o", summary={"warnings": []})])
    assert reader_warnings([clean]) == [] and reader_warnings([]) == []


def test_report_shows_reader_warnings_as_code_and_text():
    """report.html (every job's html_report) has a table of the warnings with their code and text, before the
    raw summary keys, which no longer repeat them."""
    rows = reader_warnings([_set_of(ROVN)])
    html = html_report("Attitude", {"epochs": 3, "reader_warnings": rows}, None)
    assert "Input files read with warnings" in html
    assert "truncated-last-epoch" in html and "rovn0010.21o" in html
    assert html.index("Input files read with warnings") < html.index("<h2>Summary</h2>")
    assert "reader_warnings" not in html
    assert "Input files read with warnings" not in html_report("Attitude", {"epochs": 3, "reader_warnings": []},
                                                              None)


def test_calibration_summary_carries_the_reader_warnings():
    """The calibration job's summary.json (gnssatt.calibration.products) lists CampaignResult.reader_warnings,
    which run_campaign fills from the sets' files."""
    import inspect

    from gnssatt.calibration import api, products

    assert "reader_warnings(cal_sets + held)" in inspect.getsource(api._finish)
    assert '"reader_warnings"' in inspect.getsource(products)
    assert api.CampaignResult.__dataclass_fields__["reader_warnings"].default_factory() == []



CODE_STYLE = re.compile(r"[a-z0-9]+(-[a-z0-9]+)*(:.+)?")


def test_one_warning_code_style_for_every_reader():
    """docs/reader_policy.md: lower-case words joined by '-', optional ':detail'. ParseWarning enforces it, and
    every code the corpus manifest expects (observation, navigation, SP3, clock and ANTEX readers; the corpus
    test asserts the readers give exactly these) has that form."""
    assert ParseWarning("LEAP_TABLE_EXPIRED", "m").code == "leap-table-expired"
    assert ParseWarning("UNSUPPORTED_RECORD:EPH X", "m", 3).to_dict() == {
        "code": "unsupported-record:EPH X", "message": "m", "line_no": 3}
    assert ParseWarning("truncated-last-epoch", "m").code == "truncated-last-epoch"
    codes = {c for r in load_manifest() if r.label == "quirk" for c in r.expect.split(";")}
    kinds = {r.kind for r in load_manifest() if r.label == "quirk"}
    assert len(codes) > 30 and kinds == {"obs", "nav", "sp3", "clk", "atx"}
    assert [c for c in codes if not CODE_STYLE.fullmatch(c)] == []
