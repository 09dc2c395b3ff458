"""The package's shape: its layers import only downwards, no module imports itself round
a circle, and no function takes more parameters than a reader can hold.

The layers, lowest first (each package's ``__init__`` says what it owns and may import):
the base modules (errors, version, the result variables' declarations, the data files,
progress and worker processes), ``physics``, ``scenario``, ``engine``, ``results``,
``analysis``, ``viz``, ``sweep``, ``study``, ``makeup`` and ``cli``. A module may import its own
layer and those below; the package's face (``ltdsim/__init__.py``) is above them all.
Every import counts, also one inside a function (the lazy imports that keep start-up
fast are imports all the same)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "ltdsim"
#: the layers, lowest first: module name prefixes (under ltdsim)
LAYERS = (
    ("_version", "errors", "variables", "_jitcache", "_provenance", "_workers", "progress",
     "data"),
    ("physics",),
    ("scenario",),
    ("engine",),
    ("results",),
    ("analysis",),
    ("viz",),
    ("sweep",),
    ("study",),
    # make-up studies: they run on the sweep's executor and build their page with the
    # study report's page helpers (study.report.html), so they sit above both; nothing
    # but the commands uses them
    ("makeup",),
    ("cli",),
)
#: most parameters a function may take
MAX_PARAMETERS = 12


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(SRC.rglob("*.py")):
        parts = path.relative_to(SRC.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


MODULES = _modules()


def _layer(module: str) -> int | None:
    """Layer of a module ``ltdsim.x...`` (None for the package face ``ltdsim``)."""
    rest = module.split(".", 1)[1] if "." in module else ""
    if not rest:
        return None
    head = rest.split(".")[0]
    for k, names in enumerate(LAYERS):
        if head in names:
            return k
    raise AssertionError(f"{module}: in no layer (add its package to LAYERS)")


def _imports(module: str) -> set[str]:
    """The ltdsim modules ``module`` imports (a package's name for ``from pkg import
    name`` unless ``name`` is a module of it)."""
    tree = ast.parse(MODULES[module].read_text())
    pkg = module if MODULES[module].name == "__init__.py" else module.rpartition(".")[0]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.split(".")[0] == "ltdsim")
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(pkg.split(".")[:len(pkg.split(".")) - node.level + 1]
                                + ([base] if base else []))
            if base.split(".")[0] != "ltdsim":
                continue
            for a in node.names:
                full = f"{base}.{a.name}"
                out.add(full if full in MODULES else base)
    return {m for m in out if m in MODULES and m != module}


GRAPH = {m: _imports(m) for m in MODULES}


@pytest.mark.parametrize("module", sorted(MODULES))
def test_a_module_imports_only_its_own_layer_and_those_below(module):
    own = _layer(module)
    if own is None:
        return  # the package's face
    upward = sorted(m for m in GRAPH[module] if (_layer(m) is None or _layer(m) > own))
    assert not upward, f"{module} (layer {own}) imports upwards: {upward}"


def test_no_module_imports_itself_round_a_circle():
    # depth-first search for a cycle over every import (strongly connected components)
    index, low, stack, on, circles = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in GRAPH[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                circles.append(sorted(comp))

    for v in sorted(GRAPH):
        if v not in index:
            visit(v)
    # (a package's __init__ that hands on its modules' names imports them; a module of
    # the package that imports the package's face would close a circle: refused too)
    assert not circles, f"import circles: {circles}"


def test_no_function_takes_more_than_twelve_parameters():
    too_many = []
    for name, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                a = node.args
                count = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs)
                if count > MAX_PARAMETERS:
                    too_many.append(f"{name}.{node.name} ({count})")
    assert not too_many, f"functions with more than {MAX_PARAMETERS} parameters: {too_many}"


def test_every_package_says_what_it_owns_and_what_it_may_import():
    for name, path in MODULES.items():
        if path.name != "__init__.py" or name == "ltdsim":
            continue
        doc = ast.get_docstring(ast.parse(path.read_text())) or ""
        assert len(doc.split()) >= 25 and "import" in doc, (
            f"{name}: its __init__ docstring must say what the package owns and what it "
            "may import")
