"""What every benchmark does with its numbers: a markdown table headed by the time and
the machine, printed and written atomically to ``<name>.md``, and the raw values to
``<name>.json``."""

from __future__ import annotations

import datetime as _dt
import json
import os
import platform
from pathlib import Path

from ltdsim.results.io import atomic_path


def machine() -> str:
    """This machine in one line: architecture, cores, Python."""
    return f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}"


def publish(out: Path, name: str, title: str, rows, columns=("quantity", "value"),
            result: dict | None = None) -> str:
    """Print and write the table of ``rows`` (tuples, one per line) under the heading
    ``"<title>, <UTC time> (<machine>)<rest>"``; ``title`` may carry a ``{stamp}``
    placeholder for that part. Writes ``out/<name>.md`` and, with ``result``,
    ``out/<name>.json`` (with the time and machine added). Returns the text."""
    stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    head = title.format(stamp=f"{stamp} ({machine()})")
    w = max(len(str(r[0])) for r in rows)
    lines = [head, "",
             f"| {columns[0]:<{w}} | " + " | ".join(columns[1:]) + " |",
             f"|{'-' * (w + 2)}|" + "|".join("-" * (len(c) + 2) for c in columns[1:]) + "|"]
    lines += ["| " + f"{r[0]:<{w}} | " + " | ".join(str(c) for c in r[1:]) + " |" for r in rows]
    text = "\n".join(lines)
    print(text)
    out.mkdir(parents=True, exist_ok=True)
    with atomic_path(out / f"{name}.md") as tmp:
        tmp.write_text(text + "\n")
    if result is not None:
        with atomic_path(out / f"{name}.json") as tmp:
            tmp.write_text(json.dumps({"timestamp": stamp, "machine": machine(), **result},
                                      indent=2) + "\n")
    return text
