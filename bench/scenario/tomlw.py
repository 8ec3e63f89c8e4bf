"""A small TOML writer for scenario files (tomllib only reads): tables, arrays of tables, strings,
booleans, numbers and arrays of those. Enough to write a scenario derived from a bundled one
(``derive_scenario_text``); comments are not kept."""
from __future__ import annotations

import copy
import math
import re
from typing import Any

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k: str) -> str:
    return k if _BARE.match(k) else '"' + k.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"TOML has no {v!r} in a scenario")
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def _is_table_array(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def dumps(doc: dict[str, Any]) -> str:
    lines: list[str] = []

    def table(d: dict[str, Any], path: list[str]) -> None:
        scalars = [(k, v) for k, v in d.items() if not isinstance(v, dict) and not _is_table_array(v)]
        for k, v in scalars:
            lines.append(f"{_key(k)} = {_value(v)}")
        for k, v in d.items():
            if isinstance(v, dict):
                lines.append("")
                lines.append("[" + ".".join(_key(p) for p in path + [k]) + "]")
                table(v, path + [k])
            elif _is_table_array(v):
                for item in v:
                    lines.append("")
                    lines.append("[[" + ".".join(_key(p) for p in path + [k]) + "]]")
                    table(item, path + [k])

    table(doc, [])
    return "\n".join(lines).lstrip("\n") + "\n"


_INDEXED = re.compile(r"(.+)\[(\d+)\]\Z")


def set_dotted(doc: dict[str, Any], dotted: str, value: Any) -> dict[str, Any]:
    """A copy of ``doc`` with ``a.b.c`` set to ``value`` (tables created as needed); a part may
    index an existing array of tables: ``events[1].load_torque_nm``."""
    out = copy.deepcopy(doc)
    node = out
    parts = dotted.split(".")
    for p in parts[:-1]:
        m = _INDEXED.match(p)
        if m:
            items = node.get(m.group(1)) if isinstance(node, dict) else None
            i = int(m.group(2))
            if not isinstance(items, list) or i >= len(items):
                raise ValueError(f"{dotted}: no {m.group(1)}[{i}] in the scenario "
                                 f"({len(items) if isinstance(items, list) else 0} there)")
            node = items[i]
        else:
            node = node.setdefault(p, {})
        if not isinstance(node, dict):
            raise ValueError(f"{dotted}: {p} is not a table")
    node[parts[-1]] = value
    return out
