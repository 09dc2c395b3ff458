"""The one-line messages a bad input gets: pydantic's errors in TOML's words, with the keys
a table allows and, for a key of another coupler model, which model it belongs to.
"""

from __future__ import annotations

import types
import typing
from typing import Annotated, Any, Union

from pydantic import (
    BaseModel,
    ValidationError,
)

from ltdsim.errors import _printable

from ltdsim.scenario.couplers import COUPLER_CLASSES, _TAGS


# ------------------------------------------------------------------ error text
#: what a value of the wrong TOML type is told (strict types, see ``_Strict``)
_TYPE_MESSAGES = {
    "float_type": "must be a number (a TOML integer or float: not in quotes, not true/false)",
    "int_type": "must be a whole number (a TOML integer such as 4: no decimal point, not in "
                "quotes, not true/false)",
    "bool_type": "must be true or false (a TOML boolean: not in quotes, not 0/1)",
    "string_type": "must be a string (in quotes)",
    "list_type": "must be an array [...]",
    "tuple_type": "must be an array [...]",
    "model_type": "must be a table",
    "dict_type": "must be a table",
}


def _problems(exc: ValidationError, root=None) -> list[tuple[str, str]]:
    """The problems of a pydantic ``ValidationError`` as ``(dotted key, one-line message)``
    pairs: TOML's words for a wrong type, the keys a table allows for an unknown one
    (from the model ``root`` the locations start at), the refused value as TOML writes
    it."""
    out: list[tuple[str, str]] = []
    for err in exc.errors():
        loc = [str(p) for p in err["loc"] if not _is_internal(p)]
        if err["type"] == "extra_forbidden":  # the last part is the file's key, as it is
            loc = [str(p) for p in err["loc"][:-1] if not _is_internal(p)] + [
                str(err["loc"][-1])]
        key = ".".join(loc)
        msg = err["msg"]
        if err["type"] in _TYPE_MESSAGES:
            msg = _TYPE_MESSAGES[err["type"]]
        if err["type"] == "extra_forbidden":
            allowed = _allowed_keys(err["loc"][:-1], root)
            msg = f"unknown key '{loc[-1]}'" + _other_model(err["loc"]) + (
                f"; allowed: {', '.join(allowed)}" if allowed else "")
        elif err["type"] == "missing":
            msg = "required key is missing"
        elif msg.startswith("Value error, "):
            msg = msg[len("Value error, "):]
            # a validator whose message names its own key below this table ("brake:
            # brake.fluid.valve: ..."): the key once, the message's
            head = msg.split(": ", 1)
            if key and len(head) == 2 and head[0].startswith(key + ".") and \
                    " " not in head[0]:
                key, msg = head
        if err["type"] in ("finite_number",):
            msg = "must be a finite number (NaN and inf are not allowed)"
        key, msg = _in_rows(err, loc, key, msg)
        if "input" in err and err["type"] not in ("missing", "extra_forbidden") and not isinstance(
                err["input"], (dict, list)):
            msg += f" (got {_toml(err['input'])})"
        same = [i for i, (k, _) in enumerate(out) if k == key]
        if same:  # the members of a union (e.g. 'karwatzki' or a number): one line
            i = same[0]
            out[i] = (key, f"{out[i][1]}; or {msg}")
        else:
            out.append((key, msg))
    return out


def _in_rows(err, loc: list[str], key: str, msg: str) -> tuple[str, str]:
    """A problem inside a table of rows of numbers (``track.gradient = [[x, y], ...]``):
    the table's key, and the row and number counted from 1 as a reader counts them
    ("row 2 has 3 numbers, at most 2 allowed")."""
    parts = err["loc"]
    if err["type"] == "too_long" and len(parts) >= 1 and isinstance(parts[-1], int) \
            and "max_length" in err.get("ctx", {}) and isinstance(err.get("input"), tuple):
        row = parts[-1]
        table = ".".join(loc[:-1])
        return table, (f"row {row + 1} has {len(err['input'])} numbers, at most "
                       f"{err['ctx']['max_length']} allowed")
    if len(parts) >= 2 and isinstance(parts[-1], int) and isinstance(parts[-2], int):
        row, col = parts[-2], parts[-1]
        table = ".".join(loc[:-2])
        if err["type"] == "missing":
            return table, (f"row {row + 1} has {col} number{'s' if col != 1 else ''}, "
                           f"needs {col + 1}")
        return table, f"row {row + 1}, number {col + 1}: {msg}"
    return key, msg


def first_problem(exc: ValidationError, prefix: str = "", model=None) -> str:
    """The first problem of ``exc`` as one line, ``prefix`` + the dotted key + its
    message in TOML's words (a wrong type, an unknown key with the keys ``model``
    allows, a missing key, a range); a problem of the whole table (a relation between
    its keys) is its message alone."""
    err = exc.errors()[0]
    key = prefix + ".".join(str(p) for p in err["loc"])
    msg = err["msg"].removeprefix("Value error, ")
    if err["type"] in _TYPE_MESSAGES:
        msg = f"{_TYPE_MESSAGES[err['type']]} (got {_toml(err['input'])})"
    elif err["type"] == "extra_forbidden":
        msg = "unknown key" + (f"; allowed: {', '.join(model.model_fields)}" if model else "")
    elif err["type"] == "missing":
        msg = "required key is missing"
    elif err["type"] == "finite_number":
        msg = "must be a finite number (NaN and inf are not allowed)"
    elif err["type"] in ("literal_error", "greater_than", "greater_than_equal", "less_than",
                         "less_than_equal"):
        msg = f"{msg} (got {_toml(err['input'])})"
    if not err["loc"]:
        return f"{prefix.rstrip('.') + ': ' if prefix else ''}{msg}"
    return f"{key}: {msg}"


def _other_model(loc) -> str:
    """For a coupler key refused because it belongs to another model: which models it
    belongs to (empty otherwise)."""
    tags = [p for p in loc if p in _TAGS]
    if not tags:
        return ""
    key = loc[-1]
    owners = [name for name, cls in COUPLER_CLASSES.items() if key in cls.model_fields]
    if not owners:
        return ""
    model = tags[-1].strip("[]")
    return (f" for model '{model}' (a key of model {' and '.join(repr(o) for o in owners)}; "
            "set model, or drop the key)")


def _toml(value) -> str:
    """A value as it reads in a TOML file (true, "text", 1.5)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, str):
        return '"' + _printable(value.replace("\\", "\\\\").replace('"', '\\"')) + '"'
    return repr(value)


def _is_internal(part) -> bool:
    # pydantic adds the names of union members / tagged types to locations
    return isinstance(part, str) and ("[" in part or part.startswith("function-"))


def _model_of(annotation):
    """The BaseModel class inside an annotation (through Optional, list, dict)."""
    origin = typing.get_origin(annotation)
    if origin is Annotated:
        return _model_of(typing.get_args(annotation)[0])
    if origin in (Union, types.UnionType, list, dict):
        for arg in typing.get_args(annotation):
            m = _model_of(arg)
            if m is not None:
                return m
        return None
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    return None


def _allowed_keys(loc, root=None) -> list[str]:
    """The keys the table at ``loc`` allows, walking the models from ``root`` (a coupler
    model's tag in ``loc`` switches to that model)."""
    cls: Any = root
    for part in loc:
        if part in _TAGS:  # the member of the coupler union that was validated
            cls = _TAGS[part]
            continue
        if isinstance(part, int) or _is_internal(part):
            continue
        if cls is None or part not in cls.model_fields:
            return []
        cls = _model_of(cls.model_fields[part].annotation)
    if cls is None:
        return []
    return [k for k in cls.model_fields if k != "case"]
