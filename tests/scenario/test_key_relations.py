"""Keys that would have no effect, and keys whose values contradict one another, are
refused in one line naming the key and the relation (issue 37); a file the scenario
reader cannot take for what it is says what it is."""

from pathlib import Path

import pytest

import ltdsim
from ltdsim import ScenarioError

from conftest import ROOT, cli_refused

SCENARIOS = ROOT / "scenarios"
SHORT = (SCENARIOS / "short-train.toml").read_text()


def write(tmp_path: Path, text: str | bytes, name: str = "bad.toml") -> Path:
    p = tmp_path / name
    if isinstance(text, bytes):
        p.write_bytes(text)
    else:
        p.write_text(text)
    return p


def refused(tmp_path, text, match, case=None) -> str:
    """Load ``text`` as bad.toml: assert it is refused with ``match``, in one line naming
    the file; return the message."""
    with pytest.raises(ScenarioError, match=match) as info:
        ltdsim.load_scenario(write(tmp_path, text), case=case)
    msg = str(info.value)
    assert "bad.toml" in msg and len(msg.splitlines()) == 1, msg
    return msg


def edit(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new)


# --------------------------------------------------------------- the file itself
def test_a_utf8_byte_order_mark_at_the_start_is_accepted(tmp_path):
    sc = ltdsim.load_scenario(write(tmp_path, b"\xef\xbb\xbf" + SHORT.encode()))
    assert sc.name == "short-train" and sc.n_vehicles == 5


def test_a_byte_order_mark_in_a_profile_csv_does_not_hide_its_first_row(tmp_path):
    (tmp_path / "line.csv").write_bytes(b"\xef\xbb\xbf0.0,0.0,0.0\n500.0,0.002,0.05\n")
    text = edit(SHORT, 'curve = [[0.0, 0.0], [150.0, 300.0], [450.0, 0.0]]',
                'profile_file = "line.csv"')
    sc = ltdsim.load_scenario(write(tmp_path, text))
    assert sc.track.profile == [(0.0, 0.0, 0.0), (500.0, 0.002, 0.05)]


def test_a_sweep_file_given_as_a_scenario_says_to_run_ltdsim_sweep():
    sweep = SCENARIOS / "heavy-haul-brakes-sweep.toml"
    with pytest.raises(ScenarioError, match=r"a sweep file \(its scenario key and "
                                            r"\[overrides\] and \[list\] tables\), not a "
                                            r"scenario: run its cases with `ltdsim sweep "):
        ltdsim.load_scenario(sweep)
    text = cli_refused("run", sweep)
    assert f"ltdsim sweep {sweep}" in text and "required key" not in text
    assert "unknown key" not in text
