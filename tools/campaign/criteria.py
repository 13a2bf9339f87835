"""Criteria: named pass/fail expressions over a trial's flattened summary.

A summary (``summary.json``) is flattened into one value per dotted key: nested tables
become ``invariants.orbits.passed``, lists their first ``MAX_LIST_ITEMS`` items
``faults.0.delay_s``. A criterion is a Python-syntax expression over those keys, parsed
with ``ast`` and evaluated by a small interpreter (no ``eval``): numbers, strings,
``True``/``False``/``None``, comparisons (chained too), ``and``/``or``/``not``,
``+ - * /``, ``abs``/``min``/``max``; a key is a name, a dotted name, or indexed
(``faults[0].delay_s`` and ``faults.0.delay_s`` are the same key); ``input.KEY`` is
the trial's input KEY (``input.event.0.effectiveness``, the truth an identified value is
compared with). A key the trial's summary lacks, or
that is null (no cross-track figure when no leg was flown), makes the value unknown,
and an unknown criterion fails.
"""
from __future__ import annotations

import ast
import math
import operator
import re
from dataclasses import dataclass

from .spec import CampaignError

MAX_LIST_ITEMS = 8

# keys that exist only in some flights (faults injected, GPS outages, FDI episodes,
# fault monitor identification, mission invariants); a criterion may name them even if a
# fault-free dry flight does not have them. "#" = an item index, "*" = any name.
OPTIONAL_KEY_PATTERNS = (
    "faults.#.at_s", "faults.#.unit", "faults.#.type", "faults.#.instance",
    "faults.#.detected_s", "faults.#.delay_s", "faults.#.isolated", "faults.#.isolated_s",
    "faults.#.isolated_all", "faults.#.isolated_all.#", "faults.#.height_at_onset_m",
    "faults.#.height_lost_m", "faults.#.departed_s", "faults.#.delay_departed_s",
    "faults.#.kind", "faults.#.cleared_s", "faults.#.identified.*", "faults.#.identified_10s.*",
    "faults.#.identified", "faults.#.identified_10s",
    "faults_injected.#.at_s", "faults_injected.#.unit", "faults_injected.#.type",
    "faults_injected.#.instance", "faults_injected.#.accepted", "faults_injected.#.source",
    "gps_outages.#.start_s", "gps_outages.#.end_s", "gps_outages.#.pos_h_err_at_end_m",
    "gps_outages.#.pos_h_err_max_m", "gps_outages.#.reconverge_s",
    "fdi_episodes.#.start_s", "fdi_episodes.#.trigger", "fdi_episodes.#.isolated",
    "fdi_episodes.#.isolated_s", "fdi_episodes.#.end_s",
    "fdi_peak_ratio.*", "nav_pos_h_rms_during_fault_okf_m",
    "invariants.*.passed", "invariants.*.figure", "invariants.*.limit", "invariants.*.seq",
    "xtrack_mission_rms_m", "xtrack_mission_max_m",
    "landing.*",                      # a flight with a NAV_LAND (tools/landing_score.py)
)
_PATTERNS = [re.compile("^" + re.escape(p).replace("\\#", r"\d+").replace("\\*", r"[^.]+") + "$")
             for p in OPTIONAL_KEY_PATTERNS]


def flatten(summary: dict, prefix: str = "") -> dict:
    """{"a": {"b": 1}, "l": [{"x": 2}]} -> {"a.b": 1, "l.0.x": 2}."""
    out: dict = {}
    for k, v in summary.items():
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(flatten(v, name + "."))
        elif isinstance(v, (list, tuple)):
            out.update(flatten({str(i): x for i, x in enumerate(v[:MAX_LIST_ITEMS])}, name + "."))
        else:
            out[name] = v
    return out


_DRY_KEYS: dict = {}


def summary_keys(vehicle: str) -> set:
    """The flattened keys of a ``vehicle`` summary, from a very short fault-free flight
    of the default mission: until one second after arming (most figures exist only for
    an armed flight; about 0.2 s of wall time), cached per process."""
    if vehicle not in _DRY_KEYS:
        from tools.runner import RunConfig, Session
        from tools.summary import run_summary
        from .spec import AIRFRAMES
        s = Session(RunConfig(vehicle=vehicle, airframe=AIRFRAMES[vehicle][0], duration_s=60.0,
                              mission=_default_mission(vehicle)))
        armed_s = None
        while s.t_s < 60.0 and (armed_s is None or s.t_s < armed_s + 1.0):
            s.step()
            if armed_s is None and s.vehicle.armed:
                armed_s = s.t_s
        _DRY_KEYS[vehicle] = set(flatten(run_summary(s)))
    return _DRY_KEYS[vehicle]


def _default_mission(vehicle: str):
    from tools.runner import DEFAULT_MISSION, QUAD_DEFAULT_MISSION
    return QUAD_DEFAULT_MISSION if vehicle == "quad" else DEFAULT_MISSION


def known_key(key: str, keys: set) -> bool:
    return key in keys or any(p.match(key) for p in _PATTERNS)


# --- expressions ---------------------------------------------------------------------

_CMP = {ast.Eq: operator.eq, ast.NotEq: operator.ne, ast.Lt: operator.lt, ast.LtE: operator.le,
        ast.Gt: operator.gt, ast.GtE: operator.ge}
_BIN = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv}
_FUNCS = {"abs": abs, "min": min, "max": max}
_CONSTS = {"True": True, "False": False, "None": None}


@dataclass(frozen=True)
class Criterion:
    name: str
    expr: str
    tree: ast.Expression
    keys: tuple                      # the summary keys it names
    line: int | None = None

    def holds(self, flat: dict) -> bool:
        """True only if the expression is true on this summary (unknown fails)."""
        try:
            v = _eval(self.tree.body, flat)
        except (ArithmeticError, TypeError, ValueError):
            return False
        return v is not None and bool(v)


def _key_of(node) -> str | None:
    """The dotted key a Name / Attribute / Subscript chain stands for, else None."""
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        base = _key_of(node.value)
        return f"{base}.{node.attr}" if base is not None else None
    if isinstance(node, ast.Subscript):
        base = _key_of(node.value)
        s = node.slice
        if base is not None and isinstance(s, ast.Constant) and isinstance(s.value, (int, str)) \
                and not isinstance(s.value, bool):
            return f"{base}.{s.value}"
    return None


# ``faults.0.delay_s`` (a flattened column name) is not Python: read it as faults[0].delay_s
_INDEX_RE = re.compile(r"(?<=[A-Za-z_\]])\.(\d+)\b")


def parse_criterion(name: str, expr: str, path: str, line: int | None) -> Criterion:
    def bad(msg):
        raise CampaignError(f"criterion {name!r}: {msg}: {expr!r}", path, line)

    try:
        tree = ast.parse(_INDEX_RE.sub(r"[\1]", expr.strip()), mode="eval")
    except SyntaxError as e:
        bad(f"does not parse ({e.msg})")
    keys: list[str] = []

    def walk(node):
        if isinstance(node, ast.Name) and node.id in _CONSTS:
            return
        if isinstance(node, (ast.Name, ast.Attribute, ast.Subscript)):
            k = _key_of(node)
            if k is None:
                bad("a key is a name, a dotted name or name[index]")
            if k not in keys:
                keys.append(k)
            return
        if isinstance(node, ast.Constant):
            if not isinstance(node.value, (int, float, str, bool, type(None))):
                bad(f"constant {node.value!r} not allowed")
            return
        if isinstance(node, ast.Compare):
            if not all(type(op) in _CMP for op in node.ops):
                bad("comparisons are == != < <= > >=")
        elif isinstance(node, ast.BoolOp) or isinstance(node, ast.UnaryOp) and \
                isinstance(node.op, (ast.Not, ast.USub, ast.UAdd)):
            pass
        elif isinstance(node, ast.BinOp):
            if type(node.op) not in _BIN:
                bad("arithmetic is + - * /")
        elif isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in _FUNCS or node.keywords:
                bad(f"functions are {', '.join(_FUNCS)}")
            for a in node.args:
                walk(a)
            return
        else:
            bad(f"{type(node).__name__} is not allowed")
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.cmpop, ast.boolop, ast.unaryop, ast.operator)):
                continue
            walk(child)

    walk(tree.body)
    if not keys:
        bad("names no summary key")
    return Criterion(name, expr, tree, tuple(keys), line)


def _eval(node, flat: dict):
    """None (unknown) propagates through arithmetic and comparisons."""
    if isinstance(node, ast.Constant):
        return node.value
    if isinstance(node, ast.Name) and node.id in _CONSTS:
        return _CONSTS[node.id]
    key = _key_of(node)
    if key is not None:
        v = flat.get(key)
        return None if isinstance(v, float) and math.isnan(v) else v
    if isinstance(node, ast.BoolOp):
        vals = [_eval(v, flat) for v in node.values]
        if isinstance(node.op, ast.And):
            if any(v is not None and not v for v in vals):
                return False
            return None if any(v is None for v in vals) else True
        if any(v is not None and v for v in vals):
            return True
        return None if any(v is None for v in vals) else False
    if isinstance(node, ast.UnaryOp):
        v = _eval(node.operand, flat)
        if v is None:
            return None
        if isinstance(node.op, ast.Not):
            return not v
        return -v if isinstance(node.op, ast.USub) else +v
    if isinstance(node, ast.BinOp):
        a, b = _eval(node.left, flat), _eval(node.right, flat)
        return None if a is None or b is None else _BIN[type(node.op)](a, b)
    if isinstance(node, ast.Compare):
        left = _eval(node.left, flat)
        for op, right_node in zip(node.ops, node.comparators):
            right = _eval(right_node, flat)
            if left is None or right is None:
                return None
            if not _CMP[type(op)](left, right):
                return False
            left = right
        return True
    if isinstance(node, ast.Call):
        args = [_eval(a, flat) for a in node.args]
        return None if any(a is None for a in args) else _FUNCS[node.func.id](*args)
    raise ValueError(f"cannot evaluate {type(node).__name__}")
