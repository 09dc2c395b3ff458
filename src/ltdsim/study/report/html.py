"""The report pages' building blocks: the style sheet, HTML tables whose numeric columns
share one format, figures embedded as data (pages that work offline), CSV tables linked
from the page, the verdict marks, and short number formats."""

from __future__ import annotations

import base64
import html
import math
from pathlib import Path

import numpy as np
import pandas as pd

from ltdsim.results.io import atomic_path

CSS = """
body{font-family:system-ui,sans-serif;max-width:1200px;margin:1.5em auto;padding:0 1em;
color:#222;line-height:1.45;font-size:16px}
h1{font-size:1.5em}h2{margin-top:2em;border-bottom:1px solid #ccc;font-size:1.25em}
h3{font-size:1.05em}
.tbl{max-width:100%;overflow-x:auto}
table{border-collapse:collapse;font-size:.85em;margin:.6em 0}
td,th{border:1px solid #ccc;padding:3px 6px;vertical-align:top}
th{background:#f2f2f2;font-weight:600;text-align:center}
td.num{text-align:right;white-space:nowrap;font-variant-numeric:tabular-nums}
td.txt{text-align:left}
figure{margin:1em 0}img{max-width:100%;height:auto;border:1px solid #eee}
figcaption{font-size:.9em;color:#444}.note{color:#444;font-size:.92em}
.take{background:#f6f9ff;border-left:4px solid #4a78c2;padding:.4em 1em}
.banner{background:#fff4e0;border:2px solid #d08000;padding:.5em 1em;margin:1em 0}
.yes{color:#17692b;font-weight:600}.no{color:#a8201a;font-weight:600}
.partly{color:#8a5a00;font-weight:600}.na{color:#666}
"""

DASH = "\u2013"


def is_num(v) -> bool:
    """Whether ``v`` is a number (a bool is not)."""
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)


def column_format(values, sig: int = 4):
    """One number format for a column of numbers: fixed decimals chosen so that the
    largest magnitude shows ``sig`` significant figures (integers without decimals), or
    scientific notation with ``sig - 1`` decimals when its largest magnitude is below
    1e-3 or from 1e6 up. Returns a function number -> text; NaN reads as a dash."""
    finite = [float(v) for v in values if is_num(v) and math.isfinite(float(v))]
    integral = bool(finite) and all(float(v).is_integer() and abs(v) < 1e15 for v in finite)
    top = max((abs(v) for v in finite), default=0.0)

    def fmt(v):
        if not is_num(v) or not math.isfinite(float(v)):
            return DASH if is_num(v) and math.isnan(float(v)) else html.escape(str(v))
        return spec.format(float(v))

    if integral:
        spec = "{:,.0f}"
    elif top >= 1e6 or 0 < top < 1e-3:
        spec = "{:.%de}" % (sig - 1)
    else:
        decimals = 0 if top == 0 else min(max(sig - 1 - math.floor(math.log10(top)), 0), 6)
        spec = "{:,.%df}" % decimals
    return fmt


def table_html(df: pd.DataFrame, sig: int = 4) -> str:
    """An HTML table: headers as given (they carry the units), every numeric column in
    one format (:func:`column_format`), text left, numbers right, missing values as a
    dash. Cells whose text starts with ``<span`` are trusted HTML (the verdict marks)."""
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in df.columns)
    fmts = [column_format(df[c].tolist(), sig) for c in df.columns]
    rows = []
    for row in df.itertuples(index=False):
        cells = []
        for v, fmt in zip(row, fmts):
            if is_num(v):
                cells.append(f"<td class='num'>{fmt(v)}</td>")
            elif isinstance(v, str) and v.startswith("<span"):
                cells.append(f"<td class='txt'>{v}</td>")
            else:
                cells.append(f"<td class='txt'>{html.escape('' if v is None else str(v))}</td>")
        rows.append("<tr>" + "".join(cells) + "</tr>")
    return (f"<div class='tbl'><table><thead><tr>{head}</tr></thead><tbody>"
            + "".join(rows) + "</tbody></table></div>")


def figure_html(path: Path, caption: str) -> str:
    """A ``<figure>`` with the PNG embedded (base64), so the page works offline."""
    data = base64.b64encode(Path(path).read_bytes()).decode()
    return (f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")


def csv_table(df: pd.DataFrame, out: Path, name: str) -> str:
    """Write ``df`` as CSV (at most 6 significant figures, also in columns that mix
    numbers with words such as "unbounded") and link it."""
    df = df.copy()
    for col in df.columns[df.dtypes == object]:
        df[col] = [f"{v:.6g}" if is_num(v) else v for v in df[col]]
    with atomic_path(out / name) as tmp:
        df.to_csv(tmp, index=False, float_format="%.6g")
    return f'<p class="note">CSV: <a href="{name}">{name}</a></p>'


def verdict(v: str) -> str:
    """The verdict mark of a side-by-side row: yes, no, partly or another word (grey)."""
    cls = {"yes": "yes", "no": "no", "partly": "partly"}.get(v, "na")
    return f"<span class='{cls}'>{html.escape(v)}</span>"


def number_or(value, text):
    """A number, or ``text`` where the metric does not exist (NaN or infinite)."""
    return value if is_num(value) and math.isfinite(float(value)) else text


def kn(x) -> float:
    """A force in N as kN."""
    return float(x) / 1e3


def spearman(a, b) -> float:
    """Spearman's rank correlation of ``a`` and ``b`` (NaN for fewer than three pairs)."""
    from scipy.stats import spearmanr

    return float(spearmanr(a, b).statistic) if len(a) > 2 else float("nan")


def span(values, spec: str = ".3g") -> str:
    """"a-b" for a range of numbers ("a to b" when either is negative), or the single
    value when they are all equal."""
    lo, hi = float(np.min(values)), float(np.max(values))
    a, b = format(lo, spec), format(hi, spec)
    if a == b:
        return a
    return f"{a} to {b}" if lo < 0 or hi < 0 else f"{a}-{b}"


def numbers_text(couplers) -> str:
    """Numbers as "1, 8, 9"."""
    return ", ".join(str(c) for c in couplers)


def page_html(title: str, body: str, viewport: bool = False) -> str:
    """A whole HTML page: ``title`` (plain text), the style sheet and ``body`` (HTML)."""
    meta = ("<meta name='viewport' content='width=device-width, initial-scale=1'>"
            if viewport else "")
    return (f"<!doctype html><html lang='en'><head><meta charset='utf-8'>{meta}"
            f"<title>{html.escape(title)}</title><style>{CSS}</style></head><body>"
            + body + "</body></html>")
