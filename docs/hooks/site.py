"""MkDocs hooks of ltdsim's documentation site (mkdocs.yml: ``hooks``).

Three things the pages need that MkDocs does not do by itself:

- the home page is the repository's README.md, its links rewritten for the site
  (``docs/x.md`` becomes ``x.md``);
- a link from a page to a file of the repository outside docs/ (a scenario file, a
  benchmark table, a test) would break in the site: the file is copied into the site
  under ``repo/`` and the link pointed there, so the site is complete offline;
- each tutorial, a jupytext percent-format script ``docs/tutorials/NAME.py``, becomes the
  page ``tutorials/NAME.md`` (its markdown cells as text, its code cells as code; not
  executed here: tests/docs/test_tutorials.py runs every script). The script itself is
  kept beside the page for download.
"""

from __future__ import annotations

import posixpath
import re
from pathlib import Path

from mkdocs.structure.files import File, Files

LINK = re.compile(r"(\]\()([^)\s]+)(\))")
FENCE = re.compile(r"^(```|~~~)")
REPO_DIR = "repo"


def _root(config) -> Path:
    return Path(config["config_file_path"]).resolve().parent


def _outside_code(text: str):
    """(is_code, chunk) pieces of a markdown text: fenced blocks and inline code are
    left alone when links are rewritten."""
    out, block, fenced = [], [], False
    for line in text.splitlines(keepends=True):
        if FENCE.match(line.lstrip()):
            if block:
                out.append((fenced, "".join(block)))
                block = []
            out.append((True, line))
            fenced = not fenced
            continue
        block.append(line)
    if block:
        out.append((fenced, "".join(block)))
    return out


def rewrite_links(text: str, src_dir: Path, page_uri: str, config, wanted: set) -> str:
    """``text`` with each relative link resolved from ``src_dir`` (the folder the
    markdown source lives in) and rewritten relative to the page's place in the site
    (``page_uri``, a docs-relative path); links to repository files outside docs/ point
    into ``repo/``, and their paths are added to ``wanted``."""
    root = _root(config)
    docs = Path(config["docs_dir"]).resolve()
    page_dir = posixpath.dirname(page_uri)

    def fix(m):
        target = m.group(2)
        if re.match(r"^[a-z][a-z0-9+.-]*:", target) or target.startswith(("#", "/")):
            return m.group(0)
        path, hashmark, anchor = target.partition("#")
        dest = (src_dir / path).resolve()
        if dest.is_relative_to(docs):
            rel = dest.relative_to(docs).as_posix()
            if dest.is_dir():   # a folder's page: the site's index.md, docs/x/index.md
                rel = posixpath.join("" if rel == "." else rel, "index.md")
        elif dest.is_relative_to(root) and dest.exists() and dest.is_file():
            inside = dest.relative_to(root).as_posix()
            wanted.add(inside)
            rel = f"{REPO_DIR}/{inside}"
        else:
            return m.group(0)
        stem = rel[len("tutorials/"):-len(".py")] if rel.startswith("tutorials/") else None
        if (rel.endswith(".py") and stem in _tutorials
                and page_uri != f"tutorials/{stem}.md"):
            rel = f"tutorials/{stem}.md"   # in the site, a tutorial's page, not its script
        new = posixpath.relpath(rel, page_dir or ".")
        return f"{m.group(1)}{new}{hashmark}{anchor}{m.group(3)}"

    pieces = []
    for is_code, chunk in _outside_code(text):
        if is_code:
            pieces.append(chunk)
            continue
        parts = re.split(r"(`[^`\n]*`)", chunk)
        pieces.append("".join(p if p.startswith("`") else LINK.sub(fix, p) for p in parts))
    return "".join(pieces)


def tutorial_markdown(script: str, name: str) -> str:
    """The page of a jupytext percent-format tutorial script."""
    import jupytext

    nb = jupytext.reads(script, fmt="py:percent")
    parts = []
    for cell in nb.cells:
        src = cell.source.strip("\n")
        if not src:
            continue
        if cell.cell_type == "markdown":
            parts.append(src)
        else:
            parts.append(f"```python\n{src}\n```")
    parts.append(f"The script of this page: [{name}]({name}) (run it with "
                 f"`python docs/tutorials/{name}` from any folder, it writes into "
                 "`results/` there; or open it in Jupyter with jupytext). This page is "
                 "not executed when the site is built; the tests run the script.")
    return "\n\n".join(parts) + "\n"


_generated: dict[str, str] = {}
_tutorials: set[str] = set()


def on_files(files: Files, config) -> Files:
    root = _root(config)
    docs = Path(config["docs_dir"]).resolve()
    wanted: set[str] = set()
    _generated.clear()
    _tutorials.clear()
    _tutorials.update(p.stem for p in (docs / "tutorials").glob("*.py"))
    readme = (root / "README.md").read_text(encoding="utf-8")
    _generated["index.md"] = rewrite_links(readme, root, "index.md", config, wanted)
    for script in sorted((docs / "tutorials").glob("*.py")):
        uri = f"tutorials/{script.stem}.md"
        md = tutorial_markdown(script.read_text(encoding="utf-8"), script.name)
        _generated[uri] = rewrite_links(md, script.parent, uri, config, wanted)
    for f in list(files):
        if f.src_uri.endswith(".md") and f.abs_src_path:
            text = Path(f.abs_src_path).read_text(encoding="utf-8")
            src_dir = Path(f.abs_src_path).resolve().parent
            _generated[f.src_uri] = rewrite_links(text, src_dir, f.src_uri, config, wanted)
    for uri, content in _generated.items():
        if files.get_file_from_path(uri) is None:
            files.append(File.generated(config, uri, content=content))
    for inside in sorted(wanted):
        uri = f"{REPO_DIR}/{inside}"
        # copied as they are (a benchmark table stays a .md file, not a page)
        f = File.generated(config, uri, abs_src_path=str(root / inside))
        if uri.endswith(".md"):
            f = _Static(uri, str(root / inside), config)
        files.append(f)
    return files


class _Static(File):
    """A repository file copied into the site unchanged, whatever its suffix."""

    def __init__(self, uri, abs_src_path, config):
        super().__init__(uri, src_dir=None, dest_dir=config["site_dir"],
                         use_directory_urls=False)
        self.abs_src_path = abs_src_path
        self.generated_by = "docs/hooks/site.py"

    def is_documentation_page(self) -> bool:
        return False

    def is_static_page(self) -> bool:
        return False

    def is_media_file(self) -> bool:
        return True


def on_page_markdown(markdown: str, page, config, files) -> str:
    return _generated.get(page.file.src_uri, markdown)
