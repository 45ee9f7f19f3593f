"""The compiled kernels' record layouts (issue 15, item 4): every record a kernel takes is a typing.NamedTuple of
a gnssatt/attitude/*_records.py module (not the readable reference_*), passed as a plain tuple and unpacked
inside the kernel in one statement. Numba unpacks a tuple by position, so a line that names the fields in another
order (or misses one) would silently read the wrong arrays: these tests parse the kernel sources and compare each
unpacking with the record's `_fields`. A kernel parameter is a record when its annotation names one
(`def qc_epoch(sd: SdEpoch, ...)`). The keyword builders of the per-epoch records are checked against the
NamedTuples, and every field must carry its comment."""
from __future__ import annotations

import ast
import importlib
import io
import tokenize

from tests.conftest import REPO_ROOT

ATTITUDE = REPO_ROOT / "gnssatt" / "attitude"
KERNEL_FILES = sorted(ATTITUDE.glob("*kernels.py"))
RECORD_FILES = sorted(p for p in ATTITUDE.glob("*_records.py") if not p.name.startswith("reference_"))


def _layouts() -> dict[str, tuple[str, ...]]:
    """Record name -> its fields, over the NamedTuples defined in the record modules."""
    out = {}
    for path in RECORD_FILES:
        mod = importlib.import_module(f"gnssatt.attitude.{path.stem}")
        for name, obj in vars(mod).items():
            if isinstance(obj, type) and issubclass(obj, tuple) and hasattr(obj, "_fields") \
                    and obj.__module__ == mod.__name__:
                out[name] = tuple(obj._fields)
    return out


def _annotation_name(node) -> str | None:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return node.attr
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value.rsplit(".", 1)[-1]
    return None


def record_unpackings(source: str, layouts: dict) -> list[tuple]:
    """(function, parameter, record, unpacked names) of every `a, b, ... = param` of a record parameter,
    and (function, parameter, record, None) for a record parameter never unpacked."""
    rows = []
    for fn in ast.walk(ast.parse(source)):
        if not isinstance(fn, ast.FunctionDef):
            continue
        params = {a.arg: _annotation_name(a.annotation) for a in fn.args.posonlyargs + fn.args.args
                  if a.annotation is not None and _annotation_name(a.annotation) in layouts}
        seen = set()
        for node in ast.walk(fn):
            if (isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Tuple)
                    and isinstance(node.value, ast.Name) and node.value.id in params):
                names = tuple(e.id if isinstance(e, ast.Name) else ast.unparse(e) for e in node.targets[0].elts)
                rows.append((fn.name, node.value.id, params[node.value.id], names))
                seen.add(node.value.id)
        rows += [(fn.name, p, rec, None) for p, rec in params.items() if p not in seen]
    return rows


def mismatches(source: str, layouts: dict) -> list[str]:
    """The unpackings of record parameters that do not name the record's fields in order (one statement, which may
    span lines), and record parameters unpacked more than once."""
    bad, count = [], {}
    for fn, param, rec, names in record_unpackings(source, layouts):
        if names is None:
            continue                                     # passed on whole (e.g. td_checks -> white_noise_update)
        count[fn, param] = count.get((fn, param), 0) + 1
        if names != layouts[rec]:
            bad.append(f"{fn}: {param} ({rec}) unpacked as {', '.join(names)}; fields {', '.join(layouts[rec])}")
    bad += [f"{fn}: {param} unpacked {n} times" for (fn, param), n in count.items() if n > 1]
    return bad


def test_the_record_modules_are_found():
    layouts = _layouts()
    assert {"SdBlockQc", "SdBlockFlags", "AntennaView", "EpochStep", "EpochMemory", "EpochClock", "QcLimits", "QcWork",
            "AmbiguityBook", "TripleDifferences", "WhiteNoise", "OutputEpoch", "PostFit",
            "ResidualBuffers"} <= set(layouts)


def test_every_record_unpacking_names_the_fields_in_order():
    layouts = _layouts()
    bad = []
    for path in KERNEL_FILES:
        bad += [f"{path.name} {m}" for m in mismatches(path.read_text(encoding="utf-8"), layouts)]
    assert not bad, "\n".join(bad)


def test_the_qc_kernels_take_records_and_unpack_them():
    """qc_epoch, td_checks, record_epoch and white_noise_update unpack each of their records (td_checks passes
    its WhiteNoise on to white_noise_update whole)."""
    layouts = _layouts()
    rows = []
    for name in ("qc_kernels.py", "kernels.py"):
        rows += record_unpackings((ATTITUDE / name).read_text(encoding="utf-8"), layouts)
    qc = ("qc_epoch", "td_checks", "record_epoch", "white_noise_update")      # kernels.py has update kernels too
    got = {(fn, rec) for fn, _, rec, names in rows if names is not None and fn in qc}
    passed_on = {(fn, rec) for fn, _, rec, names in rows if names is None and fn in qc}
    assert got == {("qc_epoch", r) for r in ("SdBlockQc", "SdBlockFlags", "AntennaView", "EpochStep", "EpochMemory",
                                             "EpochClock", "QcLimits", "QcWork")} \
        | {("td_checks", r) for r in ("SdBlockFlags", "EpochStep", "AmbiguityBook", "EpochMemory", "QcLimits",
                                      "QcWork")} \
        | {("record_epoch", r) for r in ("SdBlockFlags", "OutputEpoch", "PostFit", "QcWork", "EpochMemory",
                                         "ResidualBuffers")} \
        | {("white_noise_update", r) for r in ("TripleDifferences", "WhiteNoise")}
    assert passed_on == {("td_checks", "WhiteNoise")}


def test_the_keyword_builders_give_the_records_tuples():
    """qc_records' per-epoch builders (fields by keyword) return exactly tuple(Record(...)), and refuse a missing
    or unknown field."""
    import pytest

    from gnssatt.attitude import qc_records as QR

    builders = {QR.AntennaView: QR.antenna_view, QR.EpochStep: QR.epoch_step, QR.AmbiguityBook: QR.ambiguity_book,
                QR.OutputEpoch: QR.output_epoch, QR.PostFit: QR.post_fit}
    for record, build in builders.items():
        values = {f: object() for f in record._fields}            # distinct sentinels: an order mix-up shows
        got = build(**values)
        assert type(got) is tuple and got == tuple(record(**values)), record.__name__
        with pytest.raises(TypeError):
            build(**dict(list(values.items())[1:]))
        with pytest.raises(TypeError):
            build(**values, not_a_field=1)
        with pytest.raises(TypeError):
            build(*values.values())


def test_a_wrong_unpacking_is_caught():
    """The check itself: fields swapped, one missing, two unpackings; a statement over two lines is fine."""
    layouts = {"Rec": ("a_m", "b_s", "c")}
    good = "def k(r: Rec):\n    a_m, b_s, c = r\n"
    assert mismatches(good, layouts) == []
    assert mismatches(good.replace("a_m, b_s", "b_s, a_m"), layouts)
    assert mismatches(good.replace("a_m, b_s, c", "a_m, b_s"), layouts)
    assert not mismatches("def k(r: 'Rec'):\n    (a_m, b_s,\n     c) = r\n", layouts)     # one statement, two lines
    assert mismatches(good + "    a_m, b_s, c = r\n", layouts)
    assert mismatches("def k(r: Rec):\n    x, b_s, c = r\n", layouts)


def test_every_record_field_has_its_comment():
    """One comment per field (unit, shape, frame) on the field's line."""
    missing = []
    for path in RECORD_FILES:
        text = path.read_text(encoding="utf-8")
        commented = {tok.start[0] for tok in tokenize.generate_tokens(io.StringIO(text).readline)
                     if tok.type == tokenize.COMMENT}
        for cls in ast.walk(ast.parse(text)):
            if isinstance(cls, ast.ClassDef):
                for item in cls.body:
                    if isinstance(item, ast.AnnAssign) and item.lineno not in commented:
                        missing.append(f"{path.name}:{item.lineno} {cls.name}.{ast.unparse(item.target)}")
    assert RECORD_FILES and not missing, "fields without a comment:\n" + "\n".join(missing)
