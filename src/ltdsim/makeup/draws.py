"""The population of a make-up study: each make-up drawn from the study's rules with its
own seeded generator (make-up ``i`` from ``numpy.random.default_rng([seed, i])``, so the
same seed gives the same population and more make-ups leave the first ones as they
were), what it is made of (its features), and the scenario overrides that turn the base
scenario's train into it.

A make-up keeps the base scenario's locomotive consists: the lead consist at the front,
each remote consist behind the wagon position drawn for it. Its wagons come in blocks
of ``block`` alike wagons (one type in one state); the counts of each type and state
are whole blocks (a share rounded to the nearest block; without an entry taking the
rest, by largest remainder); the blocks covering wagon positions 1 to
``empties_behind`` are loaded ones, drawn at random, and every other block is placed
at random behind them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ltdsim.makeup.study import Study, vehicle_dict


@dataclass(frozen=True)
class Makeup:
    """One make-up: its id (``m0001`` for the first), its wagons front to rear as
    ``(type, state)`` pairs, and the wagon position each remote consist stands behind
    (wagons counted from 1)."""

    id: str
    wagons: tuple[tuple[str, str], ...]
    remote_after: tuple[int, ...]

    @property
    def empty(self) -> np.ndarray:
        """True for each empty wagon, front to rear."""
        return np.array([s == "empty" for _, s in self.wagons])

    def label(self) -> str:
        """The wagons as runs of alike wagons, ``ore-loaded x20 | ore-empty x5 | ...``,
        with the remote consists where they stand."""
        parts, k = [], 0
        remotes = list(self.remote_after)
        n = len(self.wagons)
        while k < n:
            j = k
            while j + 1 < n and self.wagons[j + 1] == self.wagons[k] and \
                    (j + 1) not in remotes:
                j += 1
            parts.append(f"{self.wagons[k][0]}-{self.wagons[k][1]} x{j - k + 1}")
            if (j + 1) in remotes:
                parts.append("REMOTE")
            k = j + 1
        return " | ".join(parts)


def draw_population(study: Study) -> list[Makeup]:
    """The study's make-ups, in order (``m0001``, ``m0002``, ...)."""
    return [draw_makeup(study, i) for i in range(study.spec.makeups)]


def _counts(study: Study, rng) -> list[int]:
    """Blocks of each mix entry for one make-up (the ranged shares drawn)."""
    spec = study.spec
    nb = study.wagons // spec.block
    target = []
    for e in spec.mix:
        if e.count is not None:
            target.append(e.count / spec.block)
        elif isinstance(e.share, tuple):
            target.append(rng.uniform(*e.share) * nb)
        elif e.share is not None:
            target.append(e.share * nb)
        else:
            target.append(None)
    if None in target:
        counts = [0 if t is None else math.floor(t + 0.5) for t in target]
        counts[target.index(None)] = nb - sum(counts)
        return counts
    counts = [math.floor(t + 1e-9) for t in target]
    left = nb - sum(counts)
    order = sorted(range(len(target)), key=lambda k: (-(target[k] - counts[k]), k))
    for k in order[:left]:
        counts[k] += 1
    return counts


def draw_makeup(study: Study, i: int) -> Makeup:
    """Make-up ``i`` (0 for the first) of ``study``."""
    spec = study.spec
    rng = np.random.default_rng([spec.seed, i])
    counts = _counts(study, rng)
    loaded, empty = [], []
    for e, c in zip(spec.mix, counts):
        (empty if e.state == "empty" else loaded).extend([(e.type, e.state)] * c)
    rng.shuffle(loaded)
    front_blocks = math.ceil(spec.empties_behind / spec.block)
    front, others = loaded[:front_blocks], loaded[front_blocks:] + empty
    order = rng.permutation(len(others))
    blocks = front + [others[k] for k in order]
    wagons = tuple(w for b in blocks for w in [b] * spec.block)
    remotes = tuple(int(r) if isinstance(r, int) else int(rng.integers(r[0], r[1] + 1))
                    for r in spec.remote_after)
    return Makeup(f"m{i + 1:04d}", wagons, remotes)


# ------------------------------------------------------------------- the train
@dataclass(frozen=True)
class Train:
    """A make-up as a train: each vehicle's base index (None for a wagon), its wagon
    (``(type, state)``, None for a locomotive) and length, m, front to rear."""

    base_index: tuple[int | None, ...]
    wagon: tuple[tuple[str, str] | None, ...]
    lengths: tuple[float, ...]

    def coupler_positions(self) -> np.ndarray:
        """Distance of each coupler from the front of the train, m (coupler 1 first)."""
        return np.cumsum(self.lengths)[:-1]


def train_of(study: Study, makeup: Makeup) -> Train:
    """The vehicles of ``makeup`` front to rear: the lead consist, the wagons with the
    remote consists where they stand."""
    base = study.base
    index: list[int | None] = []
    wagon: list[tuple[str, str] | None] = []
    lengths: list[float] = []

    def loco(consist):
        for i in consist:
            index.append(i)
            wagon.append(None)
            lengths.append(base.vehicles[i].length)

    loco(study.consists[0])
    remotes = dict(zip(makeup.remote_after, study.consists[1:]))
    for k, w in enumerate(makeup.wagons, start=1):
        index.append(None)
        wagon.append(w)
        lengths.append(_wagon_length(study, w[0]))
        if k in remotes:
            loco(remotes[k])
    return Train(tuple(index), tuple(wagon), tuple(lengths))


def _wagon_length(study: Study, type_name: str) -> float:
    t = next(t for t in study.spec.types if t.name == type_name)
    return t.length if t.length is not None else float(study.templates[type_name]["length"])


def makeup_overrides(study: Study, makeup: Makeup) -> dict:
    """The dotted-key overrides that make the base scenario's train ``makeup``: its
    vehicles (runs of alike vehicles as one table with ``count``), each consist's new
    vehicle indices, and the coupler overrides: the base's between two vehicles of one
    consist (kept with the consist) and each wagon type's ``coupler`` table on the
    coupler ahead of its wagons. The base's other coupler overrides (between a
    locomotive and a wagon, or two wagons) belong to its own train and are dropped."""
    base = study.base
    train = train_of(study, makeup)
    tables: list[dict] = []
    for i, w in zip(train.base_index, train.wagon):
        v = (base.vehicles[i].model_dump(mode="json", exclude={"count"}) if w is None
             else vehicle_dict(study, *w))
        if tables and tables[-1]["key"] == (i, w) and w is not None:
            tables[-1]["table"]["count"] += 1
        else:
            tables.append({"key": (i, w), "table": {**v, "count": 1}})
    out: dict = {"vehicles": [t["table"] for t in tables]}
    where = {i: k for k, i in enumerate(train.base_index) if i is not None}
    if base.locomotives:
        for k, loco in enumerate(base.locomotives):
            out[f"locomotives.{k}.vehicles"] = [where[i] for i in loco.vehicles]
    if base.couplers is not None:
        same = {i: c for c, consist in enumerate(study.consists) for i in consist}
        overrides = []
        for o in base.couplers.override:
            a, b = o.index, o.index + 1
            if a in same and b in same and same[a] == same[b]:
                table = o.model_dump(mode="json", exclude_none=True)
                table["index"] = where[a]
                overrides.append(table)
        couplers = {t.name: t.coupler for t in study.spec.types if t.coupler}
        for j, w in enumerate(train.wagon):
            if w is not None and j > 0 and w[0] in couplers:
                overrides.append({"index": j - 1, **couplers[w[0]]})
        out["couplers.override"] = sorted(overrides, key=lambda t: t["index"])
    return out


def coupler_limits(study: Study, train: Train) -> tuple[np.ndarray, np.ndarray]:
    """Each coupler's LCF and LTF limits, N: the lower of the limits of the wagons it
    joins (a coupler between two locomotives: the study's ``[limits]``, NaN without)."""
    spec = study.spec
    flat = (math.nan if spec.limits is None or spec.limits.lcf is None else spec.limits.lcf,
            math.nan if spec.limits is None or spec.limits.ltf is None else spec.limits.ltf)
    n = len(train.wagon)
    lcf, ltf = np.full(n - 1, np.nan), np.full(n - 1, np.nan)
    for j in range(n - 1):
        ends = [study.limits[w] for w in (train.wagon[j], train.wagon[j + 1])
                if w is not None]
        if not ends:
            ends = [flat]
        lcf[j] = np.nanmin([e[0] for e in ends]) if any(e[0] == e[0] for e in ends) else np.nan
        ltf[j] = np.nanmin([e[1] for e in ends]) if any(e[1] == e[1] for e in ends) else np.nan
    return lcf, ltf


# ------------------------------------------------------------------- features
def features(makeup: Makeup) -> dict:
    """What a make-up is made of: its empties (count, -, and share, -), the share of
    (empty, loaded) pairs of wagons with the empty ahead (-: 1 when every empty stands
    ahead of every load, 0 when behind them all, NaN without both), its longest run of
    neighbouring empty wagons (wagons, -; a remote consist between two wagons does not
    break a run) and the most empties standing right ahead of a remote consist (wagons,
    -: the run of empties its pushing loads first; 0 without remote consists)."""
    e = makeup.empty
    n_e, n = int(e.sum()), len(e)
    # pairs (empty at i, loaded at j > i): for each load, the empties ahead of it
    ahead = np.cumsum(e)
    pairs = float(ahead[~e].sum())
    total = n_e * (n - n_e)
    run = best = 0
    for x in e:
        run = run + 1 if x else 0
        best = max(best, run)
    before = 0
    for at in makeup.remote_after:
        k = at
        while k > 0 and e[k - 1]:
            k -= 1
        before = max(before, at - k)
    return {"empties": n_e, "empty_share": n_e / n if n else math.nan,
            "empties_ahead_of_loads": pairs / total if total else math.nan,
            "longest_empty_run": best, "empties_ahead_of_remote": before}
