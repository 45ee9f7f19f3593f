"""Shared helpers for benchmark scripts: machine description and docs/BENCHMARKS.md section updates."""
from __future__ import annotations

import os
import platform
import re
import subprocess
from datetime import date
from pathlib import Path


def cpu_model(default: str = "unknown CPU") -> str:
    """The CPU's model name from /proc/cpuinfo (Linux), or `default`."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return default


def machine_line() -> str:
    cpu = cpu_model()
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                                cwd=Path(__file__).parent).stdout.strip()
    except OSError:
        commit = "?"
    mem_gib = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    return (f"{os.cpu_count()} cores, {cpu}, {mem_gib:.0f} GiB, Python {platform.python_version()}, "
            f"commit {commit}, {date.today().isoformat()}")


def replace_section(path: Path, title: str, body: str) -> None:
    """Replace (or append) the `## title` section of a markdown file, leaving other sections alone."""
    text = path.read_text() if path.exists() else "# Benchmarks\n"
    block = f"## {title}\n\n{body.strip()}\n"
    pattern = re.compile(rf"^## {re.escape(title)}\n.*?(?=^## |\Z)", re.S | re.M)
    if pattern.search(text):
        text = pattern.sub(lambda _: block + "\n", text)
    else:
        text = text.rstrip() + "\n\n" + block
    path.write_text(text.rstrip() + "\n")


def prepend_to_section(path: Path, title: str, body: str) -> None:
    """Put `body` first in the `## title` section of a markdown file, keeping what the section held below it
    (a dated history of hand-written figures); a new section at the end if there is none."""
    text = path.read_text() if path.exists() else "# Benchmarks\n"
    heading = re.compile(rf"^## {re.escape(title)}\n\n?", re.M)
    m = heading.search(text)
    if m is None:
        text = text.rstrip() + f"\n\n## {title}\n\n{body.strip()}\n"
    else:
        text = text[:m.end()] + body.strip() + "\n\n" + text[m.end():]
    path.write_text(text.rstrip() + "\n")
