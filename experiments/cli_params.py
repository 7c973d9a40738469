"""``slamarena params METHOD``: a method's parameters as its config takes them, with defaults, units and descriptions.

One row per parameter, named by its dotted path (``loop.level``: the key ``level`` of the section ``loop`` in a
config's ``params:``, and the form ``slamarena map --param`` takes); a sub-model is a row of its own (its description)
followed by its parameters; a dict-valued parameter is expanded key by key, with the descriptions of the model that
validates it where its field names one (``json_schema_extra={"model": attribute}``: a matcher's ``matcher_params``). The
default is the method's own (the RBPF's ``pyramid.cells.hit_guard`` is 1 where the cell model's is 0), in the
canonical JSON form an experiment's cache key hashes. The unit is the bracketed part of the description (``[m]``).
"""

from __future__ import annotations

import difflib
import json
import re

from slamarena.params import Params, params_model

__all__ = ["parameter_rows", "params_command"]

_UNIT = re.compile(r"\s*\[([^\]]+)\]")


def _unit(description: str) -> tuple[str, str]:
    """(unit, description without it): the first bracketed part of a field's description."""
    found = _UNIT.search(description)
    if found is None:
        return "", description
    return found.group(1), (description[: found.start()] + description[found.end() :]).strip()


def parameter_rows(params: Params, prefix: str = "") -> list[tuple[str, str, str, str]]:
    """(path, default, unit, description) of every parameter of ``params`` (an instance: its values are the
    defaults shown), sub-models and dicts expanded after a row of their own; an optional sub-model that is off (None)
    shows ``null`` and then the defaults its fields take when it is set."""
    from slamarena.params import submodel

    rows = []
    canonical = params.canonical()
    for name, field in type(params).model_fields.items():
        path, value = prefix + name, getattr(params, name)
        unit, text = _unit(field.description or "")
        off = submodel(field.annotation) if value is None else None
        if isinstance(value, Params):
            rows.append((path, "", "", text))
            rows += parameter_rows(value, f"{path}.")
        elif off is not None:
            rows.append((path, "null", "", text))
            rows += parameter_rows(off(), f"{path}.")
        elif isinstance(value, dict) and value:
            rows.append((path, "", "", text))
            model = getattr(params, (field.json_schema_extra or {}).get("model", ""), None)
            if isinstance(model, Params):
                rows += parameter_rows(model, f"{path}.")
            else:
                rows += [(f"{path}.{key}", json.dumps(v), "", "") for key, v in canonical[name].items()]
        else:
            rows.append((path, json.dumps(canonical[name]), unit, text))
    return rows


def params_command(method: str) -> str:
    """The text ``slamarena params METHOD`` prints; an unknown method names the closest registered ones."""
    from slamarena.errors import UnknownNameError
    from slamarena.experiments.config import method_table
    from slamarena.targets import import_target

    table = method_table()
    if method not in table:
        close = difflib.get_close_matches(method, list(table), n=3)
        hint = f"did you mean {' or '.join(close)}? " if close else ""
        raise UnknownNameError(f"unknown method {method!r}; {hint}registered: {', '.join(sorted(table))}")
    model = params_model(import_target(table[method]))
    rows = [("PARAMETER", "DEFAULT", "UNIT", "DESCRIPTION"), *parameter_rows(model())]
    widths = [max(len(row[i]) for row in rows) for i in range(3)]
    lines = [f"{method} ({table[method]}, {model.__name__}): a config's params: take these keys, nested by the dots"]
    lines += ["  ".join(cell.ljust(w) for cell, w in zip(row[:3], widths)) + "  " + row[3] for row in rows]
    return "\n".join(line.rstrip() for line in lines)
