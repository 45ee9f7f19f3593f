"""bench._report's docs/BENCHMARKS.md section writers: a replaced section leaves the others alone, a prepended one
keeps what the section held (the hand-written history bench_attitude_speed.py --write used to wipe)."""
from __future__ import annotations

from bench._report import prepend_to_section, replace_section

DOC = "# Benchmarks\n\n## A\n\nold A\n\n## Speed\n\n**2026-12-06** hand-written figures.\n\nolder table\n\n## B\n\nb\n"


def test_prepend_keeps_the_section_history_and_the_other_sections(tmp_path):
    p = tmp_path / "BENCHMARKS.md"
    p.write_text(DOC)
    prepend_to_section(p, "Speed", "Machine: new run\n\n| table |")
    text = p.read_text()
    speed = text.split("## Speed\n\n", 1)[1].split("\n## B", 1)[0]
    assert speed.startswith("Machine: new run\n\n| table |\n\n**2026-12-06** hand-written figures.")
    assert "older table" in speed
    assert "## A\n\nold A\n" in text and text.endswith("## B\n\nb\n")


def test_prepend_to_a_missing_section_appends_it(tmp_path):
    p = tmp_path / "BENCHMARKS.md"
    p.write_text(DOC)
    prepend_to_section(p, "New", "figures")
    assert p.read_text().endswith("## B\n\nb\n\n## New\n\nfigures\n")


def test_replace_drops_only_that_section(tmp_path):
    p = tmp_path / "BENCHMARKS.md"
    p.write_text(DOC)
    replace_section(p, "Speed", "fresh")
    text = p.read_text()
    assert "hand-written" not in text and "## Speed\n\nfresh\n" in text and "old A" in text and "\nb\n" in text
