"""Scenario files: wind and timed fault events, in TOML.

    [wind]
    speed_mps = 5.0
    from_deg = 270.0      # direction the wind blows FROM, degrees true
    turbulence = "light"  # none | light | moderate | severe

    [[event]]
    at_s = 120.0
    unit = "gps"          # FAILURE_UNIT name, lower case without prefix
    type = "off"          # ok, off, stuck, garbage, wrong, slow, delayed, intermittent
    instance = 0
    # magnitudes of the fault as further keys: see sim_bridge.faults.catalogue
    # (a sensor's body axis as axis = "x", "y", "z" or 0, 1, 2)

Everything is checked when the file is loaded, against the fault injector's own
catalogue: an unknown key, unit or type, a magnitude the fault does not take, a value
of the wrong type or out of range is a ``ScenarioError`` whose message starts with
``FILE:LINE:``. tomllib reports no line numbers for valid TOML, so the line of a key is
found by scanning the raw text (table headers and ``key =`` lines); TOML syntax errors
keep tomllib's own message, which has the line and column.
"""
from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .faults.catalogue import (
    ALL_MAGNITUDES, SUPPORTED, TYPES, UNITS, FaultSpecError, axis_index, check_magnitudes,
)

TURBULENCE = ("none", "light", "moderate", "severe")
_TOP_KEYS = ("wind", "event")
_WIND_KEYS = ("speed_mps", "from_deg", "turbulence")
_EVENT_KEYS = ("at_s", "unit", "type", "instance")


class ScenarioError(ValueError):
    """A scenario file (or --wind argument) that cannot be used; the message names the
    file and line."""

    def __init__(self, message: str, path: str | None = None, line: int | None = None):
        where = ""
        if path is not None:
            where = f"{path}:{line}: " if line is not None else f"{path}: "
        super().__init__(where + message)
        self.path = path
        self.line = line


@dataclass(frozen=True, slots=True)
class Wind:
    """Steady wind and turbulence intensity of a scenario."""

    speed_mps: float = 0.0        # steady wind speed [m/s]
    from_deg: float = 0.0         # direction the wind blows FROM, true [deg]
    turbulence: str = "none"      # none | light | moderate | severe

    def wind_ned(self) -> np.ndarray:
        """Air velocity over ground, NED [m/s]: from 270 deg (west) -> (0, +speed, 0)."""
        a = math.radians(self.from_deg)
        return np.array([-self.speed_mps * math.cos(a), -self.speed_mps * math.sin(a), 0.0])


@dataclass(frozen=True, slots=True)
class Event:
    """A fault event: at ``at_s`` inject (unit, type, instance) with ``magnitudes``."""

    at_s: float                   # simulation time of the event [s]
    unit: str                     # FAILURE_UNIT name, e.g. "gps"
    type: str                     # FAILURE_TYPE name, e.g. "off"
    instance: int = 0
    magnitudes: dict = field(default_factory=dict)  # as written in the file

    @property
    def unit_id(self) -> int:
        """MAVLink FAILURE_UNIT number."""
        return UNITS[self.unit]

    @property
    def type_id(self) -> int:
        """MAVLink FAILURE_TYPE number."""
        return TYPES[self.type]


@dataclass(frozen=True, slots=True)
class Scenario:
    wind: Wind = field(default_factory=Wind)
    events: tuple[Event, ...] = ()   # sorted by at_s (file order among equal times)
    path: str | None = None


# --- locating keys in the raw text ---------------------------------------------------

_HEADER_RE = re.compile(r'^\s*(\[\[?)\s*([^\]]+?)\s*\]\]?')
_KEY_RE = re.compile(r'^\s*("[^"]*"|\'[^\']*\'|[A-Za-z0-9_\-]+)\s*[.=]')


class _Lines:
    """Line numbers of table headers and keys, by (table, index) and key."""

    def __init__(self, text: str):
        self.headers: dict[tuple, int] = {}
        self.keys: dict[tuple, int] = {}
        table: tuple = ()
        counts: dict[str, int] = {}
        for lineno, line in enumerate(text.splitlines(), start=1):
            stripped = line.strip()
            if not stripped or stripped.startswith("#"):
                continue
            m = _HEADER_RE.match(line)
            if m:
                name = m.group(2).strip().strip('"\'')
                if m.group(1) == "[[":
                    idx = counts.get(name, 0)
                    counts[name] = idx + 1
                    table = (name, idx)
                else:
                    table = (name,)
                self.headers.setdefault(table, lineno)
                continue
            m = _KEY_RE.match(line)
            if m:
                key = m.group(1).strip('"\'')
                self.keys.setdefault((table, key), lineno)

    def of(self, table: tuple, key: str | None = None) -> int | None:
        if key is not None and (table, key) in self.keys:
            return self.keys[(table, key)]
        if table in self.headers:
            return self.headers[table]
        if len(table) == 1 and (table[0], 0) in self.headers:   # [[name]] arrays
            return self.headers[(table[0], 0)]
        if table == () and key is not None:
            return self.headers.get((key,)) or self.headers.get((key, 0))
        return None


# --- loading -------------------------------------------------------------------------

def load_scenario(path: str | Path) -> Scenario:
    """Read and check a scenario file (see the module doc). Raises ScenarioError."""
    path_s = str(path)
    try:
        with open(path, "rb") as f:
            raw = f.read()
    except OSError as e:
        raise ScenarioError(f"cannot read: {e.strerror}", path_s) from e
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ScenarioError(f"not UTF-8 text: {e}", path_s) from e
    return parse_scenario_text(text, path_s)


def parse_scenario_text(text: str, path: str = "<string>") -> Scenario:
    """Like load_scenario, from a string (tests, the CLI)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        m = re.search(r"line (\d+)", str(e))
        raise ScenarioError(f"TOML syntax error: {e}", path, int(m.group(1)) if m else None) from e
    return _build(data, _Lines(text), path)


def _build(data: dict, lines: _Lines, path: str) -> Scenario:
    def fail(msg: str, table: tuple, key: str | None = None):
        raise ScenarioError(msg, path, lines.of(table, key))

    for key in data:
        if key not in _TOP_KEYS:
            fail(f"unknown top-level key {key!r} (expected: {', '.join(_TOP_KEYS)})", (), key)

    wind = Wind()
    if "wind" in data:
        w = data["wind"]
        if not isinstance(w, dict):
            fail("'wind' must be a table: [wind]", (), "wind")
        for key in w:
            if key not in _WIND_KEYS:
                fail(f"unknown key {key!r} in [wind] (expected: {', '.join(_WIND_KEYS)})",
                     ("wind",), key)
        speed = _number(w.get("speed_mps", 0.0), "speed_mps", ("wind",), fail)
        if speed < 0.0:
            fail(f"speed_mps must be >= 0, not {speed}", ("wind",), "speed_mps")
        from_deg = _number(w.get("from_deg", 0.0), "from_deg", ("wind",), fail)
        if not 0.0 <= from_deg <= 360.0:
            fail(f"from_deg must be in [0, 360], not {from_deg}", ("wind",), "from_deg")
        turb = w.get("turbulence", "none")
        if turb not in TURBULENCE:
            fail(f"turbulence must be one of {', '.join(TURBULENCE)}, not {turb!r}",
                 ("wind",), "turbulence")
        wind = Wind(speed, from_deg, turb)

    events = []
    raw_events = data.get("event", [])
    if not isinstance(raw_events, list):
        fail("'event' must be an array of tables: [[event]]", (), "event")
    for i, ev in enumerate(raw_events):
        table = ("event", i)
        if not isinstance(ev, dict):
            fail("each event must be a table: [[event]]", (), "event")
        for key in ev:
            if key not in _EVENT_KEYS and key not in ALL_MAGNITUDES:
                fail(f"unknown key {key!r} in [[event]] (expected: "
                     f"{', '.join(_EVENT_KEYS + ALL_MAGNITUDES)})", table, key)
        for key in ("at_s", "unit", "type"):
            if key not in ev:
                fail(f"[[event]] needs {key!r}", table)
        at_s = _number(ev["at_s"], "at_s", table, fail)
        if at_s < 0.0:
            fail(f"at_s must be >= 0, not {at_s}", table, "at_s")
        unit, ftype = ev["unit"], ev["type"]
        if not isinstance(unit, str) or unit not in SUPPORTED:
            known = ", ".join(SUPPORTED)
            what = "not supported by the fault injector" if unit in UNITS else "unknown"
            fail(f"unit {unit!r} is {what} (supported: {known})", table, "unit")
        if not isinstance(ftype, str) or ftype not in TYPES:
            fail(f"unknown type {ftype!r} (expected: {', '.join(TYPES)})", table, "type")
        if ftype not in SUPPORTED[unit]:
            fail(f"{unit} does not support type {ftype!r} (supported: "
                 f"{', '.join(SUPPORTED[unit])})", table, "type")
        instance = ev.get("instance", 0)
        if isinstance(instance, bool) or not isinstance(instance, int) or instance < 0:
            fail(f"instance must be an integer >= 0, not {instance!r}", table, "instance")
        mags = {k: v for k, v in ev.items() if k not in _EVENT_KEYS}
        try:
            check_magnitudes(unit, ftype, mags)
        except FaultSpecError as e:
            fail(str(e), table, e.key)
        if "axis" in mags:   # "x"/"y"/"z" or 0/1/2, kept as the index the injector uses
            mags["axis"] = axis_index(mags["axis"])
        events.append(Event(at_s, unit, ftype, instance, mags))
    events.sort(key=lambda e: e.at_s)
    return Scenario(wind, tuple(events), path)


def _number(v, key: str, table: tuple, fail) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        fail(f"{key} must be a finite number, not {v!r}", table, key)
    return float(v)


def parse_wind_arg(text: str) -> Wind:
    """The CLI's ``--wind SPEED,FROM_DEG[,TURBULENCE]``, e.g. "5,270" or "5,270,light"."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) not in (2, 3):
        raise ScenarioError(f"--wind wants SPEED,FROM_DEG[,TURBULENCE], not {text!r}")
    try:
        speed, from_deg = float(parts[0]), float(parts[1])
    except ValueError as e:
        raise ScenarioError(f"--wind wants numbers SPEED,FROM_DEG, not {text!r}") from e
    if not math.isfinite(speed) or speed < 0.0:
        raise ScenarioError(f"--wind speed must be >= 0, not {parts[0]}")
    if not math.isfinite(from_deg) or not 0.0 <= from_deg <= 360.0:
        raise ScenarioError(f"--wind direction must be in [0, 360] deg, not {parts[1]}")
    turb = parts[2] if len(parts) == 3 else "none"
    if turb not in TURBULENCE:
        raise ScenarioError(f"--wind turbulence must be one of {', '.join(TURBULENCE)}")
    return Wind(speed, from_deg, turb)
