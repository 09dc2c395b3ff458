"""Law: whatever scenario tree the schema's keys can spell, ``load_scenario`` either returns
a Scenario or raises a ScenarioError of one line per problem, each naming the file (and a
key where there is one); and ``ltdsim run`` on it either runs or refuses in exactly one
``error`` line (exit 2 for invalid input, 3 for a run that blew up), never a traceback,
and a run it makes stays within its estimate (memory, and the steps of a fixed step).

The trees start from the small shipped scenarios and are changed where the pydantic
models say a key may go (their ``model_fields``, recursively): values inside, at and just
beyond each field's range (its ge/gt/le/lt or ``quantity`` bounds), values of the wrong
TOML type (strings, booleans, NaN, inf, huge and tiny numbers, arrays, tables), keys
deleted and unknown keys added; for the command line also plausible trains (vehicle
counts and masses, coupler models and presets, brakes, solver method and step) kept
short, so that each run takes a fraction of a second.
"""

from __future__ import annotations

import copy
import importlib
import json
import math
import tomllib
import types
import typing

import annotated_types as at
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import AfterValidator, BaseModel

import ltdsim
from ltdsim.data import preset_names
from ltdsim.engine.lowering import lower
from ltdsim.engine.run import estimate
from ltdsim.errors import ScenarioError
from ltdsim.scenario import Scenario, scenario_from_data
from ltdsim.scenario.couplers import COUPLER_CLASSES, DEFAULT_COUPLER_MODEL

from conftest import ROOT


def _base(name: str) -> dict:
    """A shipped scenario, cut to a 1 s run recorded every 10 ms."""
    d = tomllib.loads((ROOT / "scenarios" / name).read_text())
    d["solver"].update(t_end=1.0, output_interval=0.01)
    return d


BASES = {name: _base(name) for name in ("short-train.toml", "two-wagons-linear.toml")}


# --------------------------------------------------------------- TOML written back
def _toml(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return ("nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v)
                else repr(v))
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml(str(k))} = {_toml(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def to_toml(tree: dict) -> str:
    """``tree`` as a TOML file of inline tables (every key quoted)."""
    return "".join(f"{_toml(str(k))} = {_toml(v)}\n" for k, v in tree.items())


# ------------------------------------------------------- values from the schema
def _strip(ann):
    """``(annotation, metadata)`` with Annotated and Optional taken off."""
    meta: list = []
    while True:
        origin = typing.get_origin(ann)
        if origin is typing.Annotated:
            ann, *more = typing.get_args(ann)
            meta += more
            continue
        if origin in (typing.Union, types.UnionType):
            args = [a for a in typing.get_args(ann) if a is not type(None)]
            if len(args) == 1:
                ann = args[0]
                continue
        return ann, meta


def _bounds(meta) -> tuple[float | None, float | None]:
    """The range a field's metadata allows (ge/gt/le/lt, or a ``quantity`` check's)."""
    lo = hi = None
    for m in meta:
        if isinstance(m, at.Ge):
            lo = m.ge
        elif isinstance(m, at.Gt):
            lo = m.gt
        elif isinstance(m, at.Le):
            hi = m.le
        elif isinstance(m, at.Lt):
            hi = m.lt
        elif isinstance(m, AfterValidator) and m.func.__closure__ and \
                "lo" in m.func.__code__.co_freevars:
            cells = dict(zip(m.func.__code__.co_freevars,
                             (c.cell_contents for c in m.func.__closure__)))
            lo, hi = cells["lo"], cells["hi"]
    return lo, hi


#: a value of the wrong kind for most keys
WRONG = st.sampled_from(["1.0", "", "nan", True, False, [], [1.0], {}, {"x": 1.0}])
#: numbers no range expects
ODD = st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308, 5e-324, -5e-324, 0.0,
                       -0.0, -1.0, 1.0, 2 ** 62, -(2 ** 62)])
NAMES = st.sampled_from(["x", "", "loco", "study-850kw", "uic-g", "karwatzki", "a\x1eb",
                         "ä", "mt-2", "ode3", "speed", "x" * 80])
SCALARS = st.one_of(ODD, WRONG, NAMES, st.integers(-10, 10), st.floats(-1e6, 1e6))


def _number(lo, hi, integer: bool):
    edges = []
    for b in (lo, hi):
        if b is None:
            continue
        if integer:
            edges += [int(b), int(b) - 1, int(b) + 1, float(b)]
        else:
            edges += [float(b), math.nextafter(b, -math.inf), math.nextafter(b, math.inf),
                      b * (1 - 1e-9), b * (1 + 1e-9), 2.0 * b, 0.5 * b, int(b)]
    if integer:
        inside = st.integers(-10 if lo is None else int(lo), 10 ** 6 if hi is None else int(hi))
    else:
        inside = st.floats(-1e6 if lo is None else lo, 1e6 if hi is None else hi,
                           allow_nan=False, allow_infinity=False)
    parts = [inside, ODD, WRONG] + ([st.sampled_from(edges)] if edges else [])
    return st.one_of(*parts)


def _is_model(ann) -> bool:
    return isinstance(ann, type) and issubclass(ann, BaseModel)


def _coupler_models(ann) -> list[type[BaseModel]] | None:
    """The coupler classes of the discriminated union ``couplers.default`` is."""
    ann, _ = _strip(ann)
    if typing.get_origin(ann) in (typing.Union, types.UnionType):
        members = [_strip(a)[0] for a in typing.get_args(ann)]
        if any(m in COUPLER_CLASSES.values() for m in members):
            return list(COUPLER_CLASSES.values())
    return None


def values(ann, meta=(), depth: int = 0):
    """A strategy of values for a key of type ``ann`` with ``meta`` (its constraints):
    mostly of its kind, in and around its range, sometimes anything at all."""
    ann, more = _strip(ann)
    meta = [*meta, *more]
    origin = typing.get_origin(ann)
    couplers = _coupler_models(ann)
    if couplers is not None:
        return st.one_of(st.sampled_from(couplers).flatmap(lambda c: table(c, depth)),
                         st.sampled_from(preset_names("gears")).map(lambda p: {"preset": p}),
                         WRONG)
    if _is_model(ann):
        return table(ann, depth) if depth < 3 else st.one_of(st.just({}), WRONG)
    if origin is typing.Literal:
        choices = list(typing.get_args(ann))
        return st.one_of(st.sampled_from(choices),
                         st.sampled_from(["bogus", str(choices[0]).upper(), 1]))
    if origin in (typing.Union, types.UnionType):
        return st.one_of(*(values(a, meta, depth) for a in typing.get_args(ann)
                           if a is not type(None)))
    if origin in (list, tuple):
        args = [a for a in typing.get_args(ann) if a is not Ellipsis]
        if origin is tuple:
            row = st.tuples(*(values(a, (), depth + 1) for a in args)).map(list)
            return st.one_of(row, st.lists(st.floats(-1e3, 1e3), max_size=4), WRONG)
        item = values(args[0], (), depth + 1) if args else SCALARS
        return st.one_of(st.lists(item, max_size=3), WRONG)
    if origin is dict:
        return st.one_of(st.dictionaries(NAMES, SCALARS, max_size=2), WRONG)
    if ann is bool:
        return st.one_of(st.booleans(), st.sampled_from([0, 1, "true"]))
    if ann is int:
        return _number(*_bounds(meta), integer=True)
    if ann is float:
        return _number(*_bounds(meta), integer=False)
    if ann is str:
        return st.one_of(NAMES, st.text(max_size=6), ODD)
    return SCALARS  # Any


def table(cls: type[BaseModel], depth: int = 0):
    """A table of ``cls``: some of its keys (its required ones usually), each a value of
    :func:`values`; now and then an unknown key."""
    fields = cls.model_fields
    required = {k: values(f.annotation, f.metadata, depth + 1)
                for k, f in fields.items() if f.is_required()}
    optional = {k: values(f.annotation, f.metadata, depth + 1)
                for k, f in fields.items() if not f.is_required()}
    model = getattr(fields.get("model"), "default", None)
    fixed = {"model": st.just(model)} if isinstance(model, str) else {}
    base = st.fixed_dictionaries({**required, **fixed},
                                 optional={k: v for k, v in optional.items() if k not in fixed})
    return st.one_of(base, base.map(lambda d: {**d, "unknown_key": 1.0}))


def _table_class(f, data):
    """The model a key's table is read as (``data``: the table given), or None."""
    couplers = _coupler_models(f.annotation)
    if couplers is not None:
        model = data.get("model", DEFAULT_COUPLER_MODEL) if isinstance(data, dict) else None
        return COUPLER_CLASSES.get(model) if isinstance(model, str) else None
    ann, _ = _strip(f.annotation)
    return ann if _is_model(ann) else None


def _item_class(f):
    """The model of a list-of-tables key's items (``[[vehicles]]``), or None."""
    ann, _ = _strip(f.annotation)
    if typing.get_origin(ann) is list:
        item, _ = _strip(typing.get_args(ann)[0])
        return item if _is_model(item) else None
    return None


@st.composite
def schema_mutation(draw, tree: dict) -> str:
    """Change ``tree`` in place at one key the schema knows (or an unknown key beside
    them): walk down the models from Scenario, following tables present in the tree,
    then set the key to a value of its kind (in, at or beyond its range, or of another
    type) or delete it. Returns the dotted key changed."""
    node, cls, path = tree, Scenario, []
    while True:
        name = draw(st.sampled_from([*cls.model_fields, "unknown_key"]), label="key")
        f = cls.model_fields.get(name)
        if f is not None and draw(st.integers(0, 9), label="descend") < 7:
            sub = node.get(name)
            inner = _table_class(f, sub if isinstance(sub, dict) else {})
            if inner is not None and isinstance(sub, dict):
                node, cls, path = sub, inner, [*path, name]
                continue
            if inner is not None and sub is None and f.annotation is not None:
                node[name] = {}
                node, cls, path = node[name], inner, [*path, name]
                continue
            item = _item_class(f)
            if item is not None and isinstance(sub, list) and sub:
                i = draw(st.integers(0, len(sub) - 1), label="item")
                if isinstance(sub[i], dict):
                    node, cls, path = sub[i], item, [*path, name, str(i)]
                    continue
        path.append(name)
        if f is None:
            node[draw(st.sampled_from(["unknown_key", "Mass", "t-end", "", "ä"]))] = \
                draw(SCALARS, label="value")
        elif draw(st.integers(0, 9), label="delete") == 0:
            node.pop(name, None)
        else:
            node[name] = draw(values(f.annotation, f.metadata), label="value")
        return ".".join(path)


# ------------------------------------------------------------ plausible trains
DTS = [1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2]


@st.composite
def plausible_change(draw, tree: dict) -> str:
    """A change a user would make to a working train: the vehicles, the couplers, the
    brakes or the solver (runs stay a few seconds of simulated time at most)."""
    what = draw(st.sampled_from(["vehicles", "couplers", "brakes", "solver", "speed", "drive",
                                 "energy", "record", "unstable", "curving", "notch"]),
                label="change")
    veh = tree["vehicles"]
    if what == "vehicles":
        veh[-1]["count"] = draw(st.integers(1, 60), label="count")
        veh[-1]["mass"] = draw(st.floats(5e3, 1.5e5), label="mass")
        veh[0]["mass"] = draw(st.floats(2e4, 2e5), label="loco mass")
        veh[0].pop("static_mass", None)
    elif what == "couplers":
        kind = draw(st.sampled_from(["preset", "linear", "simplified"]), label="coupler")
        if kind == "preset":
            gear = {"preset": draw(st.sampled_from(preset_names("gears")), label="preset")}
        elif kind == "linear":
            gear = {"model": "linear", "slack": draw(st.sampled_from([0.0, 0.01, 0.025])),
                    "stiffness": draw(st.floats(1e5, 1e8)), "damping": draw(st.floats(0, 1e6))}
        else:
            gear = dict(BASES["short-train.toml"]["couplers"]["default"])
        tree["couplers"] = {"default": gear}
    elif what == "brakes":
        model = draw(st.sampled_from(["lumped", "fluid"]), label="brake model")
        for v in veh[1:]:
            v["brake"] = {"cylinder_force": 4.05e4, "rigging_ratio": 2.6, "shoes": 8,
                          "friction": 0.3}
        tree["brake"] = {"model": model}
        if model == "fluid":
            tree["brake"]["fluid"] = {"valve": draw(st.sampled_from(preset_names("brakes"))),
                                      "cells_per_vehicle": draw(st.integers(1, 3))}
            tree["driver"]["brake_commands"] = [{"time": 0.2, "handle": "full"}]
        else:
            tree["driver"]["brake_profile"] = [[0.0, 0.0], [0.2, 1.0]]
    elif what == "solver":
        dt = draw(st.sampled_from(DTS), label="dt")
        sv = tree["solver"]
        sv["method"] = draw(st.sampled_from(["euler", "heun", "ode3", "rk4", "bs23"]))
        sv["dt"] = dt
        sv["output_interval"] = dt * draw(st.sampled_from([1, 10, 100]), label="record every")
        sv["t_end"] = max(sv["output_interval"], draw(st.floats(0.05, 3.0), label="t_end"))
        pid = tree["driver"].get("pid")
        if pid is not None:
            pid["ts"] = dt
    elif what == "speed":
        tree.setdefault("initial", {})["speed"] = draw(st.floats(0.0, 30.0), label="speed")
    elif what == "drive":
        tree["traction"]["drive"] = "induction"
    elif what == "energy":
        tree["solver"]["energy"] = True
    elif what == "record":
        tree["solver"]["record"] = draw(st.lists(st.sampled_from(
            ["position", "velocity", "coupler_force", "brake_force", "motor_torque",
             "brake_pipe_pressure"]), max_size=3, unique=True), label="record")
    elif what == "unstable":
        # a step its method cannot keep stable, run anyway: a clean SimulationError
        tree["solver"].update(stability_check=False, dt=0.01, output_interval=0.01,
                              method=draw(st.sampled_from(["euler", "ode3"])))
        if draw(st.booleans(), label="stiff"):
            tree["couplers"] = {"default": {"model": "linear", "slack": 0.0,
                                            "stiffness": 1e9, "damping": 0.0}}
        pid = tree["driver"].get("pid")
        if pid is not None:
            pid["ts"] = 0.01
    elif what == "curving":
        tree["curving"] = {}
        tree["solver"].pop("record", None)
    else:
        tree["driver"] = {"mode": "notch", "notch_profile": [[0.0, 0.0], [0.5, 8.0]]}
    return what


# ---------------------------------------------------------------- the checks
def check_refusal(exc: ScenarioError, source: str) -> None:
    """One line per problem, each starting with the file's name; a problem's own text
    is one line."""
    text = str(exc)
    lines = text.split("\n")
    assert exc.problems and len(lines) == len(exc.problems), text
    assert all(line.startswith(source) for line in lines), text
    for key, msg in exc.problems:
        assert "\n" not in key and "\n" not in msg and msg.strip(), (key, msg)


def load_outcome(tree: dict, path) -> Scenario | ScenarioError:
    """``load_scenario`` of ``tree`` written as TOML at ``path``, checked: a Scenario that
    can be lowered, estimated and saved, or a clean refusal."""
    path.write_text(to_toml(tree), encoding="utf-8")
    try:
        sc = ltdsim.load_scenario(path)
    except ScenarioError as exc:
        check_refusal(exc, str(path))
        return exc
    lower(sc)  # a scenario that loads can be lowered to the kernel's arrays
    est = estimate(sc)
    assert est.steps > 0 and est.bytes > 0 and math.isfinite(est.seconds), est
    # a result keeps its scenario as JSON: that reads back as the same scenario
    again = Scenario.from_saved(json.loads(json.dumps(sc.to_dict())), "result")
    assert again.to_dict() == sc.to_dict()
    return sc


#: the same examples on every machine and run (CI reproduces a failure), no time limit
REPRODUCIBLE = dict(deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                           HealthCheck.function_scoped_fixture])


@pytest.fixture(scope="module")
def tmp_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("random-scenarios")


@settings(max_examples=150, **REPRODUCIBLE)
@given(base=st.sampled_from(sorted(BASES)), data=st.data())
def test_a_schema_built_tree_loads_or_is_refused_in_one_line_per_problem(tmp_dir, base, data):
    tree = copy.deepcopy(BASES[base])
    for _ in range(data.draw(st.integers(1, 3), label="mutations")):
        data.draw(schema_mutation(tree), label="changed")
    path = tmp_dir / "tree.toml"
    got = load_outcome(tree, path)
    # the same tree as a dictionary: the same outcome (no CSV profile read from a file)
    track = tree.get("track")
    if not (isinstance(track, dict) and isinstance(track.get("profile_file"), str)):
        try:
            again = scenario_from_data(copy.deepcopy(tree), str(path))
        except ScenarioError as exc:
            assert isinstance(got, ScenarioError) and str(exc) == str(got), (str(exc), got)
        else:
            assert isinstance(got, Scenario), got
            assert again.to_dict() == got.to_dict()


# ------------------------------------------------------------ the command line
_SIMULATE = importlib.import_module("ltdsim.results.simulate")


def run_cli(path, *options):
    """``ltdsim run`` in-process: (exit code, stdout, stderr, the result if it ran)."""
    from typer.testing import CliRunner

    from ltdsim.cli.app import app

    made = []
    real = _SIMULATE.simulate

    def keep(*args, **kw):
        made.append(real(*args, **kw))
        return made[-1]

    _SIMULATE.simulate = keep
    try:
        res = CliRunner().invoke(app, ["run", str(path), *options])
    finally:
        _SIMULATE.simulate = real
    text = res.stdout + res.stderr
    assert res.exception is None or isinstance(res.exception, SystemExit), (
        repr(res.exception), text)
    assert "Traceback" not in text, text
    return res.exit_code, res.stdout, res.stderr, (made[0] if made else None)


def check_cli(tree: dict, path) -> int:
    """The command line on ``tree``: a clean refusal, or a run within its estimate."""
    got = load_outcome(tree, path)
    est = estimate(got) if isinstance(got, Scenario) else None
    long = est is not None and est.seconds > 2.0
    code, out, err, ds = run_cli(path, "--max-time", "2" if long else "5", "-q")
    assert code in (0, 2, 3), (code, out, err)
    errors = [line for line in err.splitlines() if line.startswith("error")]
    if code != 0:
        assert len(errors) == 1, err
        assert ds is None or code == 3, err
    if isinstance(got, ScenarioError):
        assert code == 2, (code, err)
        return code
    if long:  # refused before it starts, with the estimate and the option to raise it
        assert code == 2 and "--max-time" in err, (est, code, err)
        return code
    if code == 0:
        assert ds is not None and not errors, err
        assert ds.nbytes <= est.bytes, (ds.nbytes, est)
        if est.exact:
            assert ds.attrs["steps"] == est.steps == got.solver.n_steps, (ds.attrs["steps"], est)
    return code


@settings(max_examples=20, **REPRODUCIBLE)
@given(base=st.sampled_from(sorted(BASES)), data=st.data())
def test_the_command_line_runs_a_random_train_or_refuses_it_in_one_line(tmp_dir, base, data):
    tree = copy.deepcopy(BASES[base])
    for _ in range(data.draw(st.integers(1, 3), label="changes")):
        data.draw(plausible_change(tree), label="changed")
    if data.draw(st.integers(0, 2), label="schema change") == 0:
        data.draw(schema_mutation(tree), label="changed")
    check_cli(tree, tmp_dir / "run.toml")


# ------------------------------------------------------ what the property found
def test_a_curving_run_stays_within_its_memory_estimate(tmp_dir):
    """[curving] adds four series per vehicle and coupler to the result, after the run:
    the estimate counted none of them (the result took 29,324 bytes of an estimated
    22,872)."""
    tree = copy.deepcopy(BASES["two-wagons-linear.toml"])
    tree["curving"] = {}
    assert check_cli(tree, tmp_dir / "curving.toml") == 0
