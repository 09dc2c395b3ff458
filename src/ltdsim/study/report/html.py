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
nav.toc{background:#fafafa;border:1px solid #ddd;padding:.3em 1em;font-size:.9em}
nav.toc ol{columns:2;margin:.3em 0}
@media (max-width:800px){nav.toc ol{columns:1}}
@media print{
body{max-width:none;margin:0;padding:0;font-size:10pt}
.tbl{overflow:visible}
table{font-size:7.5pt;width:100%;table-layout:auto}
td.num{white-space:normal}td,th{padding:1px 3px;word-break:break-word}
figure,tr,.take{break-inside:avoid}h2,h3{break-after:avoid}
a{color:inherit;text-decoration:none}img{border:0}
}
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


def small_png(path: Path) -> bytes:
    """The PNG at ``path`` with its colours reduced to a 256-colour palette (Pillow's
    median cut, no dithering): a plot's flat colours and anti-aliased lines survive,
    at a third to a fifth of the bytes; the original if that is not smaller."""
    import io

    from PIL import Image

    raw = Path(path).read_bytes()
    with Image.open(io.BytesIO(raw)) as im:
        pal = im.convert("RGB").quantize(256, method=Image.Quantize.MEDIANCUT,
                                         dither=Image.Dither.NONE)
        buf = io.BytesIO()
        pal.save(buf, format="PNG", optimize=True)
    return buf.getvalue() if buf.tell() < len(raw) else raw


def figure_html(path: Path, caption: str) -> str:
    """A ``<figure>`` with the PNG embedded (base64, :func:`small_png`), so the page works
    offline and moves as one file."""
    data = base64.b64encode(small_png(path)).decode()
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
    # the table travels in the link too (a data URL), so it works when the page is moved
    # or mailed alone; the file beside the page is the same table
    data = base64.b64encode((out / name).read_bytes()).decode()
    return (f'<p class="note">CSV: <a download="{name}" href="data:text/csv;base64,'
            f'{data}">{name}</a> (also beside this page)</p>')


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


def contents(body: str) -> str:
    """A table of contents of the ``<h2 id=...>`` headings in ``body`` (HTML)."""
    import re

    items = re.findall(r"<h2 id='([^']+)'[^>]*>(.*?)</h2>", body)
    if len(items) < 3:
        return ""
    return ("<nav class='toc'><b>Contents</b><ol>" + "".join(
        f"<li><a href='#{i}'>{re.sub('<[^>]+>', '', t)}</a></li>" for i, t in items)
        + "</ol></nav>")


def page_html(title: str, body: str, viewport: bool = False) -> str:
    """A whole HTML page: ``title`` (plain text), the style sheet and ``body`` (HTML)."""
    meta = ("<meta name='viewport' content='width=device-width, initial-scale=1'>"
            if viewport else "")
    return (f"<!doctype html><html lang='en'><head><meta charset='utf-8'>{meta}"
            f"<title>{html.escape(title)}</title><style>{CSS}</style></head><body>"
            + body + "</body></html>")
