"""First-run benchmark: what a new user waits for before the first result.

Measures, each in a fresh ``git clone`` of this repository and with an empty numba
cache (a fresh ``NUMBA_CACHE_DIR``, so every kernel is compiled):

  (a) ``ltdsim run scenarios/paper.toml`` as a subprocess; then the same command again
      with the cache it filled: the difference is what the first run pays (compiling);
  (b) ``make run`` (``ltdsim study scenarios/paper.toml --output report``);
  (c) the warm kernel: one case of the base scenario, after compilation, several times;
  (d) with ``--fresh-machine``: as a new user does it, in a fresh clone of HEAD with no
      environment: ``make run`` (the virtual environment created and the project
      installed, from pip's download cache where it holds the wheels, then the study),
      then ``make test`` in the same clone (every test, on all cores).

Each is measured for this checkout (HEAD, committed code only) and for a reference
commit (``--reference``, default: the last commit before the first-run work), in the
same run, interleaved: reference then new in each round. The clones reuse the installed
virtual environment (``PYTHONPATH`` at the clone's ``src``; ``make run VENV=<this
environment>``) instead of installing their own: installing is not timed.

The machine is shared: wall seconds move with its load, so CPU seconds (user + system
of the child and its worker processes, from ``getrusage``) are given beside them, and
the ratios are taken on CPU seconds.

Usage: python benchmarks/bench_first_run.py [--rounds 1] [--reference REV]
       [--no-reference] [--skip-study] [--kernel-repeats 5] [--fresh-machine]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _results import publish

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
#: the last commit before the first-run work (issue 12, point 7): kernels inlined at
#: numba's IR level, no compile before the sweep's workers start
REFERENCE = "ccf4c4a"

_SERVER = r"""
import json, sys, time
import ltdsim
sc = ltdsim.load_scenario("scenarios/paper.toml", case="LHHL")
ltdsim.simulate(sc.with_overrides({"solver.t_end": 0.01}))
print("ready", flush=True)
for line in sys.stdin:
    c0 = time.thread_time()
    ds = ltdsim.simulate(sc)
    print(json.dumps({"cpu": time.thread_time() - c0, "kernel_wall": ds.attrs["wall_time_s"]}),
          flush=True)
"""


def _clone(rev: str, into: Path) -> Path:
    subprocess.run(["git", "clone", "--quiet", str(ROOT), str(into)], check=True)
    subprocess.run(["git", "-C", str(into), "checkout", "--quiet", rev], check=True)
    return into


def _env(clone: Path, cache: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(clone / "src"), NUMBA_CACHE_DIR=str(cache))
    env.pop("COLUMNS", None)
    return env


def _timed(cmd, cwd: Path, env: dict, log: Path) -> tuple[float, float]:
    """Run ``cmd``; returns (wall s, CPU s of the child and everything it waited for)."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    with open(log, "w") as f:
        proc = subprocess.run(cmd, cwd=cwd, env=env, stdout=f, stderr=subprocess.STDOUT)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(map(str, cmd))} failed in {cwd}:\n"
                         + log.read_text()[-3000:])
    return wall, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)


def _first_run(clone: Path, work: Path, tag: str) -> dict:
    cache = Path(tempfile.mkdtemp(prefix=f"cache-{tag}-", dir=work))
    cmd = [sys.executable, "-m", "ltdsim.cli.app", "run", "scenarios/paper.toml"]
    cold = _timed(cmd, clone, _env(clone, cache), work / f"run-cold-{tag}.log")
    warm = _timed(cmd, clone, _env(clone, cache), work / f"run-warm-{tag}.log")
    return {"cold": cold, "warm": warm, "cache": cache}


def _make_run(clone: Path, work: Path, tag: str) -> tuple[float, float]:
    cache = Path(tempfile.mkdtemp(prefix=f"cache-study-{tag}-", dir=work))
    venv = Path(sys.prefix)
    stamp = venv / ".installed-stamp"
    if shutil.which("make") and stamp.is_file():
        # the Makefile's own command; -o: never (re)install into the shared environment
        cmd = ["make", "--no-print-directory", "run", f"VENV={venv}", "-o", str(stamp)]
    else:
        cmd = [sys.executable, "-m", "ltdsim.cli.app", "study", "scenarios/paper.toml",
               "--output", "report"]
    shutil.rmtree(clone / "report", ignore_errors=True)
    return _timed(cmd, clone, _env(clone, cache), work / f"make-run-{tag}.log")


def _fresh_machine(work: Path) -> dict:
    """(d): ``make run`` then ``make test`` in a fresh clone of HEAD, which installs its
    own environment; (wall s, CPU s) of each."""
    clone = _clone("HEAD", work / "clone-fresh")
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "NUMBA_CACHE_DIR", "VIRTUAL_ENV", "COLUMNS")}
    # an empty numba cache, as on a new machine (pip's download cache stays: the wheels
    # come from it where it holds them, as from a package index nearby)
    env["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="cache-fresh-", dir=work)
    out = {}
    for target in ("run", "test"):
        out[target] = _timed(["make", "--no-print-directory", target], clone, env,
                             work / f"fresh-make-{target}.log")
        print(f"fresh clone: make {target} {out[target][0]:.0f} s wall", file=sys.stderr,
              flush=True)
    return out


def _kernel(clones: dict, caches: dict, repeats: int) -> dict:
    """Warm kernel, one case per call, alternating between the versions."""
    procs = {tag: subprocess.Popen([sys.executable, "-c", _SERVER], cwd=clones[tag],
                                   env=_env(clones[tag], caches[tag]), stdin=subprocess.PIPE,
                                   stdout=subprocess.PIPE, text=True)
             for tag in clones}
    for p in procs.values():
        assert p.stdout.readline().strip() == "ready"
    out = {tag: [] for tag in procs}
    for r in range(repeats):
        for tag in (list(procs) if r % 2 == 0 else list(procs)[::-1]):
            procs[tag].stdin.write("run\n")
            procs[tag].stdin.flush()
            out[tag].append(json.loads(procs[tag].stdout.readline()))
    for p in procs.values():
        p.stdin.close()
        p.wait()
    return out


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--reference", default=REFERENCE, help="git revision to compare with")
    ap.add_argument("--no-reference", action="store_true", help="measure HEAD only")
    ap.add_argument("--skip-study", action="store_true", help="skip (b), make run")
    ap.add_argument("--kernel-repeats", type=int, default=5)
    ap.add_argument("--fresh-machine", action="store_true",
                    help="(d): make run and make test in a fresh clone that installs itself")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)

    work = Path(tempfile.mkdtemp(prefix="ltdsim-first-run-"))
    revs = {"new": subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                                  capture_output=True, text=True, check=True).stdout.strip()}
    if not args.no_reference:
        revs = {"ref": args.reference, **revs}
    res = {tag: {"run_cold": [], "run_warm": [], "study": []} for tag in revs}
    try:
        clones = {tag: _clone(rev, work / f"clone-{tag}") for tag, rev in revs.items()}
        caches = {}
        for r in range(args.rounds):
            for tag in revs:
                fr = _first_run(clones[tag], work, f"{tag}{r}")
                res[tag]["run_cold"].append(fr["cold"])
                res[tag]["run_warm"].append(fr["warm"])
                caches[tag] = fr["cache"]
                print(f"round {r + 1} {tag}: ltdsim run cold {fr['cold'][0]:.1f} s wall, "
                      f"{fr['cold'][1]:.1f} s CPU", file=sys.stderr, flush=True)
            if not args.skip_study:
                for tag in revs:
                    res[tag]["study"].append(_make_run(clones[tag], work, f"{tag}{r}"))
                    print(f"round {r + 1} {tag}: make run {res[tag]['study'][-1][0]:.1f} s wall",
                          file=sys.stderr, flush=True)
        kern = _kernel(clones, caches, args.kernel_repeats)
        fresh = _fresh_machine(work) if args.fresh_machine else {}
    finally:
        shutil.rmtree(work, ignore_errors=True)

    def med(tag, key, i):
        return statistics.median(x[i] for x in res[tag][key])

    def kmed(tag, key):
        return statistics.median(x[key] for x in kern[tag])

    rows = []
    tags = list(revs)
    for tag in tags:
        name = f"{'reference ' if tag == 'ref' else ''}{revs[tag]}"
        cold_w, cold_c = med(tag, "run_cold", 0), med(tag, "run_cold", 1)
        warm_w, warm_c = med(tag, "run_warm", 0), med(tag, "run_warm", 1)
        rows += [
            (f"{name}: first `ltdsim run scenarios/paper.toml`, empty cache, wall s",
             f"{cold_w:.1f}"),
            (f"{name}: the same, CPU s", f"{cold_c:.1f}"),
            (f"{name}: the same again, cache filled, wall s / CPU s",
             f"{warm_w:.1f} / {warm_c:.1f}"),
            (f"{name}: share of the first run's CPU that a second run does not pay "
             "(compiling)", f"{(cold_c - warm_c) / cold_c:.0%}"),
        ]
        if res[tag]["study"]:
            rows += [(f"{name}: `make run` in a fresh clone, empty cache, wall s",
                      f"{med(tag, 'study', 0):.0f}"),
                     (f"{name}: the same, CPU s (all processes)", f"{med(tag, 'study', 1):.0f}")]
        rows.append((f"{name}: warm kernel, one 270 s case, CPU s (median of "
                     f"{len(kern[tag])})", f"{kmed(tag, 'cpu'):.2f}"))
    if "ref" in revs:
        rows += [
            ("ratio reference / new, first `ltdsim run`, CPU s",
             f"{med('ref', 'run_cold', 1) / med('new', 'run_cold', 1):.1f}x"),
            ("ratio reference / new, first `ltdsim run`, wall s",
             f"{med('ref', 'run_cold', 0) / med('new', 'run_cold', 0):.1f}x"),
        ]
        if res["new"]["study"]:
            rows += [("ratio reference / new, `make run`, CPU s",
                      f"{med('ref', 'study', 1) / med('new', 'study', 1):.1f}x"),
                     ("ratio reference / new, `make run`, wall s",
                      f"{med('ref', 'study', 0) / med('new', 'study', 0):.1f}x")]
        ratios = [n["cpu"] / o["cpu"] for o, n in zip(kern["ref"], kern["new"])]
        rows.append(("warm kernel new / reference, CPU s (median of the per-round ratios)",
                     f"{statistics.median(ratios):.3f}"))
    for target, what in (("run", "install and the study"), ("test", "every test")):
        if target in fresh:
            rows.append((f"{revs['new']}: fresh clone, no environment: `make {target}` "
                         f"({what}), wall s / CPU s",
                         f"{fresh[target][0]:.0f} / {fresh[target][1]:.0f}"))
    load = os.getloadavg()[0]
    publish(args.out, "bench_first_run",
            f"First-run benchmark, {{stamp}}; fresh clones, empty numba caches, the installed "
            f"environment reused; {args.rounds} round(s), reference then new; load average "
            f"at the end {load:.1f}"
            + ("; last, a fresh clone that installs its own environment" if fresh else ""),
            rows,
            result={"revisions": revs, "runs": res, "kernel": kern, "fresh_machine": fresh,
                    "load_average": load})
    return res


if __name__ == "__main__":
    main()
