"""The key reference of ``docs/scenario.md``, generated from the scenario schema.

Every model class reachable from :class:`ltdsim.scenario.Scenario` becomes one table:
for each key its dotted path (as ``--set`` and error messages spell it; ``<i>`` stands
for an index), type, unit, default, allowed values and meaning. Units, ranges and
defaults come from the pydantic fields, so the document cannot drift from the code:
``tests/scenario/test_schema_doc.py`` fails when the file differs from what this module writes.

Rewrite the tables in place with ``python -m ltdsim.scenario.doc`` (``--check`` only
reports whether they are current). The tables sit between marker comments::

    <!-- BEGIN schema solver -->
    ...generated...
    <!-- END schema solver -->

one block per section (``solver``, ``vehicles``, ``vehicles.brake``, ``couplers.default``,
``driver.pid``, ...; ``top`` for the top-level keys), so the hand-written prose around
them stays. A section without its own block goes, with a heading, into the block named
``rest``; a block that names no section is an error.

Description convention (what this module reads from ``Field(description=...)``):

- ``"meaning, UNIT"`` or ``"meaning, UNIT (note)"``: the unit is the last comma-separated
  part (a trailing note in parentheses aside), written with SI symbols (``m``, ``s``,
  ``kg``, ``N``, ``W``, ``deg``, ...), products by a space, powers by ``^``, one ``/``:
  ``N s^2/m^2``, ``1/s``, ``m/s^2``; ``-`` means dimensionless; ``U and U`` for a value
  that takes two units (``m and m/s``).
- an array of points starts with its columns, each ending in its unit:
  ``"[t s, v m/s] or [t s, v m/s, jerk time s] ..."``, ``"[start position m, grade -]"``.
- a flag, a choice (``Literal``), a text (``str``: a name, a label), a file path or a whole number (count,
  index) needs no unit (:data:`UNITLESS`); everything else (a number, an array of numbers)
  does, and :func:`missing_units` names each field that lacks one.
- ranges enforced by a validator rather than by ``Field(ge=..., le=...)`` (a table's
  columns, "a whole multiple of dt") are written in the meaning.

A field whose type is a union of models with a ``discriminator`` (the coupler models on
``model``) gives one table per member, headed by its discriminator value, each listing
that member's keys.
"""

from __future__ import annotations

import argparse
import functools
import re
import sys
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Literal, Union

import annotated_types
from pydantic import BaseModel
from pydantic.fields import FieldInfo

#: kinds of value that carry no unit (the unit column shows "–")
UNITLESS = ("flag", "choice", "text", "path", "whole number")

#: the document this module writes: the source tree's (a wheel carries no docs/, so an
#: installed package looks for it in the working folder)
_SOURCE_DOC = Path(__file__).resolve().parents[3] / "docs" / "scenario.md"
DOC = _SOURCE_DOC if _SOURCE_DOC.is_file() else Path("docs/scenario.md")

_ATOM = r"(?:kg|km|mm|m|s|kN|N|kW|W|J|Pa|Hz|rad|deg|K)(?:\^-?\d+)?"
_PRODUCT = rf"{_ATOM}(?: {_ATOM})*"
_ONE = rf"(?:(?:1|{_PRODUCT})(?:/(?:{_PRODUCT}|\({_PRODUCT}\)))?|-)"
UNIT_RE = re.compile(rf"^{_ONE}(?: and {_ONE})*$")
_SUP = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")

_BEGIN = re.compile(r"<!-- BEGIN schema (\S+) -->\n")
_END = "<!-- END schema {} -->"


# ------------------------------------------------------------------- the model
@dataclass
class Key:
    """One field of one section, as the document shows it."""

    path: str  # dotted, ``<i>`` for an index
    name: str  # the field's name
    kind: str  # number, whole number, flag, choice, text, path, array, points, table, ...
    unit: str | None  # as written in the description (None: none found)
    default: str
    allowed: str
    meaning: str
    needs_unit: bool


@dataclass
class Section:
    """One TOML table (or array of tables, or one member of a discriminated union)."""

    id: str  # block name: the dotted path without indices ("vehicles.brake", "top")
    header: str  # as in the TOML file: "[solver]", "[[vehicles]]", "" for the top level
    model: type[BaseModel]
    status: str  # required / optional and its default, from the parent field
    variant: str | None = None  # discriminator value for a union member
    discriminator: str | None = None  # its key (``model``)
    about: str = ""  # the parent field's description (else the class docstring is used)
    keys: list[Key] = field(default_factory=list)


def _strip_annotated(tp):
    """(bare type, metadata) of a possibly Annotated type."""
    meta: list = []
    while typing.get_origin(tp) is Annotated:
        args = typing.get_args(tp)
        tp, meta = args[0], meta + list(args[1:])
    return tp, meta


def _members(tp) -> list:
    """The members of a union (None dropped), else [tp]."""
    tp, _ = _strip_annotated(tp)
    if typing.get_origin(tp) in (Union, types.UnionType):
        return [a for a in typing.get_args(tp) if a is not type(None)]
    return [tp]


def _is_model(tp) -> bool:
    tp, _ = _strip_annotated(tp)
    return isinstance(tp, type) and issubclass(tp, BaseModel)


def _models_in(tp) -> tuple[list[type[BaseModel]], bool]:
    """The model classes a field holds (through Optional, unions and lists) and whether
    it holds an array of them."""
    out: list = []
    many = False
    for m in _members(tp):
        bare, _ = _strip_annotated(m)
        origin = typing.get_origin(bare)
        if origin is list:
            inner, _ = _models_in(typing.get_args(bare)[0])
            if inner:
                out += inner
                many = True
        elif _is_model(bare):
            out.append(bare)
    return out, many


def fmt_number(x) -> str:
    """A number as the document writes it: ``0.976``, ``20000``, ``1e-4``, ``1e12``."""
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, int):
        return str(x)
    x = float(x)
    if x == 0.0:
        return "0"
    if abs(x) >= 1e5 or abs(x) < 1e-3:
        mant, exp = f"{x:.6e}".split("e")
        mant = mant.rstrip("0").rstrip(".")
        return f"{mant}e{int(exp)}"
    return f"{x:.6g}"


def fmt_unit(unit: str | None) -> str:
    """A unit for reading: powers as superscripts, ``-`` (dimensionless) and none as –."""
    if unit is None or unit == "-":
        return "–"
    return re.sub(r"\^(-?\d+)", lambda m: m.group(1).translate(_SUP), unit)


def _toml(value) -> str:
    """A default value as TOML writes it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return fmt_number(value)
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + "}"
    return str(value)


def _bounds(meta) -> dict:
    """ge/gt/le/lt/min_length/max_length from a field's metadata."""
    out: dict = {}
    for m in meta:
        if isinstance(m, FieldInfo):  # Annotated[float, Field(gt=0)]: its constraints
            out.update(_bounds(m.metadata))
            continue
        for name in ("ge", "gt", "le", "lt", "min_length", "max_length"):
            v = getattr(m, name, None)
            if v is not None:
                out[name] = v
        if isinstance(m, annotated_types.Interval):
            for name in ("ge", "gt", "le", "lt"):
                if getattr(m, name) is not None:
                    out[name] = getattr(m, name)
    return out


def interval(b: dict) -> str:
    """``(0, 1]``, ``≥ 0``, ``> 0``, ``≤ 8`` from bounds, or "" without any."""
    lo = ("(", b["gt"]) if "gt" in b else ("[", b["ge"]) if "ge" in b else None
    hi = (")", b["lt"]) if "lt" in b else ("]", b["le"]) if "le" in b else None
    if lo and hi:
        return f"{lo[0]}{fmt_number(lo[1])}, {fmt_number(hi[1])}{hi[0]}"
    if lo:
        return f"{'>' if lo[0] == '(' else '≥'} {fmt_number(lo[1])}"
    if hi:
        return f"{'<' if hi[0] == ')' else '≤'} {fmt_number(hi[1])}"
    return ""


def _count_phrase(b: dict, what: str) -> str:
    lo, hi = b.get("min_length"), b.get("max_length")
    if lo and hi:
        return f"{lo} to {hi} {what}"
    if lo == 1:
        return "non-empty"
    if lo:
        return f"at least {lo} {what}"
    if hi:
        return f"at most {hi} {what}"
    return ""


def _describe_type(tp, meta) -> tuple[str, str]:
    """(kind, allowed) of one non-model member type with its constraints."""
    bare, inner_meta = _strip_annotated(tp)
    b = _bounds(list(meta) + inner_meta)
    origin = typing.get_origin(bare)
    if bare is bool:
        return "flag", "true, false"
    if origin is Literal:
        return "choice", ", ".join(f'`"{a}"`' for a in typing.get_args(bare))
    if bare is int:
        return "whole number", interval(b) or "any"
    if bare is float:
        return "number", interval(b) or "any"
    if bare is str:
        return "text", _count_phrase(b, "characters") or "any"
    if isinstance(bare, type) and issubclass(bare, Path):
        return "path", "a file"
    if origin is tuple:
        return "point", f"[{', '.join('xyz'[:len(typing.get_args(bare))])}]"
    if origin is list:
        (elem,) = typing.get_args(bare)
        ebare, _ = _strip_annotated(elem)
        ekinds = [typing.get_origin(_strip_annotated(e)[0]) for e in _members(ebare)]
        if all(k is tuple for k in ekinds):
            widths = [len(typing.get_args(_strip_annotated(e)[0])) for e in _members(ebare)]
            shape = " or ".join(f"[{', '.join('xyz'[:w])}]" for w in widths)
            allowed = f"array of {shape} points"
            extra = _count_phrase(b, "points")
            return "points", allowed + (f", {extra}" if extra else "")
        ekind, eallowed = _describe_type(elem, [])
        parts = [f"each {eallowed}" if eallowed not in ("any", "") else ""]
        parts.append(_count_phrase(b, "values"))
        allowed = "; ".join(p for p in parts if p) or "any"
        head, sep, tail = ekind.partition(" of ")
        return f"array of {head}s{sep}{tail}", allowed
    if origin is dict:
        return "table", "any keys"
    if isinstance(bare, type) and issubclass(bare, BaseModel):  # a table among other forms
        return "table", "keys " + ", ".join(f"`{k}`" for k in bare.model_fields)
    if typing.get_origin(bare) in (Union, types.UnionType):
        kinds, alloweds = zip(*(_describe_type(m, []) for m in _members(bare)))
        return " or ".join(dict.fromkeys(kinds)), " or ".join(alloweds)
    return getattr(bare, "__name__", str(bare)), "any"


def needs_unit(tp) -> bool:
    """Whether a value of type ``tp`` is a quantity (a number, or numbers in an array),
    which needs a unit; flags, choices, names, paths and whole numbers do not."""
    bare, _ = _strip_annotated(tp)
    origin = typing.get_origin(bare)
    if origin in (Union, types.UnionType):
        return any(needs_unit(m) for m in _members(bare))
    if origin in (list, tuple):
        return any(needs_unit(a) for a in typing.get_args(bare) if a is not Ellipsis)
    return bare is float


def split_unit(description: str | None) -> tuple[str, str | None]:
    """(meaning, unit) of a description written ``"meaning, UNIT (note)"``; the unit is
    None when the last comma-separated part is not a unit."""
    text = (description or "").strip()
    note = ""
    if text.endswith(")") and "(" in text:
        depth, k = 0, len(text) - 1
        while k >= 0:
            depth += {")": 1, "(": -1}.get(text[k], 0)
            if depth == 0:
                break
            k -= 1
        if k > 0:
            text, note = text[:k].rstrip(), text[k:]
    head, sep, last = text.rpartition(",")
    candidate = last.strip() if sep else text
    if UNIT_RE.match(candidate):
        meaning = head.strip() if sep else ""
        return (f"{meaning} {note}".strip() if note else meaning), candidate
    return (description or "").strip(), None


def column_units(description: str | None) -> str | None:
    """The units of a points array from the bracketed column lists that open its
    description: ``"[t s, v m/s] or [t s, v m/s, jerk time s] ..."`` gives
    ``"[s, m/s] or [s, m/s, s]"``; None when a column has no unit."""
    text = (description or "").strip()
    groups = []
    while text.startswith("["):
        end = text.find("]")
        if end < 0:
            return None
        units = []
        for col in text[1:end].split(","):
            words = col.split()
            unit = next((" ".join(words[k:]) for k in range(len(words))
                         if UNIT_RE.match(" ".join(words[k:]))), None)
            if unit is None:
                return None
            units.append(unit)
        groups.append(units)
        text = text[end + 1:].lstrip()
        if text.startswith("or ["):
            text = text[3:]
        else:
            break
    if not groups:
        return None
    return " or ".join("[" + ", ".join(g) + "]" for g in groups)


def _default(f: FieldInfo) -> str:
    if f.is_required():
        return "required"
    value = f.get_default(call_default_factory=True)
    if value is None:
        return "none"
    if isinstance(value, BaseModel):
        return "table"
    if isinstance(value, (list, dict)) and not value:
        return "none"
    return f"`{_toml(value if not isinstance(value, tuple) else list(value))}`"


def _key(path: str, name: str, f: FieldInfo) -> Key:
    kinds, alloweds = [], []
    for m in _members(f.annotation):
        k, a = _describe_type(m, f.metadata)
        kinds.append(k)
        alloweds.append(a)
    kind = " or ".join(dict.fromkeys(kinds))
    allowed = " or ".join(dict.fromkeys(alloweds))
    quantity = needs_unit(f.annotation)
    if kind == "points":
        unit, meaning = column_units(f.description), (f.description or "").strip()
    elif quantity:
        meaning, unit = split_unit(f.description)
    else:
        meaning, unit = (f.description or "").strip(), None
    return Key(path=path, name=name, kind=kind, unit=unit, default=_default(f),
               allowed=allowed, meaning=meaning, needs_unit=quantity)


def _status(f: FieldInfo | None, model: type[BaseModel]) -> str:
    """Required, or optional and what holds without the table."""
    if f is None:
        return ""
    if f.is_required():
        extra = _count_phrase(_bounds(f.metadata), "tables")
        return f"required, {extra}" if extra and extra != "non-empty" else (
            "required, at least one" if extra else "required")
    value = f.get_default(call_default_factory=True)
    if value is None or (isinstance(value, list) and not value):
        return "optional"
    if isinstance(value, list):
        return "optional; default " + _toml([v.model_dump() if isinstance(v, BaseModel) else v
                                              for v in value])
    if isinstance(value, BaseModel):
        changed = {k: getattr(value, k) for k, fi in type(value).model_fields.items()
                   if not fi.is_required()
                   and getattr(value, k) != fi.get_default(call_default_factory=True)}
        if changed:
            keys = ", ".join(f"`{k} = {_toml(v)}`" for k, v in changed.items())
            return f"optional; without it every key takes its default, and {keys}"
        return "optional; without it every key takes its default"
    return "optional"


def _literal_key(models: list[type[BaseModel]]) -> str | None:
    """The key that tells union members apart when the union's discriminator is a
    function: a field that at least two members type as a ``Literal`` of one value."""
    for name in {n for m in models for n in m.model_fields}:
        if sum(name in m.model_fields and _single_literal(m.model_fields[name].annotation)
               for m in models) >= 2:
            return name
    return None


def _single_literal(tp) -> bool:
    bare, _ = _strip_annotated(tp)
    return typing.get_origin(bare) is typing.Literal and len(typing.get_args(bare)) == 1


def _discriminator(f: FieldInfo | None, tp) -> str | None:
    if f is not None and isinstance(f.discriminator, str):
        return f.discriminator
    for m in _members(tp):
        bare, meta = _strip_annotated(m)
        if typing.get_origin(bare) is list:
            return _discriminator(None, typing.get_args(bare)[0])
        for x in meta:
            if isinstance(getattr(x, "discriminator", None), str):
                return x.discriminator
    _, meta = _strip_annotated(tp)
    for x in meta:
        if isinstance(getattr(x, "discriminator", None), str):
            return x.discriminator
    return None


def sections(root: type[BaseModel] | None = None) -> list[Section]:
    """Every table reachable from ``root`` (default :class:`~ltdsim.scenario.Scenario`),
    depth first in field order; a discriminated union gives one section per member."""
    if root is None:
        from ltdsim.scenario import Scenario as root
    out: list[Section] = []
    seen: set[tuple[str, str | None]] = set()

    def walk(model, sid, header, path, status, variant=None, disc=None, about=""):
        if (sid, variant) in seen:
            return
        seen.add((sid, variant))
        sec = Section(id=sid, header=header, model=model, status=status, variant=variant,
                      discriminator=disc, about=about)
        out.append(sec)
        children = []
        for name, f in model.model_fields.items():
            models, many = _models_in(f.annotation)
            child_path = f"{path}.{name}" if path else name
            if models:
                children.append((name, f, models, many, child_path))
                continue
            if disc is not None and name == disc:
                continue  # shown in the section's heading
            sec.keys.append(_key(child_path, name, f))
        for name, f, models, many, child_path in children:
            cid = f"{sid}.{name}" if sid != "top" else name
            chead = f"[[{cid}]]" if many else f"[{cid}]"
            cpath = f"{child_path}.<i>" if many else child_path
            d = _discriminator(f, f.annotation) if len(models) > 1 else None
            if d is None and len(models) > 1:
                # a union told apart by a function (the couplers): its members are known
                # by the key each fixes to one value; a member that does not (the
                # stand-in refusing an unknown model) has no keys of its own to document
                d = _literal_key(models)
                if d is not None:
                    models = [m for m in models if d in m.model_fields
                              and _single_literal(m.model_fields[d].annotation)]
            for m in models:
                value = m.__name__ if len(models) > 1 else None  # a plain union
                if d is not None:
                    lit = m.model_fields[d].annotation
                    value = typing.get_args(_strip_annotated(lit)[0])[0]
                walk(m, cid, chead, cpath, _status(f, m), value, d, f.description or "")

    walk(root, "top", "", "", "")
    return out


def missing_units(root: type[BaseModel] | None = None) -> list[str]:
    """The dotted paths of the fields that need a unit and have none in their description."""
    return [k.path for s in sections(root) for k in s.keys if k.needs_unit and k.unit is None]


def key_unit(key: str) -> tuple[bool, str | None]:
    """``(known, unit)`` of a dotted scenario key as ``--set`` and sweep files spell it
    (``"couplers.default.k3"``, ``"vehicles.2.mass"``), from the schema's field
    descriptions: ``(True, "N/m")``; ``(True, "-")`` for a dimensionless number;
    ``(True, None)`` for a key that carries no unit (a flag, a choice, a name, a whole
    number); ``(False, None)`` when the key is not a field of the schema or its unit is
    not written there (nothing is guessed)."""
    found = _key_table().get(re.sub(r"\.\d+(?=\.|$)", ".<i>", key))
    if not found:
        return False, None
    if not any(k.needs_unit for k in found):
        return True, None
    units = {k.unit for k in found if k.needs_unit}
    return (True, units.pop()) if len(units) == 1 and None not in units else (False, None)


@functools.lru_cache(maxsize=1)
def _key_table() -> dict[str, list[Key]]:
    """Every documented key by its dotted path (one per model that has the key)."""
    out: dict[str, list[Key]] = {}
    for sec in sections():
        for k in sec.keys:
            out.setdefault(k.path, []).append(k)
    return out


# ---------------------------------------------------------------- the Markdown
def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _intro(sec: Section) -> str:
    what = f"`{sec.header}`" if sec.header else "Top-level keys"
    if sec.variant is not None:
        what += (f" with `{sec.discriminator} = \"{sec.variant}\"`" if sec.discriminator
                 else f" as `{sec.variant}`")
    if sec.status:
        what += f" ({sec.status})"
    # the parent field's description, else the class docstring's first paragraph (a union
    # member's docstring first: it tells the members apart)
    doc = (sec.model.__doc__ or "").strip().split("\n\n")[0]
    text = (doc or sec.about) if sec.variant is not None else (sec.about or doc)
    text = " ".join(text.replace("``", "`").split()).rstrip(".")
    if not text or not sec.header:
        return f"{what}."
    return f"{what}. {text[0].upper()}{text[1:]}."


def section_markdown(sec: Section) -> str:
    """One section's table: its TOML header and status line, then one row per key."""
    lines = [_intro(sec), ""]
    if not sec.keys:
        return lines[0]
    lines.append("| key | type | unit | default | allowed | meaning |")
    lines.append("|---|---|---|---|---|---|")
    for k in sec.keys:
        unit = f"`{fmt_unit(k.unit)}`" if k.unit and k.unit != "-" else "–"
        lines.append("| " + " | ".join(_cell(c) for c in (
            f"`{k.path}`", k.kind, unit, k.default, k.allowed or "any",
            k.meaning.replace("``", "`"))) + " |")
    return "\n".join(lines)


def block_markdown(secs: list[Section], with_headings: bool = False) -> str:
    """The generated text of one block: its sections' tables, one after another."""
    parts = []
    headed = set()
    for s in secs:
        if with_headings and "." not in s.id and s.id not in headed:
            headed.add(s.id)
            parts.append(f"### `{s.header}`" if s.header else "### Top-level keys")
        parts.append(section_markdown(s))
    return "\n\n".join(parts)


def _owner(sid: str, blocks: list[str]) -> str:
    """The block a section goes to: its own, else its nearest ancestor's, else 'rest'."""
    parts = sid.split(".")
    for n in range(len(parts), 0, -1):
        if ".".join(parts[:n]) in blocks:
            return ".".join(parts[:n])
    return "rest"


def render(text: str, root: type[BaseModel] | None = None) -> str:
    """``text`` (a Markdown document) with every ``BEGIN schema``/``END schema`` block
    rewritten from the schema; the prose outside the blocks is kept as it is.

    A block takes its section and every section below it that has no block of its own
    (block ``vehicles`` shows ``[vehicles.davis]`` unless there is a block
    ``vehicles.davis``); block ``rest`` takes the sections no block takes.
    Raises ValueError for a block that names no section, a block without its end, or
    sections left over with no ``rest`` block to take them."""
    secs = sections(root)
    ids = [m.group(1) for m in _BEGIN.finditer(text)]
    known = {s.id for s in secs}
    unknown = [i for i in ids if i not in known and i != "rest"]
    if unknown:
        raise ValueError(f"{', '.join(unknown)}: no such section of the schema; sections: "
                         f"{', '.join(dict.fromkeys(s.id for s in secs))}")
    by_block: dict[str, list[Section]] = {}
    for s in secs:
        by_block.setdefault(_owner(s.id, ids), []).append(s)
    if by_block.get("rest") and "rest" not in ids:
        left = ", ".join(dict.fromkeys(s.id for s in by_block["rest"]))
        raise ValueError(f"sections {left} have no block and the document has no 'rest' block")
    out, pos = [], 0
    for m in _BEGIN.finditer(text):
        sid = m.group(1)
        end = text.find(_END.format(sid), m.end())
        if end < 0:
            raise ValueError(f"block {sid!r} has no '{_END.format(sid)}'")
        out.append(text[pos:m.end()])
        out.append(block_markdown(by_block.get(sid, []), with_headings=sid == "rest") + "\n")
        pos = end
    out.append(text[pos:])
    return "".join(out)


def main(argv: list[str] | None = None) -> int:
    """``python -m ltdsim.scenario.doc [--check] [FILE]``: rewrite the generated tables of
    FILE (default docs/scenario.md), or with --check only say whether they are current."""
    p = argparse.ArgumentParser(prog="python -m ltdsim.scenario.doc",
                                description="Rewrite the key tables of docs/scenario.md "
                                            "from the scenario schema.")
    p.add_argument("file", nargs="?", type=Path, default=DOC)
    p.add_argument("--check", action="store_true",
                   help="write nothing; exit 1 if the file is not current")
    args = p.parse_args(argv)
    try:
        text = args.file.read_text(encoding="utf-8")
    except OSError as exc:
        print(f"error: {args.file}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    try:
        new = render(text)
    except ValueError as exc:
        print(f"error: {args.file}: {exc}", file=sys.stderr)
        return 2
    missing = missing_units()
    if missing:
        print(f"warning: no unit in the description of {', '.join(missing)}", file=sys.stderr)
    if new == text:
        print(f"{args.file}: current")
        return 0
    if args.check:
        print(f"{args.file}: out of date (run python -m ltdsim.scenario.doc)")
        return 1
    tmp = args.file.with_name(args.file.name + ".tmp")
    tmp.write_text(new, encoding="utf-8")
    tmp.replace(args.file)  # whole or not at all
    print(f"{args.file}: rewritten")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
