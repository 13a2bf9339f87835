"""Typed parameter registry: the MAVLink PARAM table.

One :class:`Param` entry per parameter (name of at most 16 characters, type, default,
min, max, unit, description, and whether a change takes effect only at the next start).
Each block declares its parameters next to its code as a tuple of ``Param`` and the
vehicle collects them into one :class:`ParamStore`. The store is what PARAM_REQUEST_LIST
streams, what ``.parm`` files (``NAME VALUE`` lines, as ArduPilot and MAVProxy write
them) save and load, and what the README's table is generated from. Controllers take
design inputs (natural frequency, damping, L1 period) from here and derive their gains.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable


class ParamError(ValueError):
    """A parameter name, type or value was refused."""


@dataclass(frozen=True, slots=True)
class Param:
    name: str
    default: float
    min: float
    max: float
    unit: str = ""
    description: str = ""
    is_int: bool = False
    # a change takes effect at the next start only (ArduPilot's @RebootRequired, PX4's
    # @reboot_required): something sized or built from it when the vehicle starts. Every
    # other parameter takes effect at once after a PARAM_SET, read where it is used or
    # re-read by the vehicle's ``_param_changed``. The value is stored either way, and a
    # ground station is told (VehicleBase.set_param)
    at_start: bool = False

    def __post_init__(self):
        if not 0 < len(self.name) <= 16:
            raise ValueError(f"parameter name {self.name!r} must be 1..16 characters")
        if not (self.min <= self.default <= self.max):
            raise ValueError(f"{self.name}: default {self.default} outside [{self.min}, {self.max}]")


class ParamStore(dict):
    """The values of a set of parameters, checked against their declarations.

    A ``dict`` of name -> value underneath, so that ``params["NAME"]`` (a few dozen
    reads per loop step) is the dictionary's own C lookup rather than a Python method;
    every write goes through :meth:`set`'s checks (``params["NAME"] = v`` included) and
    the other ``dict`` mutators are refused. Equality and hashing stay by identity."""

    __slots__ = ("_decl", "_names")
    __hash__ = object.__hash__
    __eq__ = object.__eq__
    __ne__ = object.__ne__

    def __init__(self, declarations: Iterable[Param]):
        decl: dict[str, Param] = {}
        for p in declarations:
            if p.name in decl:
                raise ValueError(f"parameter {p.name} declared twice")
            decl[p.name] = p
        super().__init__((p.name, float(p.default)) for p in decl.values())
        self._decl = decl
        self._names = list(decl)  # index order for PARAM_VALUE param_index

    def __reduce__(self):
        return _restore_store, (list(self._decl.values()), list(dict.items(self)))

    # --- reading -----------------------------------------------------------------
    # __getitem__, __contains__, __len__: the dict's (its keys are the declared names)

    def names(self) -> list[str]:
        return list(self._names)

    def index(self, name: str) -> int:
        return self._names.index(name)

    def declaration(self, name: str) -> Param:
        return self._decl[name]

    def declarations(self) -> list[Param]:
        return [self._decl[n] for n in self._names]

    def items(self) -> list[tuple[str, float]]:
        return [(n, self[n]) for n in self._names]

    def __setitem__(self, name: str, value: float) -> None:
        self.set(name, value)

    def _refuse(self, *_a, **_k):
        raise TypeError("ParamStore: values change through set() or load() only")

    __delitem__ = update = pop = popitem = clear = setdefault = __ior__ = _refuse

    # --- writing -----------------------------------------------------------------
    def set(self, name: str, value: float) -> float:
        """Set a value; raises ParamError (value unchanged) if refused."""
        decl = self._decl.get(name)
        if decl is None:
            raise ParamError(f"unknown parameter {name}")
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ParamError(f"{name}: not a number: {value!r}") from None
        if not math.isfinite(v):
            raise ParamError(f"{name}: not finite")
        if decl.is_int and v != int(v):
            raise ParamError(f"{name}: must be an integer")
        if not decl.min <= v <= decl.max:
            raise ParamError(f"{name}: {v:g} outside [{decl.min:g}, {decl.max:g}]")
        dict.__setitem__(self, name, v)
        return v

    # --- .parm files -------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        """Write ``NAME VALUE`` lines atomically (temp file + rename)."""
        path = Path(path)
        tmp = path.with_suffix(path.suffix + ".tmp")
        with open(tmp, "w", encoding="ascii") as f:
            for name, value in self.items():
                f.write(f"{name:<16} {_fmt(value)}\n")
        tmp.replace(path)

    def load(self, path: str | Path) -> list[str]:
        """Apply a ``.parm`` file. All lines are checked before any value changes;
        a bad line raises ParamError naming it. Returns the names that were set."""
        path = Path(path)
        updates: list[tuple[str, float]] = []
        with open(path, encoding="utf-8") as f:
            for lineno, raw in enumerate(f, 1):
                line = raw.split("#", 1)[0].strip()
                if not line:
                    continue
                parts = line.replace(",", " ").split()
                if len(parts) != 2:
                    raise ParamError(f"{path}:{lineno}: expected 'NAME VALUE'")
                name, value = parts
                decl = self._decl.get(name)
                if decl is None:
                    raise ParamError(f"{path}:{lineno}: unknown parameter {name}")
                try:
                    v = float(value)
                except ValueError:
                    raise ParamError(f"{path}:{lineno}: {name}: not a number: {value}") from None
                if not (decl.min <= v <= decl.max) or (decl.is_int and v != int(v)):
                    raise ParamError(f"{path}:{lineno}: {name}: {value} outside [{decl.min:g}, {decl.max:g}]")
                updates.append((name, v))
        for name, v in updates:
            dict.__setitem__(self, name, v)
        return [n for n, _ in updates]


def _restore_store(declarations: list[Param], values: list[tuple[str, float]]) -> ParamStore:
    """Unpickling (ParamStore.__reduce__): the declarations, then the values."""
    store = ParamStore(declarations)
    for name, v in values:
        dict.__setitem__(store, name, v)
    return store


def _fmt(value: float) -> str:
    return str(int(value)) if value == int(value) and abs(value) < 1e15 else repr(value)
