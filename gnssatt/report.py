"""A job's report as one self-contained HTML file (plots embedded as base64 PNG, inline CSS, no scripts),
that can be saved, mailed and opened offline. The attitude, calibration and ttff pipelines write it as
`report.html`:

    from gnssatt.report import html_report
    ctx.write_product("report.html", html_report(f"Attitude of {set_name}", summary, {"Euler angles": png}, tables))

Never imports web code.
"""
from __future__ import annotations

import base64
import datetime as _dt
import html
import json
import math
from typing import Any, Mapping, Sequence

_CSS = """
body{font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;color:#1d2733;max-width:1100px;
margin:0 auto;padding:24px}
h1{font-size:22px;margin:0 0 4px}h2{font-size:17px;margin:28px 0 8px;border-bottom:1px solid #d8dee6;padding-bottom:4px}
.meta{color:#5a6775;font-size:12px;margin-bottom:16px}
table{border-collapse:collapse;margin:6px 0 12px;font-size:13px}
th,td{border:1px solid #d8dee6;padding:3px 8px;text-align:right;vertical-align:top}
th{background:#eef2f7;text-align:center}td.k{text-align:left;color:#3c4957;background:#f7f9fb}
tfoot td{font-weight:600;background:#f3f3f3}
figure{margin:10px 0 24px}figure img{max-width:100%;height:auto;border:1px solid #e3e8ee}
figcaption{font-size:12px;color:#5a6775}
.verdict{display:inline-block;padding:1px 8px;border-radius:10px;font-size:12px;font-weight:600;text-transform:uppercase}
.verdict-pass{background:#e3f3e7;color:#237a3b}.verdict-check{background:#fff3dc;color:#a86400}
.verdict-fail{background:#fde4e2;color:#b3261e}.verdict-info{background:#eef2f7;color:#5a6775}
table.quality td,table.quality th{text-align:left}pre.config{background:#f7f9fb;padding:6px 8px;font-size:12px;
white-space:pre-wrap;overflow-wrap:anywhere}details summary{cursor:pointer;color:#1f5fa8}
@media print{body{padding:0}figure{break-inside:avoid}details>*{display:block}}
"""


def _esc(value: Any) -> str:
    return html.escape(str(value), quote=True)


def format_value(value: Any) -> str:
    """Text of a summary value: "–" for None and NaN, yes/no, 6 significant digits, short lists joined, other
    containers as (truncated) JSON. Shared by report.html and the job pages (app/routes/pages.py)."""
    if value is None:
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        if math.isnan(value):
            return "–"
        return f"{value:.6g}"
    if isinstance(value, (list, tuple)) and all(not isinstance(v, (dict, list, tuple)) for v in value):
        return ", ".join(format_value(v) for v in value)
    if isinstance(value, (dict, list, tuple)):
        return json.dumps(value, default=str)[:500]
    return str(value)


def flatten_summary(summary: Mapping[str, Any], prefix: str = "", depth: int = 3) -> list[tuple[str, Any]]:
    """(dotted key, value) pairs of a nested summary dict, nested dicts expanded up to `depth` levels."""
    out: list[tuple[str, Any]] = []
    for key, value in summary.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping) and depth > 1:
            out.extend(flatten_summary(value, name + ".", depth - 1))
        else:
            out.append((name, value))
    return out


def _table_html(name: str, table: Any) -> str:
    """A table given as a list of row dicts, or {"columns": [...], "rows": [[...]], "footer": [[...]]}, or
    a (columns, rows) pair."""
    if isinstance(table, Mapping):
        columns, rows, footer = list(table.get("columns", [])), table.get("rows", []), table.get("footer", [])
    elif isinstance(table, tuple) and len(table) == 2:
        columns, rows, footer = list(table[0]), table[1], []
    else:
        rows_d = list(table)
        columns = list(dict.fromkeys(k for r in rows_d for k in r))
        rows, footer = [[r.get(c) for c in columns] for r in rows_d], []
    head = "".join(f"<th>{_esc(c)}</th>" for c in columns)
    body = "".join("<tr>" + "".join(f"<td>{_esc(format_value(v))}</td>" for v in row) + "</tr>" for row in rows)
    foot = "".join("<tr>" + "".join(f"<td>{_esc(format_value(v))}</td>" for v in row) + "</tr>" for row in footer)
    return (f"<h2>{_esc(name)}</h2><table><thead><tr>{head}</tr></thead><tbody>{body}</tbody>"
            + (f"<tfoot>{foot}</tfoot>" if foot else "") + "</table>")


def quality_html(quality: Mapping[str, Any]) -> str:
    """The quality block of summary.json (gnssatt.attitude.quality) as a verdict table and the epoch lists."""
    verdict = _esc(quality.get("verdict", ""))
    rows = "".join(f"<tr><th>{_esc(it.get('label'))}</th><td>{_esc(it.get('text'))}</td>"
                   f"<td><span class=\"verdict verdict-{_esc(it.get('verdict'))}\">{_esc(it.get('verdict'))}</span></td>"
                   f"<td>{_esc(it.get('threshold'))}</td></tr>" for it in quality.get("items", []))
    parts = [f"<h2>Quality <span class=\"verdict verdict-{verdict}\">{verdict}</span></h2>"
             f"<table class=\"quality\"><thead><tr><th>item</th><th>result</th><th>verdict</th><th>threshold</th></tr>"
             f"</thead><tbody>{rows}</tbody></table>"]
    for key, name in (("wrong_fixes", "Wrong fixes"), ("over_1deg", "Fixed epochs over 1 deg (not wrong fixes)")):
        lst = quality.get(key) or []
        if lst:
            body = "".join(f"<tr><td>{_esc(e['time_gps'])}</td><td>{_esc(e['axis'])}</td><td>{e['error_deg']:+.3f}</td>"
                           f"<td>{e['sigma_deg']:.3f}</td><td>{_esc(e['label'])}</td></tr>" for e in lst)
            parts.append(f"<details><summary>{_esc(name)}: {len(lst)}</summary><table><thead><tr><th>GPS time</th>"
                         f"<th>axis</th><th>error [deg]</th><th>sigma [deg]</th><th>label</th></tr></thead>"
                         f"<tbody>{body}</tbody></table></details>")
    return "".join(parts)


def html_report(title: str, summary: Mapping[str, Any] | None, plots: Mapping[str, bytes] | None,
                tables: Mapping[str, Any] | Sequence[tuple[str, Any]] | None = None,
                generated_at: _dt.datetime | None = None, config: Mapping[str, Any] | None = None) -> str:
    """One self-contained HTML document: title, summary numbers as a key/value table, each table, and each
    plot as an inline `data:image/png;base64` image with its name as caption. All text is HTML-escaped.

    Args:
        title: the report's heading (e.g. "Attitude of set X, job Y").
        summary: summary.json content; nested dicts are flattened to dotted keys.
        plots: {caption: PNG bytes} in display order.
        tables: {name: rows} where rows are a list of dicts, a (columns, rows) pair, or
            {"columns", "rows", "footer"} (e.g. gnssatt.plots.ttff.table5()).
        generated_at: time stamp printed under the title (default: now, UTC).
        config: the job's configuration, shown once (the plots' titles need not repeat it).

    A `quality` block in the summary (attitude jobs) comes first as a verdict table, then `reader_warnings`
    (gnssatt.gnss.io.reader_warnings: the input files' quirk warnings) as a table; the raw summary keys follow
    in a collapsed section, with sensible digits (format_value).
    """
    when = (generated_at or _dt.datetime.now(_dt.timezone.utc)).strftime("%Y-%m-%d %H:%M:%S UTC")
    parts = [f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
             f"<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
             f"<title>{_esc(title)}</title><style>{_CSS}</style></head><body>",
             f"<h1>{_esc(title)}</h1><div class=\"meta\">gnssatt report · generated {when} · times in GPS time</div>"]
    quality = summary.get("quality") if isinstance(summary, Mapping) else None
    if isinstance(quality, Mapping):
        parts.append(quality_html(quality))
    quirks = summary.get("reader_warnings") if isinstance(summary, Mapping) else None
    if quirks:   # docs/reader_policy.md: files read with a quirk, shown as code + text
        parts.append(_table_html("Input files read with warnings (docs/reader_policy.md)", quirks))
    if summary:
        rows = "".join(f"<tr><td class=\"k\">{_esc(k)}</td><td>{_esc(format_value(v))}</td></tr>"
                       for k, v in flatten_summary({k: v for k, v in summary.items()
                                                    if k not in ("quality", "reader_warnings")}))
        table = f"<table class=\"summary\"><tbody>{rows}</tbody></table>"
        parts.append(f"<details><summary>All summary keys (raw summary.json)</summary>{table}</details>"
                     if isinstance(quality, Mapping) else f"<h2>Summary</h2>{table}")
    if config:
        parts.append(f"<h2>Configuration</h2><pre class=\"config\">"
                     f"{_esc(json.dumps(config, indent=2, sort_keys=True, default=str))}</pre>")
    items = tables.items() if isinstance(tables, Mapping) else (tables or [])
    for name, table in items:
        parts.append(_table_html(name, table))
    if plots:
        parts.append("<h2>Plots</h2>")
        for name, png in plots.items():
            data = base64.b64encode(png).decode("ascii")
            parts.append(f"<figure><img alt=\"{_esc(name)}\" src=\"data:image/png;base64,{data}\">"
                         f"<figcaption>{_esc(name)}</figcaption></figure>")
    parts.append("</body></html>\n")
    return "".join(parts)
