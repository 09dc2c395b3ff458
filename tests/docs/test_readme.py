"""The README's worked example, run as written.

The fenced code blocks of the README's "A worked example" section are read from the
README itself (so the test follows any edit): the Python block runs as a script, each
line of the shell block as a command (``make`` lines skipped), all in an empty working
folder whose only addition is the repository's ``scenarios/`` (the paths the example
names). Every command must exit 0, and every file the section says is written
(``results/...`` in backquotes) must exist and be what its suffix says. The modes the
example's comment quotes (0.32-1.99 Hz) are checked against what the command prints.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def worked_example() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    m = re.search(r"^## A worked example\n(.*?)(?=^## )", text, re.S | re.M)
    assert m, "README.md has no '## A worked example' section"
    return m.group(1)


def blocks(section: str) -> list[tuple[str, str]]:
    return re.findall(r"^```(\w*)\n(.*?)^```", section, re.S | re.M)


def run_example(work: Path):
    (work / "scenarios").symlink_to(ROOT / "scenarios", target_is_directory=True)
    env = {**os.environ,
           "PYTHONPATH": os.pathsep.join([str(ROOT / "src"),
                                          *filter(None, [os.environ.get("PYTHONPATH")])]),
           "PATH": os.pathsep.join([str(Path(sys.executable).parent), os.environ["PATH"]])}
    outputs = []
    section = worked_example()
    found = blocks(section)
    assert {lang for lang, _ in found} >= {"python", "sh"}
    for lang, body in found:
        if lang == "python":
            script = work / "worked_example.py"
            script.write_text(body, encoding="utf-8")
            commands = [[sys.executable, str(script)]]
        elif lang == "sh":
            lines = [ln for ln in body.splitlines() if ln.strip()]
            commands = [["bash", "-c", ln] for ln in lines
                        if not ln.lstrip().startswith("make ")]
        else:
            continue
        for cmd in commands:
            proc = subprocess.run(cmd, cwd=work, env=env, capture_output=True, text=True,
                                  timeout=600)
            assert proc.returncode == 0, (cmd, proc.stdout[-2000:], proc.stderr[-2000:])
            outputs.append((cmd, proc.stdout))
    return work, section, outputs


def check_the_files_it_names_are_written(ran):
    import ltdsim

    work, section, _ = ran
    named = sorted(set(re.findall(r"`(results/[^`\s]+)`", section)))
    assert len(named) >= 4
    for rel in named:
        path = work / rel
        assert path.is_file() and path.stat().st_size > 0, rel
        head = path.read_bytes()[:8]
        if rel.endswith(".nc"):
            assert head.startswith(b"\x89HDF"), rel        # netCDF-4 is HDF5
            ds = ltdsim.load_result(path)
            assert ds.coupler_force.attrs["units"] == "N"
        elif rel.endswith(".png"):
            assert head.startswith(b"\x89PNG"), rel
        elif rel.endswith(".html"):
            assert b"<html" in path.read_bytes()[:2000].lower(), rel
        elif rel.endswith(".csv"):
            assert len(path.read_text().splitlines()) > 2, rel


def check_the_python_block_prints_what_it_says(ran):
    _, _, outputs = ran
    out = next(o for cmd, o in outputs if cmd[-1].endswith("worked_example.py"))
    m = re.search(r"coupler 1: largest tension (\d+\.\d) kN; RMS speed error (\d+\.\d+) m/s",
                  out)
    assert m
    assert float(m.group(1)) > 0.0 and float(m.group(2)) < 1.0


def check_the_modes_are_those_its_comment_quotes(ran):
    _, section, outputs = ran
    quoted = re.search(r"ltdsim modal .*# (\d+\.\d+)-(\d+\.\d+) Hz", section)
    assert quoted, "the worked example's modal command quotes its range (# A-B Hz)"
    out = next(o for cmd, o in outputs if "ltdsim modal" in cmd[-1])
    freqs = [float(x) for x in re.findall(r"│\s*\d+\s*│\s*(\d+\.\d+)\s*│", out)]
    nonzero = [f for f in freqs if f > 1e-6]       # mode 1: the rigid body, 0 Hz
    assert round(min(nonzero), 2) == float(quoted.group(1))
    assert round(max(nonzero), 2) == float(quoted.group(2))


def test_the_worked_example_runs_as_written(tmp_path):
    # one run for every check (a module fixture would run once per xdist worker)
    ran = run_example(tmp_path)
    check_the_files_it_names_are_written(ran)
    check_the_python_block_prints_what_it_says(ran)
    check_the_modes_are_those_its_comment_quotes(ran)
