"""Trial i of a campaign: its seed, every input, and the ``sitl run`` command that flies it.

Trial ``i`` is a pure function of (file, i). Its flight seed is drawn from
``SeedSequence([campaign seed, i])``; each dispersed key draws from its own generator,
``SeedSequence([campaign seed, i, crc32(key)])``, so adding a dispersion to a file
leaves the other keys' draws of every trial as they were.

The command line is the trial: the worker builds the run from exactly these arguments
with the parser and configuration code of ``sitl run`` (tools/sitl.py), so rerunning
the printed command gives the same summary. Everything is explicit in it (wind,
turbulence, seed, duration, ...) so that no default of ``sitl run`` stands in for a
campaign value; events go to a scenario file holding only them (``--wind`` and
``--turbulence`` override a scenario's wind).
"""
from __future__ import annotations

import shlex
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .spec import DEFAULT_WIND, HOME_KEYS, PARAM_PREFIX, Campaign

SEED_MAX = 2 ** 31 - 1


@dataclass
class Trial:
    index: int
    seed: int
    inputs: dict                          # option / param.NAME / event.N.key -> value
    argv: list                            # ``sitl run`` arguments (paths as written)
    scenario_text: str | None = None      # events, if any (the --scenario file)
    error: str | None = None              # an input that cannot be resolved
    events: list = field(default_factory=list)

    def command(self, scenario_path: str | None = None) -> str:
        """The shell command that reproduces the trial; ``scenario_path``: where the
        trial's scenario file is (``write_scenario``)."""
        argv = list(self.argv)
        if self.scenario_text is not None:
            argv += ["--scenario", scenario_path or f"trial_{self.index:05d}.scenario.toml"]
        return "sitl run " + " ".join(shlex.quote(a) for a in argv)


def trial_seed(campaign_seed: int, index: int) -> int:
    return int(np.random.SeedSequence([campaign_seed, index]).generate_state(1)[0]) % SEED_MAX


def _rng(campaign_seed: int, index: int, key: str):
    return np.random.default_rng(np.random.SeedSequence([campaign_seed, index, zlib.crc32(key.encode())]))


def _num(v: float) -> str:
    """Shortest text that reads back as exactly this float (repr), ints as ints."""
    if isinstance(v, bool):
        return str(int(v))
    if isinstance(v, int) or (isinstance(v, float) and v.is_integer() and abs(v) < 1e15):
        return str(int(v))
    return repr(float(v))


def resolve(c: Campaign, index: int) -> Trial:
    """Trial ``index`` (0-based) of campaign ``c``."""
    if not 0 <= index < c.trials:
        raise IndexError(f"trial {index} is outside 0..{c.trials - 1}")
    seed = trial_seed(c.seed, index)
    inputs: dict = {}
    for key, d in c.values.items():
        v = d.draw(_rng(c.seed, index, key))
        if isinstance(v, str):
            v = v.replace("{seed}", str(seed))
        inputs[key] = v
    for k, v in DEFAULT_WIND.items():
        inputs.setdefault(k, v)
    events = []
    for i, ev in enumerate(c.events):
        e = {}
        for key, d in ev.fields.items():
            e[key] = d.draw(_rng(c.seed, index, f"event.{i}.{key}"))
            inputs[f"event.{i}.{key}"] = e[key]
        if "after_s" in e:                # the time after the previous event
            inputs[f"event.{i}.at_s"] = events[-1]["at_s"] + e.pop("after_s")
            e = {"at_s": inputs[f"event.{i}.at_s"], **e}
        events.append(e)
    t = Trial(index, seed, inputs, [], events=events)
    t.argv, t.error = _argv(inputs, seed)
    if events:
        t.scenario_text = scenario_text(events)
    return t


def _argv(inputs: dict, seed: int) -> tuple[list[str], str | None]:
    """The ``sitl run`` arguments, and an error if an input cannot be resolved (a home
    given in part, from a mission that cannot be read here)."""
    error = None
    a = ["--vehicle", str(inputs.get("vehicle", "plane"))]
    if "airframe" in inputs:
        a += ["--airframe", str(inputs["airframe"])]
    if "mission" in inputs:
        a += ["--mission", str(inputs["mission"])]
    if "params_file" in inputs:
        a += ["--params", str(inputs["params_file"])]
    if any(k in inputs for k in HOME_KEYS):
        home = [inputs.get(k) for k in HOME_KEYS]
        if any(v is None for v in home):
            # the unset ones from the mission, as sitl run would take them
            from autopilot.mission.files import load_mission
            from tools.runner import DEFAULT_MISSION, QUAD_DEFAULT_MISSION, mission_home
            m = inputs.get("mission") or (QUAD_DEFAULT_MISSION if inputs.get("vehicle") == "quad"
                                          else DEFAULT_MISSION)
            try:
                mh = mission_home(load_mission(resolve_path(m)))
                home = [mh[i] if v is None else v for i, v in enumerate(home)]
            except (OSError, ValueError) as e:
                error = (f"home given in part ({', '.join(k for k in HOME_KEYS if k in inputs)}) and "
                         f"the rest not readable from the mission: {e}")
        if error is None:
            a += ["--home=" + ",".join(_num(v) for v in home)]   # "=": a southern latitude
    a += ["--wind", f"{_num(inputs['wind_speed_mps'])},{_num(inputs['wind_from_deg'])}",
          "--turbulence", str(inputs["turbulence"]), "--seed", str(seed)]
    if "duration_s" in inputs:
        a += ["--duration", _num(inputs["duration_s"])]
    if "nav" in inputs:
        a += ["--nav", str(inputs["nav"])]
    if "gps" in inputs:
        a += ["--gps", str(inputs["gps"])]
    for key in sorted(k for k in inputs if k.startswith(PARAM_PREFIX)):
        a += ["--param", f"{key[len(PARAM_PREFIX):]}={_num(inputs[key])}"]
    # the sensor-fault comparison flight of sitl run (R adaptation off) is not a
    # campaign figure: it would double the trial's cost
    a += ["--no-okf-replay"]
    return a, error


def resolve_path(p: str) -> str:
    """A relative file path is relative to the current directory, else to the
    repository (so the shipped campaigns run from anywhere); other mission sources
    (``random:plane:123``) are left as they are."""
    if ":" in p and not Path(p).exists():
        return p
    path = Path(p)
    if path.is_absolute() or path.exists():
        return str(path)
    from tools.runner import REPO_ROOT
    if (REPO_ROOT / path).exists():
        return str(REPO_ROOT / path)
    return str(path)


def run_argv(t: Trial) -> list[str]:
    """The arguments a worker runs, but ``--scenario`` (the worker writes the file):
    paths made absolute (workers may run elsewhere)."""
    out = list(t.argv)
    for i, a in enumerate(out[:-1]):
        if a in ("--mission", "--params"):
            out[i + 1] = resolve_path(out[i + 1])
    return out


def scenario_text(events: list[dict]) -> str:
    """A scenario file of these events (no [wind]: the command line has it)."""
    lines = ["# the events of one campaign trial (sitl campaign)"]
    for e in events:
        lines.append("")
        lines.append("[[event]]")
        for k, v in e.items():
            lines.append(f"{k} = {_toml(v)}")
    return "\n".join(lines) + "\n"


def _toml(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    s = str(v).replace("\\", "\\\\").replace('"', '\\"')
    return f'"{s}"'


def write_scenario(t: Trial, folder: Path) -> Path | None:
    """Write trial t's scenario file into ``folder`` (if it has events); its path."""
    if t.scenario_text is None:
        return None
    folder.mkdir(parents=True, exist_ok=True)
    p = folder / f"trial_{t.index:05d}.scenario.toml"
    if not p.exists() or p.read_text() != t.scenario_text:
        p.write_text(t.scenario_text)
    return p


def display_path(p: Path | str) -> str:
    """A path relative to the current directory when it is below it."""
    p = Path(p).resolve()
    try:
        return str(p.relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(p)
