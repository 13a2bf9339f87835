"""``sitl campaign show | run | report | export``.

    sitl campaign show FILE [--trial I] [--out DIR]
    sitl campaign run FILE [--workers N] [--scheduler tcp://HOST:PORT] [--out DIR] [--trials N]
    sitl campaign report DIR
    sitl campaign export DIR --format parquet|csv [-o FILE]

The campaign folder (``--out``, default ``campaigns/NAME``) holds ``campaign.duckdb``,
``scenarios/`` (the event files the reproduce commands name), ``runs/`` (kept run
folders) and ``report/``.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path


def add_parser(sub) -> None:
    """The ``campaign`` subcommand of ``sitl`` (tools/sitl.py)."""
    cp = sub.add_parser("campaign", help="dispersion campaigns: many seeded trials on Dask, results in DuckDB")
    cs = cp.add_subparsers(dest="campaign_cmd", required=True)
    s = cs.add_parser("show", help="the campaign's dispersions, or one trial's inputs and its sitl run command")
    s.add_argument("file")
    s.add_argument("--trial", type=int, default=None, help="trial index (0-based)")
    s.add_argument("--out", help="campaign folder for the trial's scenario file (default campaigns/NAME)")
    s.add_argument("--json", action="store_true", help="the trial as JSON (inputs, seed, command)")
    r = cs.add_parser("run", help="run the trials not yet stored (resumes an interrupted campaign)")
    r.add_argument("file")
    r.add_argument("--workers", type=int, default=None, help="LocalCluster worker processes (default: one per core)")
    r.add_argument("--scheduler", default=None, help="an existing Dask cluster: tcp://HOST:PORT")
    r.add_argument("--out", help="campaign folder (default campaigns/NAME)")
    r.add_argument("--trials", type=int, default=None, help="only the first N trials of the file")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    rp = cs.add_parser("report", help="HTML page (and PNGs) of a campaign folder: DIR/report/index.html")
    rp.add_argument("dir")
    ex = cs.add_parser("export", help="one row per stored trial, as Parquet or CSV")
    ex.add_argument("dir")
    ex.add_argument("--format", choices=["parquet", "csv"], default="parquet")
    ex.add_argument("-o", "--output", default=None, help="output file (default DIR/trials.FORMAT)")
    cp.set_defaults(func=cmd_campaign)


class CampaignCliError(Exception):
    pass


def cmd_campaign(args) -> int:
    """Errors are printed as ``sitl campaign: error: ...`` with status 2 (the campaign
    file's mistakes with FILE:LINE:)."""
    from .spec import CampaignError
    from .store import StoreError
    from .execute import CampaignRunError
    try:
        return {"show": _show, "run": _run, "report": _report, "export": _export}[args.campaign_cmd](args)
    except (CampaignError, StoreError, CampaignRunError, CampaignCliError) as e:
        print(f"sitl campaign: error: {e}", file=sys.stderr)
        return 2


def _show(args) -> int:
    from .execute import SCENARIOS_DIR, default_out
    from .spec import load_campaign
    from .trials import display_path, resolve, write_scenario
    c = load_campaign(args.file)
    if args.trial is None:
        print(f"campaign {c.name}: {c.trials} trials, seed {c.seed}, keep_worst {c.keep_worst}, "
              f"trial_timeout_s {c.trial_timeout_s:g}")
        if c.description:
            print(f"  {c.description}")
        for k, d in c.values.items():
            print(f"  {k:>28} = {d.describe()}")
        for i, ev in enumerate(c.events):
            print(f"  event {i}: " + ", ".join(f"{k} = {d.describe()}" for k, d in ev.fields.items()))
        for name, cr in c.criteria.items():
            print(f"  criterion {name}: {cr.expr}")
        return 0
    try:
        t = resolve(c, args.trial)
    except IndexError as e:
        raise CampaignCliError(str(e)) from None
    folder = Path(args.out) if args.out else default_out(c)
    scen = write_scenario(t, folder / SCENARIOS_DIR)
    cmd = t.command(display_path(scen) if scen else None)
    if args.json:
        print(json.dumps({"trial": t.index, "seed": t.seed, "inputs": t.inputs, "command": cmd,
                          "error": t.error}, indent=2, sort_keys=True))
        return 0
    print(f"trial {t.index} of {c.name}: seed {t.seed}")
    for k, v in t.inputs.items():
        print(f"  {k:>28} = {v!r}")
    if t.error:
        print(f"  error: {t.error}")
    if scen:
        print(f"  scenario file: {display_path(scen)}")
    print(cmd)
    return 0


def _run(args) -> int:
    from .execute import run_campaign
    from .report import pass_summary
    from .spec import load_campaign
    from .store import Store
    c = load_campaign(args.file)
    if args.trials is not None and args.trials < 1:
        raise CampaignCliError("--trials: a positive number")
    res = run_campaign(c, Path(args.out) if args.out else None, workers=args.workers,
                       scheduler=args.scheduler, trials=args.trials, progress=not args.quiet)
    if res.get("wall_s"):
        print(f"sitl campaign: ran {res['ran']} trials in {res['wall_s']:.1f} s on {res['threads']} "
              f"threads: {res['sim_per_wall']:.1f} simulated s per wall s, "
              f"{res['ran'] / res['wall_s'] * 3600:.0f} trials/h; scheduling and storage "
              f"{100 * res['overhead']:.1f} % of the workers' time (setup {res['setup_s']:.1f} s); the "
              f"trials got {100 * res['trial_cpu_s'] / max(res['trial_wall_s'], 1e-9):.0f} % of a CPU each: "
              f"{res['sim_s'] / max(res['trial_cpu_s'], 1e-9):.1f} simulated s per CPU s",
              file=sys.stderr)
    store = Store(res["folder"], read_only=True)
    try:
        for line in pass_summary(store):
            print(line)
    finally:
        store.close()
    return 0


def _report(args) -> int:
    from .report import make_report
    print(make_report(Path(args.dir)))
    return 0


def _export(args) -> int:
    from .export import export
    print(export(Path(args.dir), args.format, Path(args.output) if args.output else None))
    return 0
