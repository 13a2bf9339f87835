"""Campaign files: schema, distributions and the checks made before any trial runs.

    [campaign]
    name = "default-wind"
    trials = 200
    seed = 7                 # trial i's seed and draws come from (seed, i) only
    vehicle = "plane"        # any run option as a fixed value (see OPTIONS)
    mission = "missions/default.waypoints"
    duration_s = 900
    keep_worst = 3           # flight logs kept for the 3 worst trials per figure
    figures = ["xtrack_max_m", "alt_rms_m"]   # the report's key figures ("-name": low is bad)
    trial_timeout_s = 1800   # wall seconds; a trial that runs longer is an error row

    [dispersion]             # a run option or "param.NAME" each: a distribution or a value
    wind_speed_mps = { uniform = [0.0, 10.0] }
    wind_from_deg = { uniform = [0.0, 360.0] }
    turbulence = { choice = ["none", "light", "moderate"] }
    "param.NAVL1_PERIOD" = { normal = [17.0, 2.0], min = 12.0, max = 25.0 }

    [[event]]                # scenario events; any value may be a distribution
    at_s = { uniform = [60.0, 200.0] }
    unit = "gps"
    type = "off"
    [[event]]
    after_s = { uniform = [20.0, 90.0] }    # instead of at_s: after the previous event
    unit = "gps"
    type = "ok"

    [criteria]               # name = expression over summary keys; all must hold to pass
    completed = "completed"
    xtrack = "xtrack_max_m <= 30"

Distributions: ``{ uniform = [a, b] }``, ``{ normal = [mean, sd] }`` (truncated with
``min`` and/or ``max``), ``{ loguniform = [a, b] }`` (0 < a), ``{ choice = [v, ...] }``
(optional ``weights``), ``{ randint = [a, b] }`` (integers a..b); a plain value is fixed.
String options may contain ``{seed}``, replaced by the trial's seed
(``mission = "random:plane:{seed}"``).

Every mistake is a ``CampaignError`` whose message starts with ``FILE:LINE:``: unknown
keys, options and parameters, bad distributions (wrong arity, empty or reversed ranges,
a support outside what the option, parameter or fault accepts), criteria that do not
parse or name no key of the vehicle's summary. Lines are found in the raw text as the
scenario loader finds them (tomllib reports none for valid TOML).
"""
from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from sim_bridge.scenario import TURBULENCE, _Lines

NAV_SOURCES = ("ekf", "ukf", "truth")
VEHICLES = ("plane", "quad")
AIRFRAMES = {"plane": ("aerosonde", "c172p"), "quad": ("f450",)}
# the default flight of ``sitl run``: missions/default_scenario.toml's wind
DEFAULT_WIND = {"wind_speed_mps": 5.0, "wind_from_deg": 270.0, "turbulence": "light"}


@dataclass(frozen=True)
class Option:
    """A ``sitl run`` option a campaign can fix or disperse."""
    kind: str                         # "number", "choice", "string"
    lo: float = -math.inf             # numbers: the accepted range
    hi: float = math.inf
    choices: tuple = ()


def _gps_models() -> tuple[str, ...]:
    from sim_bridge.sensors.params import GPS_PRESETS
    return tuple(GPS_PRESETS)


OPTIONS: dict[str, Option] = {
    "vehicle": Option("choice", choices=VEHICLES),
    "airframe": Option("choice", choices=AIRFRAMES["plane"] + AIRFRAMES["quad"]),
    "mission": Option("string"),
    "params_file": Option("string"),
    "home_lat_deg": Option("number", -90.0, 90.0),
    "home_lon_deg": Option("number", -180.0, 180.0),
    "home_alt_m": Option("number", -500.0, 9000.0),
    "home_heading_deg": Option("number"),
    "wind_speed_mps": Option("number", 0.0, 60.0),
    "wind_from_deg": Option("number"),
    "turbulence": Option("choice", choices=TURBULENCE),
    "gps": Option("choice", choices=_gps_models()),
    "nav": Option("choice", choices=NAV_SOURCES),
    "duration_s": Option("number", 1e-3, 1e7),
}
HOME_KEYS = ("home_lat_deg", "home_lon_deg", "home_alt_m", "home_heading_deg")
PARAM_PREFIX = "param."

_META_KEYS = ("name", "trials", "seed", "keep_worst", "figures", "trial_timeout_s", "description")
_TOP_KEYS = ("campaign", "dispersion", "event", "criteria")
_EVENT_KEYS = ("at_s", "after_s", "unit", "type", "instance")
DISTRIBUTIONS = ("uniform", "normal", "loguniform", "choice", "randint")


class CampaignError(ValueError):
    """A campaign file that cannot be used; the message starts with FILE:LINE:."""

    def __init__(self, message: str, path: str | None = None, line: int | None = None):
        where = ""
        if path is not None:
            where = f"{path}:{line}: " if line is not None else f"{path}: "
        super().__init__(where + message)
        self.path = path
        self.line = line


@dataclass(frozen=True)
class Dist:
    """One dispersed value: ``kind`` in DISTRIBUTIONS or "fixed"."""
    kind: str
    args: tuple = ()
    lo: float | None = None           # normal: truncation
    hi: float | None = None
    weights: tuple | None = None      # choice

    def support(self) -> list:
        """The values whose acceptance bounds the acceptance of every draw: the ends of
        a numeric support (the truncation ends of a normal; none if unbounded), every
        value of a choice, the value itself if fixed."""
        if self.kind == "fixed":
            return [self.args[0]]
        if self.kind == "choice":
            return list(self.args)
        if self.kind == "normal":
            return [v for v in (self.lo, self.hi) if v is not None]
        return [self.args[0], self.args[1]]

    def unbounded(self) -> tuple[bool, bool]:
        """(below, above): whether draws can go without bound on that side."""
        if self.kind == "normal":
            return self.lo is None, self.hi is None
        return False, False

    def draw(self, rng):
        """One value from the generator ``rng`` (numpy Generator); one uniform variate
        per numeric draw, so a draw depends on its own generator only."""
        k, a = self.kind, self.args
        if k == "fixed":
            return a[0]
        if k == "uniform":
            return float(a[0] + (a[1] - a[0]) * rng.random())
        if k == "loguniform":
            return float(math.exp(math.log(a[0]) + (math.log(a[1]) - math.log(a[0])) * rng.random()))
        if k == "randint":
            return int(rng.integers(a[0], a[1] + 1))
        if k == "choice":
            if self.weights is None:
                return a[int(rng.integers(0, len(a)))]
            u = rng.random() * sum(self.weights)
            acc = 0.0
            for v, w in zip(a, self.weights):
                acc += w
                if u < acc:
                    return v
            return a[-1]
        # normal, truncated to [lo, hi] by the inverse CDF (eq: x = mu + sd Phi^-1(u),
        # u uniform on [Phi((lo - mu)/sd), Phi((hi - mu)/sd)])
        from scipy.special import ndtr, ndtri
        mu, sd = a
        if sd == 0.0:
            return float(mu)
        p0 = ndtr((self.lo - mu) / sd) if self.lo is not None else 0.0
        p1 = ndtr((self.hi - mu) / sd) if self.hi is not None else 1.0
        u = p0 + (p1 - p0) * rng.random()
        u = min(max(u, 1e-300), 1.0 - 1e-16)
        x = float(mu + sd * ndtri(u))
        if self.lo is not None:
            x = max(x, self.lo)
        if self.hi is not None:
            x = min(x, self.hi)
        return x

    def describe(self) -> str:
        if self.kind == "fixed":
            return repr(self.args[0])
        extra = ""
        if self.kind == "normal":
            extra = "".join(f", {n}={v}" for n, v in (("min", self.lo), ("max", self.hi)) if v is not None)
        if self.weights is not None:
            extra = f", weights={list(self.weights)}"
        return f"{self.kind}{list(self.args)}{extra}"


@dataclass
class EventSpec:
    """A scenario event whose values may be dispersed (``fields``: key -> Dist)."""
    fields: dict
    line: int | None = None


@dataclass
class Campaign:
    path: str
    text: str
    name: str
    trials: int
    seed: int
    keep_worst: int = 3
    figures: tuple = ()
    trial_timeout_s: float = 1800.0
    description: str = ""
    values: dict = field(default_factory=dict)      # option or param.NAME -> Dist
    events: list = field(default_factory=list)      # EventSpec
    criteria: dict = field(default_factory=dict)    # name -> criteria.Criterion
    lines: object = None

    def dispersed(self) -> list[str]:
        """Keys (options, param.NAME, event.N.key) with a non-fixed distribution."""
        out = [k for k, d in self.values.items() if d.kind != "fixed"]
        for i, ev in enumerate(self.events):
            out += [f"event.{i}.{k}" for k, d in ev.fields.items() if d.kind != "fixed"]
        return out

    def vehicles(self) -> tuple[str, ...]:
        d = self.values.get("vehicle")
        if d is None:
            return ("plane",)
        return tuple(d.support())


# --- loading -------------------------------------------------------------------------

def load_campaign(path: str | Path, check_keys: bool = True) -> Campaign:
    """Read and check a campaign file. ``check_keys``: check criteria against the
    summary keys of the campaign's vehicles (costs one very short flight per vehicle,
    cached per process). Raises CampaignError."""
    path_s = str(path)
    try:
        raw = Path(path).read_bytes()
    except OSError as e:
        raise CampaignError(f"cannot read: {e.strerror}", path_s) from e
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise CampaignError(f"not UTF-8 text: {e}", path_s) from e
    return parse_campaign_text(text, path_s, check_keys=check_keys)


def parse_campaign_text(text: str, path: str = "<string>", check_keys: bool = True) -> Campaign:
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        m = re.search(r"line (\d+)", str(e))
        raise CampaignError(f"TOML syntax error: {e}", path, int(m.group(1)) if m else None) from e
    lines = _Lines(text)

    def fail(msg: str, table: tuple, key: str | None = None):
        raise CampaignError(msg, path, lines.of(table, key))

    for key in data:
        if key not in _TOP_KEYS:
            fail(f"unknown top-level key {key!r} (expected tables: {', '.join(_TOP_KEYS)})", (), key)
    for key in ("campaign", "dispersion", "criteria"):
        if key in data and not isinstance(data[key], dict):
            fail(f"{key!r} must be a table: [{key}]", (), key)
    camp = data.get("campaign")
    if camp is None:
        fail("a campaign file needs a [campaign] table (name, trials, seed)", ())
    ct = ("campaign",)
    for key in ("name", "trials", "seed"):
        if key not in camp:
            fail(f"[campaign] needs {key!r}", ct)
    name = camp["name"]
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z0-9_.\-]+", name):
        fail(f"name must be letters, digits, '_', '-', '.', not {name!r}", ct, "name")
    trials = _int(camp["trials"], "trials", 1, ct, fail)
    seed = _int(camp["seed"], "seed", 0, ct, fail)
    keep_worst = _int(camp.get("keep_worst", 3), "keep_worst", 0, ct, fail)
    timeout = camp.get("trial_timeout_s", 1800.0)
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not timeout > 0:
        fail(f"trial_timeout_s must be a positive number, not {timeout!r}", ct, "trial_timeout_s")
    figures = camp.get("figures", [])
    if not isinstance(figures, list) or not all(isinstance(f, str) and f.lstrip("-") for f in figures):
        fail("figures must be a list of summary key names (\"-name\": low values are bad)", ct, "figures")
    description = camp.get("description", "")
    if not isinstance(description, str):
        fail("description must be a string", ct, "description")

    c = Campaign(path=path, text=text, name=name, trials=trials, seed=seed, keep_worst=keep_worst,
                 figures=tuple(figures), trial_timeout_s=float(timeout), description=description,
                 lines=lines)
    for key, v in camp.items():
        if key in _META_KEYS:
            continue
        if key not in OPTIONS and not key.startswith(PARAM_PREFIX):
            fail(f"unknown key {key!r} in [campaign] (campaign keys: {', '.join(_META_KEYS)}; "
                 f"run options: {', '.join(OPTIONS)}; parameters: param.NAME)", ct, key)
        c.values[key] = Dist("fixed", (v,))
    for key, v in data.get("dispersion", {}).items():
        dt = ("dispersion",)
        if key not in OPTIONS and not key.startswith(PARAM_PREFIX):
            fail(f"unknown key {key!r} in [dispersion] (run options: {', '.join(OPTIONS)}; "
                 f"parameters: param.NAME)", dt, key)
        if key in c.values:
            fail(f"{key!r} is set in [campaign] and dispersed in [dispersion]: keep one", dt, key)
        c.values[key] = _dist(v, key, dt, fail)
    for key, d in c.values.items():
        table = ("dispersion",) if key in data.get("dispersion", {}) else ct
        _check_value(key, d, c, table, fail)

    raw_events = data.get("event", [])
    if not isinstance(raw_events, list):
        fail("'event' must be an array of tables: [[event]]", (), "event")
    for i, ev in enumerate(raw_events):
        et = ("event", i)
        if not isinstance(ev, dict):
            fail("each event must be a table: [[event]]", (), "event")
        c.events.append(_event(ev, et, fail, lines))

    from .criteria import parse_criterion
    for cname, expr in data.get("criteria", {}).items():
        line = lines.of(("criteria",), cname)
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", cname):
            raise CampaignError(f"criterion name {cname!r}: letters, digits and '_' only", path, line)
        if not isinstance(expr, str):
            raise CampaignError(f"criterion {cname!r} must be an expression in a string, not {expr!r}",
                                path, line)
        c.criteria[cname] = parse_criterion(cname, expr, path, line)
    if check_keys:
        check_summary_keys(c)
    return c


def check_summary_keys(c: Campaign) -> None:
    """Every key a criterion or ``figures`` names must be a key of the summary of one of
    the campaign's vehicles (criteria.known_key), or ``input.KEY`` of one of its inputs
    (``input.event.0.effectiveness``: the truth an identification is compared with)."""
    from .criteria import known_key, summary_keys
    keys = set()
    for v in c.vehicles():
        keys |= summary_keys(v)
    inputs = set(DEFAULT_WIND) | set(c.values)
    for i, ev in enumerate(c.events):
        inputs |= {f"event.{i}.{k}" for k in ev.fields} | {f"event.{i}.at_s"}
    for crit in c.criteria.values():
        for k in crit.keys:
            if k.startswith("input."):
                if k[len("input."):] not in inputs:
                    raise CampaignError(f"criterion {crit.name!r} names {k!r}, which is no input of this "
                                        f"campaign{_near(k, {'input.' + x for x in inputs})}", c.path, crit.line)
                continue
            if not known_key(k, keys):
                raise CampaignError(f"criterion {crit.name!r} names {k!r}, which is no key of the "
                                    f"{'/'.join(c.vehicles())} summary{_near(k, keys)}", c.path, crit.line)
    for f in c.figures:
        if not known_key(f.lstrip("-"), keys):
            raise CampaignError(f"figures: {f.lstrip('-')!r} is no key of the "
                                f"{'/'.join(c.vehicles())} summary{_near(f.lstrip('-'), keys)}",
                                c.path, c.lines.of(("campaign",), "figures"))


def _near(key: str, keys) -> str:
    import difflib
    m = difflib.get_close_matches(key, sorted(keys), n=3)
    return f" (did you mean {', '.join(m)}?)" if m else ""


def _int(v, key, lo, table, fail) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or v < lo:
        fail(f"{key} must be an integer >= {lo}, not {v!r}", table, key)
    return v


def _dist(v, key: str, table: tuple, fail) -> Dist:
    """A value of [dispersion] or of an event: a distribution table or a fixed value."""
    if not isinstance(v, dict):
        return Dist("fixed", (v,))
    kinds = [k for k in v if k in DISTRIBUTIONS]
    if len(kinds) != 1:
        fail(f"{key}: a distribution is one of {', '.join(DISTRIBUTIONS)} "
             f"(e.g. {{ uniform = [0.0, 10.0] }}), not {v!r}", table, key)
    kind = kinds[0]
    allowed = {"normal": ("min", "max"), "choice": ("weights",)}.get(kind, ())
    for extra in v:
        if extra != kind and extra not in allowed:
            fail(f"{key}: {kind} takes no {extra!r}"
                 + (f" (only {', '.join(allowed)})" if allowed else ""), table, key)
    args = v[kind]
    if not isinstance(args, list):
        fail(f"{key}: {kind} wants a list, e.g. {kind} = [a, b]", table, key)
    if kind == "choice":
        if not args:
            fail(f"{key}: choice of nothing", table, key)
        w = v.get("weights")
        if w is not None:
            if not isinstance(w, list) or len(w) != len(args) or not all(_num(x) and x >= 0 for x in w) \
                    or not sum(w) > 0:
                fail(f"{key}: weights must be {len(args)} numbers >= 0, not all 0", table, key)
            w = tuple(float(x) for x in w)
        return Dist("choice", tuple(args), weights=w)
    if len(args) != 2 or not all(_num(x) for x in args):
        what = "[mean, sd]" if kind == "normal" else "[low, high]"
        fail(f"{key}: {kind} wants two numbers {what}, not {args!r}", table, key)
    a, b = float(args[0]), float(args[1])
    if kind == "normal":
        if b < 0:
            fail(f"{key}: normal standard deviation must be >= 0, not {b}", table, key)
        lo, hi = v.get("min"), v.get("max")
        for n, x in (("min", lo), ("max", hi)):
            if x is not None and not _num(x):
                fail(f"{key}: normal {n} must be a number, not {x!r}", table, key)
        lo = float(lo) if lo is not None else None
        hi = float(hi) if hi is not None else None
        if lo is not None and hi is not None and not lo < hi:
            fail(f"{key}: normal min {lo} must be below max {hi}", table, key)
        return Dist("normal", (a, b), lo, hi)
    if not a <= b:
        fail(f"{key}: {kind} range [{a}, {b}] is reversed (low must not exceed high)", table, key)
    if kind == "loguniform" and not a > 0:
        fail(f"{key}: loguniform needs 0 < low, not {a}", table, key)
    if kind == "randint":
        if a != int(a) or b != int(b):
            fail(f"{key}: randint wants integers, not {args!r}", table, key)
        return Dist("randint", (int(a), int(b)))
    return Dist(kind, (a, b))


def _num(x) -> bool:
    return not isinstance(x, bool) and isinstance(x, (int, float)) and math.isfinite(x)


def _check_value(key: str, d: Dist, c: Campaign, table: tuple, fail) -> None:
    """Every value a distribution can draw must be one the option (or parameter)
    accepts: checked at the ends of its support."""
    if key.startswith(PARAM_PREFIX):
        _check_param(key, d, c, table, fail)
        return
    opt = OPTIONS[key]
    below, above = d.unbounded()
    for v in d.support():
        if opt.kind == "choice":
            if v not in opt.choices:
                fail(f"{key}: {v!r} is not one of {', '.join(map(str, opt.choices))}", table, key)
        elif opt.kind == "string":
            if not isinstance(v, str) or not v:
                fail(f"{key}: a non-empty string, not {v!r}", table, key)
        elif not _num(v) or not opt.lo <= v <= opt.hi:
            fail(f"{key}: {v!r} is outside [{opt.lo:g}, {opt.hi:g}]", table, key)
    if opt.kind in ("choice", "string") and d.kind not in ("fixed", "choice"):
        fail(f"{key} takes a value or a choice, not a {d.kind} distribution", table, key)
    if opt.kind == "number" and ((below and opt.lo > -math.inf) or (above and opt.hi < math.inf)):
        fail(f"{key}: a normal without {'min' if below and opt.lo > -math.inf else 'max'} can draw "
             f"outside [{opt.lo:g}, {opt.hi:g}]: truncate it", table, key)


def _param_decls(vehicle: str) -> dict:
    if vehicle == "quad":
        from autopilot.vehicle_quad import quad_param_declarations
        decls = quad_param_declarations()
    else:
        from autopilot.vehicle import plane_param_declarations
        decls = plane_param_declarations()
    return {p.name: p for p in decls}


def _check_param(key: str, d: Dist, c: Campaign, table: tuple, fail) -> None:
    name = key[len(PARAM_PREFIX):]
    for vehicle in c.vehicles():
        decls = _param_decls(vehicle)
        p = decls.get(name)
        if p is None:
            import difflib
            near = difflib.get_close_matches(name, list(decls), n=3)
            fail(f"unknown parameter {name!r} for the {vehicle}"
                 + (f" (did you mean {', '.join(near)}?)" if near else ""), table, key)
        below, above = d.unbounded()
        if below or above:
            fail(f"{key}: a normal without {'min' if below else 'max'} can draw outside "
                 f"[{p.min:g}, {p.max:g}]: truncate it", table, key)
        for v in d.support():
            if not _num(v) or not p.min <= v <= p.max:
                fail(f"{key}: {v!r} is outside the parameter's range [{p.min:g}, {p.max:g}]", table, key)
            if p.is_int and d.kind in ("uniform", "normal", "loguniform"):
                fail(f"{key}: {name} is an integer parameter: use randint or choice", table, key)


def _event(ev: dict, table: tuple, fail, lines) -> EventSpec:
    from sim_bridge.faults.catalogue import (
        ALL_MAGNITUDES, SUPPORTED, TYPES, FaultSpecError, check_magnitudes,
    )
    fields = {}
    for key, v in ev.items():
        if key not in _EVENT_KEYS and key not in ALL_MAGNITUDES:
            fail(f"unknown key {key!r} in [[event]] (expected: {', '.join(_EVENT_KEYS + ALL_MAGNITUDES)})",
                 table, key)
        fields[key] = _dist(v, key, table, fail)
    for key in ("unit", "type"):
        if key not in fields:
            fail(f"[[event]] needs {key!r}", table)
    if ("at_s" in fields) == ("after_s" in fields):
        fail("[[event]] needs one of 'at_s' (time of the event) and 'after_s' (time after the "
             "previous event)", table)
    if "after_s" in fields and table[1] == 0:
        fail("the first [[event]] has no previous event: give at_s", table, "after_s")
    tkey = "at_s" if "at_s" in fields else "after_s"
    at = fields[tkey]
    below, above = at.unbounded()
    if below:
        fail(f"{tkey}: a normal without min can draw a negative time: truncate it", table, tkey)
    for v in at.support():
        if not _num(v) or v < 0:
            fail(f"{tkey} must be a number >= 0, not {v!r}", table, tkey)
    for key in ("unit", "type"):
        if fields[key].kind not in ("fixed", "choice"):
            fail(f"{key}: a value or a choice, not a {fields[key].kind} distribution", table, key)
    inst = fields.get("instance", Dist("fixed", (0,)))
    for v in inst.support():
        if isinstance(v, bool) or not isinstance(v, int) or v < 0:
            fail(f"instance must be an integer >= 0, not {v!r}", table, "instance")
    mags = {k: d for k, d in fields.items() if k not in _EVENT_KEYS}
    for unit in fields["unit"].support():
        if unit not in SUPPORTED:
            fail(f"unit {unit!r} is not supported by the fault injector (supported: "
                 f"{', '.join(SUPPORTED)})", table, "unit")
        for ftype in fields["type"].support():
            if ftype not in TYPES or ftype not in SUPPORTED[unit]:
                fail(f"{unit} does not support type {ftype!r} (supported: {', '.join(SUPPORTED[unit])})",
                     table, "type")
            # every magnitude at each end of its support, the others at their first end
            for key, d in mags.items():
                if any(d.unbounded()):
                    fail(f"{key}: truncate the normal (min and max): a fault magnitude has a range",
                         table, key)
                for v in d.support():
                    sample = {k: (v if k == key else m.support()[0]) for k, m in mags.items()}
                    try:
                        check_magnitudes(unit, ftype, sample)
                    except FaultSpecError as e:
                        fail(f"{e} (at {key} = {v!r})", table, e.key if e.key in mags else key)
    return EventSpec(fields, lines.of(table))
