"""The record layouts of the compiled update kernels (gnssatt.attitude.update_records) against the kernels' sources.

A kernel receives each record as a plain tuple and unpacks it in one line at its top, so nothing but the order of the
names ties the kernel to the layout: these tests parse the kernel modules with `ast` and check that every unpacking of
a record parameter names exactly the record's `_fields` in order, that a record parameter is otherwise only passed on
whole, that a record built inside a kernel (`model: VarianceModel = (...)`) names its fields in order, and that a
kernel annotated to return a record returns a tuple of exactly its fields.
"""
from __future__ import annotations

import ast
import textwrap

import pytest

from gnssatt.attitude import update_records
from tests.conftest import REPO_ROOT

#: the kernel modules whose parameters may be update_records records
KERNEL_MODULES = ("gnssatt/attitude/update_kernels.py", "gnssatt/attitude/kernels.py")
RECORDS = {r.__name__: r for r in update_records.RECORDS}


def _annotation_name(node) -> str | None:
    """The record name of an annotation (`rows: UsedRows` or `rows: "UsedRows"`), None if it names no record."""
    if isinstance(node, ast.Name):
        name = node.id
    elif isinstance(node, ast.Constant) and isinstance(node.value, str):
        name = node.value
    else:
        return None
    return name if name in RECORDS else None


def _body_after_docstring(fn: ast.FunctionDef) -> list:
    body = fn.body
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
        body = body[1:]
    return body


def _unpacking(stmt, params: dict) -> tuple[str, list[str]] | None:
    """(parameter, target names) if stmt is `a, b, ... = param` for a record parameter."""
    if (isinstance(stmt, ast.Assign) and len(stmt.targets) == 1 and isinstance(stmt.targets[0], ast.Tuple)
            and isinstance(stmt.value, ast.Name) and stmt.value.id in params):
        return stmt.value.id, [t.id if isinstance(t, ast.Name) else ast.unparse(t) for t in stmt.targets[0].elts]
    return None


def check_function(fn: ast.FunctionDef) -> list[str]:
    """Problems of one function's use of its record parameters and record return (empty: none)."""
    a = fn.args
    params = {p.arg: _annotation_name(p.annotation) for p in a.posonlyargs + a.args + a.kwonlyargs}
    params = {p: r for p, r in params.items() if r}
    bad = []
    body = _body_after_docstring(fn)
    top = []                                   # the unpackings at the top, before any other statement
    for stmt in body:
        u = _unpacking(stmt, params)
        if u is None:
            break
        top.append(stmt)
        name, targets = u
        fields = list(RECORDS[params[name]]._fields)
        if targets != fields:
            bad.append(f"{fn.name}: `{', '.join(targets)} = {name}` does not name {params[name]}._fields {fields}")
    seen = [_unpacking(s, params)[0] for s in top]
    for name in set(seen):
        if seen.count(name) > 1:
            bad.append(f"{fn.name}: {name} unpacked {seen.count(name)} times")
    # any other use of a record parameter: only passed on whole to a call
    passed_whole = set()
    for node in ast.walk(fn):
        if isinstance(node, ast.Call):
            passed_whole.update(id(x) for x in node.args if isinstance(x, ast.Name) and x.id in params)
    top_values = {id(s.value) for s in top}
    for node in ast.walk(fn):
        if isinstance(node, ast.Name) and node.id in params and id(node) not in passed_whole | top_values:
            bad.append(f"{fn.name}:{node.lineno}: record {node.id} used other than unpacked at the top or passed on")
    for node in ast.walk(fn):
        if isinstance(node, ast.AnnAssign) and _annotation_name(node.annotation):
            rec = _annotation_name(node.annotation)
            names = [e.id if isinstance(e, ast.Name) else ast.unparse(e) for e in node.value.elts] \
                if isinstance(node.value, ast.Tuple) else [ast.unparse(node.value)]
            if names != list(RECORDS[rec]._fields):
                bad.append(f"{fn.name}:{node.lineno}: {rec} built from ({', '.join(names)}), not its _fields")
    ret = _annotation_name(fn.returns)
    if ret:
        fields = list(RECORDS[ret]._fields)
        returns = [n for n in ast.walk(fn) if isinstance(n, ast.Return)]
        if not returns:
            bad.append(f"{fn.name}: annotated to return {ret} but has no return")
        for r in returns:
            names = [e.id if isinstance(e, ast.Name) else ast.unparse(e) for e in r.value.elts] \
                if isinstance(r.value, ast.Tuple) else [ast.unparse(r.value)]
            if names != fields:
                bad.append(f"{fn.name}:{r.lineno}: returns ({', '.join(names)}), not {ret}._fields {fields}")
    return bad


def _is_compiled(fn: ast.FunctionDef) -> bool:
    """Decorated with numba's njit (the kernels get plain tuples; Python helpers may get the NamedTuples)."""
    for d in fn.decorator_list:
        f = d.func if isinstance(d, ast.Call) else d
        if (f.id if isinstance(f, ast.Name) else getattr(f, "attr", None)) == "njit":
            return True
    return False


def _kernels(path: str) -> list[ast.FunctionDef]:
    tree = ast.parse((REPO_ROOT / path).read_text(encoding="utf-8"), filename=path)
    return [n for n in tree.body if isinstance(n, ast.FunctionDef) and _is_compiled(n)]


def _record_users() -> dict[str, ast.FunctionDef]:
    out = {}
    for path in KERNEL_MODULES:
        for fn in _kernels(path):
            a = fn.args
            if _annotation_name(fn.returns) or any(_annotation_name(p.annotation) for p in a.args):
                out[f"{path} {fn.name}"] = fn
    return out


def test_the_record_kernels_are_found():
    """The walk sees the kernels that take records (so the checks below are not vacuous)."""
    found = {k.split(" ")[1] for k in _record_users()}
    assert {"measurement_rows", "measurement_variances", "measurement_update", "update_epoch", "fix_newcomers",
            "round_newcomers_rows", "store_outputs"} <= found, found


@pytest.mark.parametrize("key", sorted(_record_users()))
def test_kernel_unpacks_each_record_in_field_order(key):
    assert not check_function(_record_users()[key])


def _parse_fn(src: str) -> ast.FunctionDef:
    return ast.parse(textwrap.dedent(src)).body[0]


def test_the_check_fails_on_a_wrong_order_a_second_unpacking_an_index_and_a_wrong_return():
    """The checker itself: a swapped field, a second unpacking, an indexed record and a short return are found."""
    swapped = _parse_fn('''
        def k(fix: FixState):
            amb_key, amb_fixed = fix
            return amb_key
    ''')
    assert any("does not name FixState._fields" in p for p in check_function(swapped))
    twice = _parse_fn('''
        def k(fix: FixState):
            amb_fixed, amb_key = fix
            amb_fixed, amb_key = fix
    ''')
    assert any("unpacked 2 times" in p for p in check_function(twice))
    indexed = _parse_fn('''
        def k(fix: FixState):
            """doc"""
            x = 1
            return fix[0]
    ''')
    assert any("used other than unpacked" in p for p in check_function(indexed))
    short = _parse_fn('''
        def k(rows: UsedRows) -> EpochStatus:
            jc, sc, fc, jp, sp, fp = rows
            return baseline_ok, n_used, ever_fixed
    ''')
    assert any("not EpochStatus._fields" in p for p in check_function(short))
    built = _parse_fn('''
        def k(x):
            fix: FixState = (amb_key, amb_fixed)
            return inner(fix)
    ''')
    assert any("FixState built from" in p for p in check_function(built))
    good = _parse_fn('''
        def k(x, fix: FixState, limits: "RoundingLimits"):
            """doc"""
            amb_fixed, amb_key = fix
            max_sigma_cyc, max_frac_cyc, var_cyc2 = limits
            return inner(x, fix, limits)
    ''')
    assert check_function(good) == []


def test_every_record_field_has_a_comment():
    """Each field line of update_records carries its one-line comment (units, shape, frame)."""
    path = REPO_ROOT / "gnssatt/attitude/update_records.py"
    lines = path.read_text(encoding="utf-8").splitlines()
    tree = ast.parse("\n".join(lines))
    classes = [n for n in tree.body if isinstance(n, ast.ClassDef) and n.name in RECORDS]
    assert len(classes) == len(RECORDS)
    for cls in classes:
        fields = [s for s in cls.body if isinstance(s, ast.AnnAssign)]
        assert [f.target.id for f in fields] == list(RECORDS[cls.name]._fields)
        for f in fields:
            assert "#" in lines[f.lineno - 1], f"{cls.name}.{f.target.id}: no comment"


@pytest.mark.parametrize("record", update_records.RECORDS, ids=lambda r: r.__name__)
def test_plain_builds_the_plain_tuple_by_keyword_only(record):
    """Record.plain(**fields) is tuple(Record(**fields)); positional, missing and unknown fields are refused."""
    fields = {name: object() for name in record._fields}
    built = record.plain(**fields)
    assert type(built) is tuple and built == tuple(record(**fields))
    with pytest.raises(TypeError):
        record.plain(*fields.values())
    with pytest.raises(TypeError):
        record.plain(**{k: v for k, v in list(fields.items())[1:]})
    with pytest.raises(TypeError):
        record.plain(**fields, not_a_field=1)
