"""The documentation site: ``mkdocs build --strict`` (mkdocs.yml) and what it rendered.

The build itself fails on a warning (a broken link between pages, a missing anchor, a
page left out of the nav, a docstring the numpydoc parser cannot read). Independently
of MkDocs' own checks, the rendered HTML is read back here: every page the nav names
must have been written with its content, and every internal ``href``/``src`` of every
page must resolve to a file of the built site (and an anchor to an ``id`` on it).
"""

from __future__ import annotations

import os
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"


def build(tmp: Path) -> Path:
    out = tmp / "site"
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet",
                           "-f", str(ROOT / "mkdocs.yml"), "--site-dir", str(out)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out


def nav_pages() -> list[str]:
    """The docs-relative paths of the pages mkdocs.yml's nav names."""
    from mkdocs.config import load_config

    cfg = load_config(str(ROOT / "mkdocs.yml"))
    pages = []

    def walk(node):
        if isinstance(node, str):
            pages.append(node)
        elif isinstance(node, dict):
            for v in node.values():
                walk(v)
        elif isinstance(node, list):
            for v in node:
                walk(v)

    walk(cfg["nav"])
    return pages


class _Links(HTMLParser):
    def __init__(self):
        super().__init__()
        self.links: list[str] = []
        self.ids: set[str] = set()
        self.text: list[str] = []
        self._in_article = 0

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if a.get("id"):
            self.ids.add(a["id"])
        if tag == "a" and a.get("name"):
            self.ids.add(a["name"])
        for key in ("href", "src"):
            if a.get(key) and tag in ("a", "link", "img", "script", "source"):
                self.links.append(a[key])
        if tag == "article":
            self._in_article += 1

    def handle_endtag(self, tag):
        if tag == "article":
            self._in_article -= 1

    def handle_data(self, data):
        if self._in_article:
            self.text.append(data)


def parse(path: Path) -> _Links:
    p = _Links()
    p.feed(path.read_text(encoding="utf-8"))
    return p


def test_every_docs_page_is_in_the_nav():
    named = set(nav_pages())
    on_disk = {p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md")}
    on_disk |= {f"tutorials/{p.stem}.md" for p in (DOCS / "tutorials").glob("*.py")}
    on_disk.add("index.md")   # the README, made the home page by docs/hooks/site.py
    assert on_disk - named == set()
    assert named - on_disk == set()


def check_every_nav_page_is_rendered_with_its_content(site):
    for page in nav_pages():
        html = site / (page[:-3] + ".html")
        assert html.is_file(), page
        text = " ".join(parse(html).text).split()
        assert len(text) > 30, f"{page}: {len(text)} words"
    # a tutorial page shows its script's code and an API page its docstrings
    first = (site / "tutorials" / "01_first_run.html").read_text(encoding="utf-8")
    assert "load_scenario" in first and "position is the integral of velocity" in first
    api = " ".join(parse(site / "api" / "ltdsim.html").text)
    assert "simulate" in api and "Parameters" in api


def check_every_internal_link_resolves(site):
    pages = sorted(site.rglob("*.html"))
    assert len(pages) >= len(nav_pages())
    ids = {}
    broken = []
    checked = 0
    for page in pages:
        for link in parse(page).links:
            parts = urlsplit(link)
            if parts.scheme or parts.netloc or link.startswith(("mailto:", "data:")):
                continue
            if parts.path.startswith("/"):   # 404.html's links: the site at the root
                target = site / unquote(parts.path).lstrip("/")
            else:
                target = page if not parts.path else (page.parent / unquote(parts.path))
            if parts.path.endswith("/"):
                target = target / "index.html"
            target = target.resolve()
            checked += 1
            if not target.is_relative_to(site.resolve()) or not target.is_file():
                broken.append(f"{page.relative_to(site)}: {link}")
                continue
            if parts.fragment and target.suffix == ".html":
                if target not in ids:
                    ids[target] = parse(target).ids
                if unquote(parts.fragment) not in ids[target]:
                    broken.append(f"{page.relative_to(site)}: {link} (no such anchor)")
    assert checked > 1000
    assert broken == [], "\n".join(broken[:40])


def test_the_site_builds_strict_with_every_page_and_link(tmp_path):
    # one build for both checks (a module fixture would build once per xdist worker)
    site = build(tmp_path)
    check_every_nav_page_is_rendered_with_its_content(site)
    check_every_internal_link_resolves(site)
