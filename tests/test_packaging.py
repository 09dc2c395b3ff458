"""The installed package: a wheel built from this tree, installed into a fresh virtual
environment, carries the gear presets and the study tables and finds them at run time.

Built and installed without downloading anything but, where the environment's setuptools
is older than pyproject's build requirement, pip's isolated build backend. The fresh
environment reuses this interpreter's dependencies (numpy, numba, ...) through a ``.pth``
file written after the install, and runs from a temporary folder without PYTHONPATH, so
it imports the installed ltdsim, never this source tree; each test checks
``ltdsim.__file__``. The installed CLI runs with ``NUMBA_DISABLE_JIT=1`` (the kernel as
plain Python, about 10 s for one impact): compiling the kernel afresh for a new install
path would take minutes, and the compiled kernel is what every other test exercises. That
makes the comparison below one of two implementations as well as of two copies of a preset.
"""

from __future__ import annotations

import csv
import json
import os
import site
import subprocess
import sys
import tomllib
import venv
import zipfile
from pathlib import Path

import pytest

from ltdsim.analysis.gears import impact
from ltdsim.scenario import CouplerParams

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "ltdsim"
TIMEOUT = 600  # s, for each child process (a hung pip must not hang CI)
NOJIT_VECTORIZE = """\
import os

if os.environ.get("NUMBA_DISABLE_JIT") == "1":
    import functools

    import numba
    import numpy as np

    def _vectorize(*args, **kw):
        def wrap(f):
            return functools.wraps(f)(np.vectorize(f, otypes=[np.float64]))
        return wrap(args[0]) if len(args) == 1 and callable(args[0]) else wrap

    numba.vectorize = _vectorize
"""


def _source_files() -> set[str]:
    """Every file of the source package, as wheel paths (``ltdsim/...``), caches excluded."""
    return {f"ltdsim/{p.relative_to(PACKAGE).as_posix()}" for p in PACKAGE.rglob("*")
            if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc"}


def _run(cmd, **kw) -> subprocess.CompletedProcess:
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=TIMEOUT, **kw)
    assert r.returncode == 0, f"{cmd} failed ({r.returncode}):\n{r.stdout}\n{r.stderr}"
    return r


def _setuptools_meets_build_requirement() -> bool:
    from packaging.requirements import Requirement

    with (ROOT / "pyproject.toml").open("rb") as fh:
        requires = tomllib.load(fh)["build-system"]["requires"]
    try:
        import setuptools
    except ImportError:
        return False
    req = next(Requirement(r) for r in requires if Requirement(r).name == "setuptools")
    return req.specifier.contains(setuptools.__version__, prereleases=True)


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """A wheel of this tree, built from a copy so that no build/ or egg-info lands in it."""
    import shutil

    tmp = tmp_path_factory.mktemp("wheel")
    tree = tmp / "tree"
    tree.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, tree / name)
    shutil.copytree(ROOT / "src", tree / "src",
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info"))
    # this environment's setuptools if it will do (offline), else pip's isolated build
    isolation = ["--no-build-isolation"] if _setuptools_meets_build_requirement() else []
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", *isolation, "--quiet",
          "-w", str(tmp / "dist"), str(tree)], cwd=tmp)
    (whl,) = (tmp / "dist").glob("ltdsim-*.whl")
    return whl


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory) -> dict:
    """A fresh virtual environment with the wheel installed: its python, bin, a clean env."""
    tmp = tmp_path_factory.mktemp("venv")
    env_dir = tmp / "env"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    bindir = env_dir / ("Scripts" if os.name == "nt" else "bin")
    python = bindir / ("python.exe" if os.name == "nt" else "python")
    _run([sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps",
          "--no-index", "--quiet", str(wheel)], cwd=tmp)
    # only now make this interpreter's dependencies visible (a venv made from a venv with
    # --system-site-packages would see the base interpreter's packages, not these); path
    # lines come after the fresh site-packages and do not run the .pth files there, so an
    # editable ltdsim in this environment stays out of the fresh one
    purelib = Path(_run([str(python), "-c", "import sysconfig; "
                         "print(sysconfig.get_paths()['purelib'])"]).stdout.strip())
    deps = list(site.getsitepackages())
    if site.ENABLE_USER_SITE and site.getusersitepackages():
        deps.append(site.getusersitepackages())
    # numba compiles a ufunc even with NUMBA_DISABLE_JIT and then fails on the plain-Python
    # functions it calls: in this throwaway environment only, np.vectorize stands in
    (purelib / "_ltdsim_test_nojit.py").write_text(NOJIT_VECTORIZE)
    (purelib / "_ltdsim_test_env.pth").write_text("\n".join(deps) + "\nimport _ltdsim_test_nojit\n")
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "PYTHONSTARTUP")}
    env.update(PATH=f"{bindir}{os.pathsep}{env.get('PATH', '')}", VIRTUAL_ENV=str(env_dir),
               PYTHONIOENCODING="utf-8", COLUMNS="200", NUMBA_DISABLE_JIT="1",
               NUMBA_CACHE_DIR=str(tmp / "numba-cache"))
    cwd = tmp / "cwd"
    cwd.mkdir()
    info = json.loads(_run([str(python), "-c", "import json, ltdsim, sys; print(json.dumps("
                            "{'file': ltdsim.__file__, 'prefix': sys.prefix}))"],
                           env=env, cwd=cwd).stdout)
    return {"python": python, "bin": bindir, "env": env, "cwd": cwd, "dir": env_dir,
            "ltdsim_file": Path(info["file"]), "prefix": Path(info["prefix"])}


def test_wheel_carries_every_file_of_the_package(wheel):
    """Presets, study tables, py.typed and every module: all of src/ltdsim is in the wheel."""
    with zipfile.ZipFile(wheel) as z:
        shipped = {n for n in z.namelist() if n.startswith("ltdsim/")}
    missing = _source_files() - shipped
    assert not missing, f"not in the wheel: {sorted(missing)}"
    assert {"ltdsim/data/study_tables.json", "ltdsim/data/gears/mt-2.toml"} <= shipped


def test_fresh_environment_imports_the_installed_package(installed):
    """The fresh environment's ltdsim is the wheel's, not this tree or an editable install."""
    f = installed["ltdsim_file"].resolve()
    assert installed["dir"].resolve() in f.parents, f
    assert ROOT.resolve() not in f.parents, f
    r = _run([str(installed["bin"] / "ltdsim"), "--help"], env=installed["env"],
             cwd=installed["cwd"])
    assert "gear" in r.stdout and "study" in r.stdout


def test_installed_gear_preset_gives_the_source_presets_impact(installed, tmp_path):
    """`ltdsim gear impact --preset mt-2` from the wheel prints the peak force that the
    preset file of this tree gives here (read directly, compiled kernel): the installed
    preset is found by name and is the real one."""
    speed = 1.0  # m/s
    out = tmp_path / "impact.csv"
    r = _run([str(installed["bin"] / "ltdsim"), "gear", "impact", "--preset", "mt-2",
              "--speeds", f"{speed:g}", "--csv", str(out)],
             env=installed["env"], cwd=installed["cwd"])
    with (PACKAGE / "data" / "gears" / "mt-2.toml").open("rb") as fh:
        gear = CouplerParams(**tomllib.load(fh))
    expected = impact(gear, speed)["peak_force_N"]

    # the printed table: the row of this speed, in the column headed "peak force [kN]"
    rows = [[c.strip() for c in line.strip().strip("│┃").replace("┃", "│").split("│")]
            for line in r.stdout.splitlines() if line.strip()[:1] in "│┃"]
    header = next(row for row in rows if any("peak force" in c for c in row))
    col = next(i for i, c in enumerate(header) if "peak force" in c)
    assert "[kN]" in header[col], header[col]
    (row,) = [row for row in rows[rows.index(header) + 1:] if float(row[0]) == speed]
    printed = float(row[col]) * 1e3
    # printed to 3-4 significant figures; the other presets differ by far more (below)
    assert printed == pytest.approx(expected, rel=5e-3, abs=500.0), r.stdout
    # the CSV carries the number to at least 6 significant figures
    with out.open() as fh:
        (rec,) = list(csv.DictReader(fh))
    key = next(k for k in rec if "peak" in k and "force" in k)
    scale = 1e3 if "kn" in key.lower() else 1.0
    assert float(rec[key]) * scale == pytest.approx(expected, rel=1e-5)
    # and the comparison can tell the presets apart: every other preset is off by > 3 %
    for other in ("mt-3", "friction-wedge-low", "friction-wedge-high"):
        f = impact(CouplerParams(preset=other), speed)["peak_force_N"]
        assert abs(f - expected) > 0.03 * expected, other


def test_installed_study_tables_are_the_published_tables(installed):
    """The wheel's ``ltdsim.data.study_tables()`` loads and equals this tree's JSON file."""
    code = ("import json, ltdsim; from ltdsim.data import study_tables; "
            "print(json.dumps({'file': ltdsim.__file__, 'tables': study_tables()}))")
    got = json.loads(_run([str(installed["python"]), "-c", code], env=installed["env"],
                          cwd=installed["cwd"]).stdout)
    assert installed["dir"].resolve() in Path(got["file"]).resolve().parents
    expected = json.loads((PACKAGE / "data" / "study_tables.json").read_text())
    assert got["tables"] == expected
    assert got["tables"]["appendix1"]  # the study's parameters are there, not an empty shell


def test_installed_fatigue_curve_is_the_source_curve(installed):
    """The wheel's ``aar-e-knuckle`` fatigue curve (package data under data/fatigue) is
    found by name at run time and is this tree's file, numbers and sources."""
    code = ("import json, ltdsim; from ltdsim.data import load_preset; "
            "print(json.dumps({'file': ltdsim.__file__, "
            "'curve': load_preset('fatigue', 'aar-e-knuckle')}))")
    got = json.loads(_run([str(installed["python"]), "-c", code], env=installed["env"],
                          cwd=installed["cwd"]).stdout)
    assert installed["dir"].resolve() in Path(got["file"]).resolve().parents
    with (PACKAGE / "data" / "fatigue" / "aar-e-knuckle.toml").open("rb") as fh:
        expected = tomllib.load(fh)
    assert got["curve"] == expected
    assert got["curve"]["reference_range"] > 0.0 and got["curve"]["sources"]
