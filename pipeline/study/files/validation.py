"""Validation of parsed study documents: every failure is one line naming the file
and the field, `UsageError("<file>: <field>: <what>")`, where <field> is a dotted
path with 0-based list indices (`scene.contact[0].mu`).  The one `Checker` every
study kind's parser uses."""
from __future__ import annotations

import difflib
import json
import math
import re

import numpy as np

from ...errors import UsageError
from .study_types import NAME_PATTERN


class Checker:
    """Validation of one study file's parsed TOML: each method returns the checked
    value or raises `UsageError("<file>: <field>: <what>")` (`fail`), with "did you
    mean" for unknown keys.  Shared by every study parser (lumped, disk, blade,
    accuracy/cost)."""

    def __init__(self, file: str):
        self.file = file

    def fail(self, field: str, what: str):
        raise UsageError(f"{self.file}: {printable(field)}: {printable(what)}")

    def table(self, value, field, required=True):
        if value is None:
            if required:
                self.fail(field, "missing table (required)")
            return {}
        if not isinstance(value, dict):
            self.fail(field, f"must be a table, got {kind_of(value)}")
        return value

    def keys(self, table: dict, field: str, allowed, required=()):
        for k in table:
            if k not in allowed:
                near = difflib.get_close_matches(str(k), list(allowed), n=1)
                hint = f"; did you mean {near[0]!r}?" if near else ""
                self.fail(join_field(field, k), f"unknown key (allowed: {', '.join(allowed)}){hint}")
        for k in required:
            if k not in table:
                self.fail(join_field(field, k), "missing (required)")

    def number(self, value, field, *, gt=None, ge=None, lt=None, le=None):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(field, f"must be a number, got {kind_of(value)}")
        try:
            x = float(value)
        except OverflowError:
            self.fail(field, f"number too large: {value}")
        if not math.isfinite(x):
            self.fail(field, f"must be finite, got {x}")
        if gt is not None and not x > gt:
            self.fail(field, f"must be > {gt:g}, got {x:g}")
        if ge is not None and not x >= ge:
            self.fail(field, f"must be >= {ge:g}, got {x:g}")
        if lt is not None and not x < lt:
            self.fail(field, f"must be < {lt:g}, got {x:g}")
        if le is not None and not x <= le:
            self.fail(field, f"must be <= {le:g}, got {x:g}")
        return x

    def phase(self, value, field):
        """A phase angle [rad]: |phase| <= 2 pi; a larger one is refused as degrees
        typed for radians (90 would otherwise load the structure at 90 rad = 2.04 rad
        modulo 2 pi, without a word)."""
        x = self.number(value, field)
        if abs(x) > 2 * math.pi:
            self.fail(field, f"a phase in radians lies within +-2 pi (6.283), got {x:g}; "
                             f"{x:g} degrees is {math.radians(x):.6g} rad")
        return x

    def integer(self, value, field, lo, hi):
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(field, f"must be an integer, got {kind_of(value)}")
        if not lo <= value <= hi:
            self.fail(field, f"must be in [{lo}, {hi}], got {value}")
        return int(value)

    def string(self, value, field, choices=None, pattern=None):
        if not isinstance(value, str):
            self.fail(field, f"must be a string, got {kind_of(value)}")
        if choices is not None and value not in choices:
            self.fail(field, f"must be one of {', '.join(map(repr, choices))}, got {value!r}")
        if pattern is not None and not pattern.match(value):
            self.fail(field, f"{value!r} is not a valid name (letters, digits, '_', '.'; "
                             "starting with a letter or '_'; at most 64 characters)")
        return value

    def boolean(self, value, field):
        if not isinstance(value, bool):
            self.fail(field, f"must be true or false, got {kind_of(value)}")
        return value

    def switch(self, value, field, choices, on):
        """true (-> `on`), false, or one of the strings `choices`."""
        if isinstance(value, bool):
            return on if value else False
        if isinstance(value, str) and value in choices:
            return value
        near = difflib.get_close_matches(value, list(choices), n=1) if isinstance(value, str) \
            else []
        self.fail(field, f"must be true, false or one of {', '.join(map(repr, choices))}, got "
                         f"{value!r}" + (f"; did you mean {near[0]!r}?" if near else ""))

    def array(self, value, field, length=None, min_length=1):
        if not isinstance(value, list):
            self.fail(field, f"must be a list, got {kind_of(value)}")
        if length is not None and len(value) != length:
            self.fail(field, f"must have {length} {'entry' if length == 1 else 'entries'}, "
                             f"got {len(value)}")
        if len(value) < min_length:
            self.fail(field, "must not be empty" if min_length == 1
                      else f"must have at least {min_length} entries")
        return value

    def numbers(self, value, field, length=None, **bounds):
        vals = self.array(value, field, length)
        return np.array([self.number(v, f"{field}[{i}]", **bounds) for i, v in enumerate(vals)])

    def matrix(self, value, field, n):
        rows = self.array(value, field, n)
        return np.array([self.numbers(r, f"{field}[{i}]", n) for i, r in enumerate(rows)])

    def names(self, value, field, min_length=1):
        vals = self.array(value, field, min_length=min_length)
        out = [self.string(v, f"{field}[{i}]", pattern=NAME_PATTERN) for i, v in enumerate(vals)]
        for i, v in enumerate(out):
            if v in out[:i]:
                self.fail(f"{field}[{i}]", f"duplicate {v!r}")
        return tuple(out)


def printable(text: str) -> str:
    """Escape control and other non-printable characters: the message is one line."""
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii")
                   for c in str(text))


def kind_of(value) -> str:
    if isinstance(value, bool):
        return "a boolean"
    return {dict: "a table", list: "a list", str: "a string", int: "an integer",
            float: "a float"}.get(type(value), type(value).__name__)


def join_field(field, key):
    """Dotted path; keys that are not plain words are quoted (JSON escapes keep
    control characters out of the one-line message)."""
    key = str(key)
    if not re.fullmatch(r"[A-Za-z0-9_\-]+", key):
        key = json.dumps(key)
    return f"{field}.{key}" if field else key
