"""Benchmarks import no test code (issue 15 item 6), and the bench modules do not import each other in a loop.

Every `import` / `from ... import` statement of every bench/*.py is read from its syntax tree, at module level and
inside functions and classes (the benches import most things lazily), so a lazy `from tests... import` fails too.
Shared helpers live in the library (gnssatt/...), in client/local_service.py or in bench/ itself; tests may import
those, never the other way round.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

from tests.conftest import REPO_ROOT

BENCH_FILES = sorted((REPO_ROOT / "bench").glob("*.py"))


def imported_modules(path: Path) -> list[tuple[int, str]]:
    """(line, absolute module name) of every import statement in the file, wherever it sits; relative imports are
    resolved against the bench package."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = ".".join(["bench"][: max(0, 1 - (node.level - 1))])
                module = ".".join(p for p in (base, node.module) if p)
            else:
                module = node.module or ""
            out.append((node.lineno, module))
            # `from bench import x` imports the module bench.x when x is one
            out += [(node.lineno, f"{module}.{alias.name}") for alias in node.names
                    if (REPO_ROOT / module.replace(".", "/") / f"{alias.name}.py").is_file()]
    return out


def test_the_bench_files_are_found_and_their_lazy_imports_seen():
    names = {p.name for p in BENCH_FILES}
    assert {"bench_attitude.py", "bench_ttff.py", "bench_ttff_rtklib.py", "bench_lambda.py"} <= names
    # bench_ttff imports bench._ttff_common at module level and bench.bench_ttff_rtklib inside report()
    mods = {m for _, m in imported_modules(REPO_ROOT / "bench" / "bench_ttff.py")}
    assert "bench._ttff_common" in mods and "bench.bench_ttff_rtklib" in mods


@pytest.mark.parametrize("path", BENCH_FILES, ids=lambda p: p.name)
def test_bench_module_imports_no_test_code(path):
    bad = [f"line {line}: {module}" for line, module in imported_modules(path)
           if module == "tests" or module.startswith("tests.")]
    assert not bad, f"bench/{path.name} imports test code: {bad}"


def test_bench_modules_import_each_other_without_a_cycle():
    graph = {f"bench.{p.stem}": {m for _, m in imported_modules(p) if m.startswith("bench.")} for p in BENCH_FILES}
    state: dict[str, int] = {}          # 1 on the current path, 2 done

    def visit(node: str, path: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                pytest.fail("import cycle: " + " -> ".join(path[path.index(nxt):] + [nxt]))
            if nxt in graph and state.get(nxt) is None:
                visit(nxt, path + [nxt])
        state[node] = 2

    for module in sorted(graph):
        if state.get(module) is None:
            visit(module, [module])
