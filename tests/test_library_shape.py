"""Library shape (issue 15 Done-when): no function in `gnssatt/` over 150 lines, none with more than 12 parameters.

Parameters count positional, positional-only and keyword-only arguments, excluding self/cls (*args and
**kwargs are not counted). Lines count from the `def` line to the function's last line, docstring included.
"""
from __future__ import annotations

import ast

from tests.conftest import REPO_ROOT

MAX_LINES = 150
MAX_PARAMS = 12


def _offenders() -> list[str]:
    out = []
    for path in sorted((REPO_ROOT / "gnssatt").rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            a = node.args
            names = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]
            if names and names[0] in ("self", "cls"):
                names = names[1:]
            n_lines = node.end_lineno - node.lineno + 1
            where = f"{path.relative_to(REPO_ROOT).as_posix()}:{node.lineno} {node.name}"
            if n_lines > MAX_LINES:
                out.append(f"{where}: {n_lines} lines (> {MAX_LINES})")
            if len(names) > MAX_PARAMS:
                out.append(f"{where}: {len(names)} parameters (> {MAX_PARAMS})")
    return out


def test_the_walk_sees_the_library():
    assert (REPO_ROOT / "gnssatt" / "gnss" / "positioning.py").is_file()


def test_no_long_function_and_no_long_parameter_list():
    """The compiled attitude kernels too: they take a few records (gnssatt.attitude.qc_records, update_records)."""
    bad = _offenders()
    assert not bad, "functions to split:\n" + "\n".join(bad)
