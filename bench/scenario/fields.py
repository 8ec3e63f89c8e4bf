"""Typed, located access to the tables of a TOML file: every problem becomes a
:class:`ScenarioError` naming the file, the line (where TOML gives one) and the dotted field.

Shared by everything that reads a scenario-like file (scenarios, their ``[[faults]]``, campaigns).
"""
from __future__ import annotations

import math
import re
from typing import Any

from hil_bench.errors import BenchError, did_you_mean


class ScenarioError(BenchError, ValueError):
    """A scenario file is missing, malformed or asks for something impossible."""


_HEADER = re.compile(r"\s*(\[\[?)\s*([^\]]+?)\s*\]\]?")
_KEY = re.compile(r"\s*(?:\"([^\"]+)\"|'([^']+)'|([A-Za-z0-9_-]+))\s*=")


def line_of(text: str, table: str, key: str | None = None) -> int | None:
    """1-based line of ``key`` in the TOML table ``table`` ("scenario", "controller.params", "events[2]";
    "" = top level), or of the table's header if ``key`` is None; None if not found. A key inside an
    inline table (``allow = {crc_errors = 5}``) is found as its enclosing key's line."""
    current = ""
    counts: dict[str, int] = {}
    header_line: int | None = 1 if table == "" else None
    for n, line in enumerate(text.splitlines(), 1):
        stripped = line.split("#", 1)[0]
        h = _HEADER.match(stripped)
        if h:
            name = h.group(2).strip()
            if h.group(1) == "[[":
                counts[name] = counts.get(name, -1) + 1
                name = f"{name}[{counts[name]}]"
            current = name
            if current == table:
                header_line = n
            continue
        if current == table and key is not None:
            k = _KEY.match(stripped)
            if k and (k.group(1) or k.group(2) or k.group(3)) == key:
                return n
    if key is None:
        return header_line
    sub = line_of(text, f"{table}.{key}" if table else key) if not key.endswith("]") else None
    if sub is not None and (table or key) and _has_header(text, f"{table}.{key}" if table else key):
        return sub   # the key is a table of its own: its header
    if "." in table:   # an inline table: the line of its key in the parent table
        parent, _, inner = table.rpartition(".")
        return line_of(text, parent, inner)
    return None


def _has_header(text: str, table: str) -> bool:
    return any((h := _HEADER.match(line.split("#", 1)[0])) and h.group(2).strip() == table
               for line in text.splitlines())


class Fields:
    """Typed access to one TOML table that remembers the dotted path and rejects unknown keys."""

    def __init__(self, where: str, table: Any, prefix: str, text: str = ""):
        self.where = where
        self.prefix = prefix
        self.text = text
        if not isinstance(table, dict):
            raise ScenarioError(f"{self._at(None)}: {prefix}: must be a table, got {type(table).__name__}")
        self.table = table
        self.used: set[str] = set()

    def _name(self, key: str) -> str:
        return f"{self.prefix}.{key}" if self.prefix else key

    def _at(self, key: str | None) -> str:
        """``file:line`` of a key of this table (``file`` alone if TOML does not say)."""
        if key is None:
            parent, _, last = self.prefix.rpartition(".")
            line = line_of(self.text, self.prefix) or line_of(self.text, parent, last) if self.text else None
        else:
            line = line_of(self.text, self.prefix, key) if self.text else None
        return f"{self.where}:{line}" if line else self.where

    def fail(self, key: str, why: str) -> ScenarioError:
        return ScenarioError(f"{self._at(key)}: {self._name(key)}: {why}")

    def number(self, key: str, default: float | None = None, *, min_value: float | None = None,
               positive: bool = False) -> float:
        self.used.add(key)
        if key not in self.table:
            if default is None:
                raise self.fail(key, "missing (required)")
            return default
        v = self.table[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.fail(key, f"must be a number, got {v!r}")
        v = float(v)
        if not math.isfinite(v):
            raise self.fail(key, f"must be finite, got {v!r}")
        if positive and not v > 0:
            raise self.fail(key, f"must be > 0, got {v!r}")
        if min_value is not None and v < min_value:
            raise self.fail(key, f"must be >= {min_value:g}, got {v!r}")
        return v

    def integer(self, key: str, default: int, lo: int, hi: int) -> int:
        self.used.add(key)
        if key not in self.table:
            return default
        v = self.table[key]
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.fail(key, f"must be a whole number in [{lo}, {hi}], got {v!r}")
        if not lo <= v <= hi:
            raise self.fail(key, f"must be in [{lo}, {hi}], got {v!r}")
        return v

    def within(self, key: str, v: float, lo: float, hi: float, unit: str, why: str) -> float:
        """Check a number already read against [lo, hi] (``why``: where the range comes from)."""
        if not lo <= v <= hi:
            raise self.fail(key, f"{v:g} {unit} is outside [{lo:g}, {hi:g}] {unit} ({why})")
        return v

    def string(self, key: str, default: str | None = None) -> str:
        self.used.add(key)
        if key not in self.table:
            if default is None:
                raise self.fail(key, "missing (required)")
            return default
        v = self.table[key]
        if not isinstance(v, str):
            raise self.fail(key, f"must be a string, got {v!r}")
        return v

    def boolean(self, key: str, default: bool) -> bool:
        self.used.add(key)
        v = self.table.get(key, default)
        if not isinstance(v, bool):
            raise self.fail(key, f"must be true or false, got {v!r}")
        return v

    def strings(self, key: str) -> tuple[str, ...]:
        self.used.add(key)
        v = self.table.get(key, [])
        if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
            raise self.fail(key, f"must be a list of strings, got {v!r}")
        return tuple(v)

    def table_of(self, key: str) -> "Fields":
        self.used.add(key)
        return Fields(self.where, self.table.get(key, {}), self._name(key), self.text)

    def reject_unknown(self, allowed_extra: set[str] = frozenset()) -> None:
        unknown = set(self.table) - self.used - set(allowed_extra)
        if unknown:
            key = sorted(unknown)[0]
            known = sorted(self.used | set(allowed_extra))
            hint = did_you_mean(key, known)
            raise self.fail(key, f"unknown key{hint or ' (typo?)'}"
                                 + (f" (known here: {', '.join(known)})" if known else ""))
