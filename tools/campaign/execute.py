"""Running a campaign on Dask distributed: the trial on a worker, the driver that feeds
the workers and stores every result as it arrives.

The worker side (``run_trial``) builds the run from the trial's ``sitl run`` arguments
with the parser and configuration code of ``sitl run`` itself, flies it in-process,
computes the summary and the criteria, and writes the run folder only when the trial is
kept (failed, an error, or among the worst so far of a key figure). A trial that raises,
or runs past its wall-time limit, comes back as an error row with its traceback.

The driver (``run_campaign``) starts a ``distributed.LocalCluster`` (one single-threaded
worker process per core) or connects to a running scheduler, refuses workers that run
another version of the package (a hash of the package's sources), submits the missing
trials a few at a time (so the keep thresholds it sends are current), and commits each
result to the store as it completes. Dask itself runs again elsewhere the trials of a
worker that dies; a trial that kills workers over and over (Dask's KilledWorker) is an
error row.
"""
from __future__ import annotations

import hashlib
import logging
import os
import sys
import tempfile
import time
import traceback
import warnings
from datetime import datetime, timezone
from pathlib import Path

from autopilot.interrupt import StopOnInterrupt

from .spec import Campaign
from .store import Store
from .trials import Trial, display_path, resolve, run_argv, write_scenario

RUNS_DIR = "runs"
SCENARIOS_DIR = "scenarios"


class CampaignRunError(RuntimeError):
    pass


class VersionMismatch(RuntimeError):
    pass


class TrialTimeout(RuntimeError):
    pass


class TrialInterrupted(RuntimeError):
    """The flight stopped on Ctrl-C before its end (``Session.run`` stops quietly): it
    is incomplete, so the trial is not stored and a rerun flies it again."""


class DriverInterrupt(StopOnInterrupt):
    """Ctrl-C for the campaign driver (``with DriverInterrupt() as ctrl_c``), installed
    as the flight loops' :class:`StopOnInterrupt` is (main thread, Python's default
    handler).

    SIGINT raises ``KeyboardInterrupt`` only while the driver waits for a trial's result
    (``waiting``). Anywhere else it is held and raised at the next wait
    (``raise_if_requested``): a ``KeyboardInterrupt`` landing in a store's insert comes out
    of DuckDB as ``RuntimeError: Query interrupted``, an error with a traceback, and one
    landing in the closing of the local cluster left the cluster to Python's exit
    handlers (one was seen still waiting for it after 7 s). Once the driver is closing
    (``closing``), a Ctrl-C is only noted, and a second one ends the process at once (its
    worker processes end with it)."""

    def __init__(self) -> None:
        super().__init__()
        self.waiting = False
        self.closing = False

    def _handler(self, signum, frame) -> None:
        if self.closing and self.requested:
            os.write(2, b"sitl campaign: interrupted again; stopping now\n")
            os._exit(130)
        self.requested = True
        if self.waiting:
            self.waiting = False
            raise KeyboardInterrupt

    def raise_if_requested(self) -> None:
        if self.requested:
            raise KeyboardInterrupt


# --- the package's version -------------------------------------------------------------
_VERSION: str | None = None


def package_version() -> str:
    """``pysitl <version>+<hash of the package sources>``: two processes with the same
    string fly the same code."""
    global _VERSION
    if _VERSION is None:
        from tools.runner import REPO_ROOT
        h = hashlib.sha256()
        for pkg in ("autopilot", "sim_bridge", "tools"):
            for p in sorted((REPO_ROOT / pkg).rglob("*")):
                if p.is_file() and p.suffix in (".py", ".xml", ".toml", ".parm") \
                        and "__pycache__" not in p.parts:
                    h.update(str(p.relative_to(REPO_ROOT)).encode())
                    h.update(p.read_bytes())
        try:
            from importlib.metadata import version
            v = version("pysitl")
        except Exception:
            v = "0"
        _VERSION = f"pysitl {v}+{h.hexdigest()[:12]}"
    return _VERSION


def worker_info() -> dict:
    """Run on every worker before the campaign starts: the version it runs, and the
    heavy imports done (so the first trial's wall time is the trial's)."""
    import tools.runner  # noqa: F401
    import tools.summary  # noqa: F401
    import tools.sitl  # noqa: F401
    from tools.runner import REPO_ROOT
    return {"version": package_version(), "path": str(REPO_ROOT), "pid": os.getpid()}


# --- the worker side ------------------------------------------------------------------

def build_session(argv: list[str]):
    """The session ``sitl run ARGV`` would fly (tools/sitl.py's own parser and
    configuration), headless, without a run folder."""
    from tools.runner import Session
    from tools.sitl import CliError, _config, _join_signed_values, build_parser
    try:
        args = build_parser().parse_args(_join_signed_values(["run", *argv]))
    except SystemExit:
        raise ValueError(f"sitl run does not accept: {' '.join(argv)}") from None
    try:
        cfg = _config(args)
    except CliError as e:
        raise ValueError(str(e)) from None
    cfg.progress = False
    cfg.log_dir = None
    return Session(cfg)


def _limit_wall(session, limit_s: float) -> None:
    """Make ``session.run()`` raise TrialTimeout once it has run ``limit_s`` wall
    seconds (checked every 1000 steps)."""
    step = session.step
    deadline = time.perf_counter() + limit_s
    n = [0]

    def limited_step():
        step()
        n[0] += 1
        if n[0] % 1000 == 0 and time.perf_counter() > deadline:
            raise TrialTimeout(f"the trial ran past its wall-time limit of {limit_s:g} s "
                               f"(at {session.t_s:.1f} simulated s)")
    session.step = limited_step


def _worse(v: float, thr: float | None, sign: float) -> bool:
    return thr is None or sign * v >= sign * thr


def run_trial(task: dict) -> dict:
    """Fly one trial (a task of ``run_campaign``); always returns a row, errors
    included, except for a worker of another version (VersionMismatch)."""
    from tools.runner import write_run
    from tools.summary import run_summary
    from .criteria import flatten, parse_criterion

    here = package_version()
    if task["version"] != here:
        raise VersionMismatch(f"worker pid {os.getpid()} runs {here}, the campaign {task['version']}")
    t0, c0 = time.perf_counter(), time.process_time()
    row = {"trial": task["trial"], "seed": task["seed"], "inputs": task["inputs"],
           "command": task["command"], "version": here, "worker": _worker_name(),
           "summary": None, "flat": None, "criteria": {}, "passed": None, "error": "", "sim_s": None,
           "kept": False}
    try:
        with tempfile.TemporaryDirectory(prefix="sitl-trial-") as td:
            scenario = None
            if task["scenario_text"] is not None:
                scenario = Path(td) / "scenario.toml"
                scenario.write_text(task["scenario_text"])
            argv = list(task["argv"]) + (["--scenario", str(scenario)] if scenario else [])
            session = build_session(argv)
            _limit_wall(session, task["timeout_s"])
            try:
                session.run()
            finally:
                session.close()
            if session.interrupted:       # Session.run stops quietly on Ctrl-C
                raise TrialInterrupted(f"trial {task['trial']} interrupted at {session.t_s:.1f} s")
            summary = run_summary(session)
            flat = flatten(summary)
            known = {**flat, **{f"input.{k}": v for k, v in task["inputs"].items()}}
            crits = {}
            for name, expr in task["criteria"].items():
                crits[name] = parse_criterion(name, expr, "<campaign>", None).holds(known)
            passed = all(crits.values())
            row.update(summary=summary, flat=flat, criteria=crits, passed=passed,
                       sim_s=float(summary.get("sim_time_s") or 0.0))
            keep = not passed
            for fig, (thr, sign) in task["thresholds"].items():
                v = flat.get(fig)
                if isinstance(v, (int, float)) and not isinstance(v, bool) and _worse(v, thr, sign):
                    keep = True
            if keep and task["log_dir"]:
                log_dir = Path(task["log_dir"])
                write_run(session, summary, log_dir)
                if scenario is not None:
                    (log_dir / "scenario.toml").write_text(task["scenario_text"])
                row["kept"] = True
    except TrialInterrupted:
        raise
    except TrialTimeout as e:
        row["error"] = f"TrialTimeout: {e}"
    except Exception:
        row["error"] = traceback.format_exc()
    row["wall_s"] = time.perf_counter() - t0
    row["cpu_s"] = time.process_time() - c0     # the worker's CPU time: wall minus contention
    return row


def _worker_name() -> str:
    try:
        from distributed import get_worker
        return f"{get_worker().address} pid {os.getpid()}"
    except Exception:
        return f"local pid {os.getpid()}"


# --- the driver -----------------------------------------------------------------------

class Progress:
    """done / passed / failed / errors, trials per minute, ETA; one line redrawn on a
    terminal; otherwise a line per trial for up to 100 trials, else at most one every
    ``every_s``."""

    def __init__(self, total: int, already: int, stream=sys.stderr, every_s: float = 1.0,
                 counts: tuple[int, int, int] = (0, 0, 0)):
        self.total, self.already = total, already
        self.done = already
        self.passed, self.failed, self.errors = counts
        self.stream = stream
        self.tty = stream.isatty()
        self.t0 = time.perf_counter()
        self.every_s = every_s
        self.last = 0.0

    def add(self, row: dict) -> None:
        self.done += 1
        if row.get("error"):
            self.errors += 1
        elif row.get("passed"):
            self.passed += 1
        else:
            self.failed += 1
        self.show()

    def line(self) -> str:
        dt = time.perf_counter() - self.t0
        new = self.done - self.already
        rate = new / dt * 60.0 if dt > 0 and new else 0.0
        left = self.total - self.done
        eta = f"{left / rate:.1f} min" if rate > 0 else "?"
        width = 24
        bar = "#" * int(width * self.done / max(self.total, 1))
        return (f"[{bar:<{width}}] {self.done}/{self.total} done  passed {self.passed}  failed "
                f"{self.failed}  errors {self.errors}  {rate:.1f} trials/min  ETA {eta}")

    def show(self, force: bool = False) -> None:
        now = time.perf_counter()
        if self.tty:
            self.stream.write("\r" + self.line())
        elif force or self.total <= 100 or now - self.last >= self.every_s or self.done == self.total:
            self.stream.write(self.line() + "\n")
            self.last = now
        else:
            return
        self.stream.flush()

    def end(self) -> None:
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()


class _Keeper:
    """Which trials keep their run folder: failed and error trials, and the
    ``keep_worst`` worst of each key figure (``-name``: the lowest)."""

    def __init__(self, figures: list[tuple[str, float]], n: int, folder: Path, rows: list[dict]):
        self.figures, self.n, self.folder = figures, n, folder
        self.values = {f: [] for f, _ in figures}       # (sign * value, trial)
        self.failed: set[int] = set()
        self.stored: set[int] = set()
        for r in rows:
            self.add(r)

    def add(self, row: dict) -> None:
        self.stored.add(row["trial"])
        if row.get("error") or not row.get("passed"):
            self.failed.add(row["trial"])
        flat = row.get("flat") or {}
        for f, sign in self.figures:
            v = flat.get(f)
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                self.values[f].append((sign * v, row["trial"]))

    def thresholds(self) -> dict:
        out = {}
        for f, sign in self.figures:
            vals = sorted(self.values[f], reverse=True)
            out[f] = (sign * vals[self.n - 1][0] if len(vals) >= self.n else None, sign) if self.n else \
                (float("inf") * sign, sign)
        return out

    def keep_set(self) -> set[int]:
        keep = set(self.failed)
        for f, _ in self.figures:
            keep |= {t for _, t in sorted(self.values[f], reverse=True)[:self.n]}
        return keep

    def prune(self) -> None:
        """Remove the run folders of stored trials that are no longer kept (never of a
        trial still running: its worker may be writing it)."""
        runs = self.folder / RUNS_DIR
        if not runs.is_dir():
            return
        keep = self.keep_set()
        import shutil
        for p in runs.iterdir():
            if p.name.startswith("trial_") and p.name[6:].isdigit() and int(p.name[6:]) in self.stored \
                    and int(p.name[6:]) not in keep:
                shutil.rmtree(p, ignore_errors=True)


def key_figures(c: Campaign) -> list[tuple[str, float]]:
    """(name, sign): sign +1 when high values are bad, -1 when low values are (a
    ``-name`` in ``figures``). Default: the keys the criteria name."""
    if c.figures:
        return [(f.lstrip("-"), -1.0 if f.startswith("-") else 1.0) for f in c.figures]
    out = []
    for crit in c.criteria.values():
        for k in crit.keys:
            if (k, 1.0) not in out:
                out.append((k, 1.0))
    return out


def trial_task(c: Campaign, t: Trial, folder: Path, version: str, thresholds: dict) -> dict:
    scen = folder / SCENARIOS_DIR / f"trial_{t.index:05d}.scenario.toml"
    return {"trial": t.index, "seed": t.seed, "inputs": t.inputs, "argv": run_argv(t),
            "scenario_text": t.scenario_text, "command": t.command(display_path(scen)),
            "criteria": {n: cr.expr for n, cr in c.criteria.items()}, "timeout_s": c.trial_timeout_s,
            "version": version, "thresholds": thresholds,
            "log_dir": str((folder / RUNS_DIR / f"trial_{t.index:05d}").resolve())}


def _error_row(c: Campaign, t: Trial, folder: Path, error: str, version: str) -> dict:
    scen = folder / SCENARIOS_DIR / f"trial_{t.index:05d}.scenario.toml"
    return {"trial": t.index, "seed": t.seed, "inputs": t.inputs, "command": t.command(display_path(scen)),
            "version": version, "worker": None, "summary": None, "flat": None, "criteria": {},
            "passed": None, "error": error, "wall_s": 0.0, "sim_s": None}


def default_out(c: Campaign) -> Path:
    return Path("campaigns") / c.name


def run_campaign(c: Campaign, out: Path | None = None, workers: int | None = None,
                 scheduler: str | None = None, trials: int | None = None, progress: bool = True,
                 client=None, stream=sys.stderr) -> dict:
    """Run the trials of ``c`` not yet stored in ``out`` (the first ``trials`` of the
    file only, if given); returns the figures of this run."""
    folder = Path(out) if out is not None else default_out(c)
    n_total = c.trials if trials is None else min(trials, c.trials)
    with DriverInterrupt() as ctrl_c:
        store = Store(folder)
        try:
            store.bind(c.text, c.path, c.trials)
            done = store.stored()
            todo = [i for i in range(n_total) if i not in done]
            already = sum(1 for i in done if i < n_total)
            if not todo:
                print(f"sitl campaign: {folder}: all {n_total} trials stored", file=stream)
                return {"ran": 0, "stored": store.count(), "folder": folder}
            keeper = _Keeper(key_figures(c), c.keep_worst, folder, [])
            for r in store.rows():
                flat = {}
                if r.get("summary_json"):
                    from .criteria import flatten
                    import json
                    flat = flatten(json.loads(r["summary_json"]))
                keeper.add({"trial": r["trial"], "error": r["error"], "passed": r["passed"], "flat": flat})
            return _drive(c, folder, store, todo, n_total, already, keeper, workers, scheduler, progress,
                          client, stream, ctrl_c)
        finally:
            ctrl_c.closing = True
            store.close()


def _drive(c, folder, store, todo, n_total, already, keeper, workers, scheduler, progress,
           client, stream, ctrl_c: DriverInterrupt) -> dict:
    from distributed import Client, LocalCluster, as_completed
    from distributed.client import FutureCancelledError
    try:
        from distributed.scheduler import KilledWorker
    except ImportError:  # pragma: no cover
        from distributed import KilledWorker
    version = package_version()
    cluster = None
    own_client = client is None
    t_start = time.perf_counter()
    if client is None:
        if scheduler:
            try:
                client = Client(scheduler, timeout=20)
            except (OSError, TimeoutError) as e:
                raise CampaignRunError(f"--scheduler {scheduler}: cannot connect ({e})") from None
        else:
            n = workers or os.cpu_count() or 1
            # The workers leave Ctrl-C to the driver (worker_setup.py). Dask's own logs are
            # kept to its critical ones: a trial's error is stored with its row, and a worker
            # closed while it flies a trial logs a failed heartbeat as an error
            # (without a dashboard, Dask's scheduler still serves HTTP, on 8787 if free, and
            # warned that the port was taken when another cluster had it)
            with warnings.catch_warnings():
                warnings.filterwarnings("ignore", message="Port .* is already in use")
                cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=logging.CRITICAL,
                                       preload=["tools.campaign.worker_setup"])
            client = Client(cluster)
    try:
        info = client.run(worker_info)
        if not info:
            raise CampaignRunError(f"no worker connected to {client.scheduler.address}")
        bad = {a: i for a, i in info.items() if i["version"] != version}
        if bad:
            raise CampaignRunError(
                "refusing workers that run another version of pysitl than this driver "
                f"({version}): " + "; ".join(f"{a} runs {i['version']} from {i['path']}"
                                              for a, i in bad.items()))
        threads = sum(client.nthreads().values())
        t_setup = time.perf_counter() - t_start
        counts = store.db.execute(
            "SELECT count(*) FILTER (WHERE error = '' AND passed), count(*) FILTER (WHERE error = '' "
            "AND NOT passed), count(*) FILTER (WHERE error <> '') FROM trials WHERE trial < ?",
            [n_total]).fetchone()
        bar = Progress(n_total, already, stream, counts=tuple(counts)) if progress else None
        if bar is not None:
            print(f"sitl campaign: {c.name}: {len(todo)} trials to run ({already} stored) on "
                  f"{len(info)} workers ({threads} threads); results in {folder}", file=stream)
        pending = iter(todo)
        ac = as_completed()
        window = max(2 * threads, 2)
        futures = {}
        t0 = time.perf_counter()
        ran = 0
        trial_wall = trial_cpu = sim_s = 0.0

        def submit_next() -> bool:
            for i in pending:
                t = resolve(c, i)
                write_scenario(t, folder / SCENARIOS_DIR)
                if t.error:
                    _store(_error_row(c, t, folder, t.error, version))
                    continue
                submit(t)
                return True
            return False

        def submit(t: Trial) -> None:
            task = trial_task(c, t, folder, version, keeper.thresholds())
            f = client.submit(run_trial, task, pure=False, key=f"sitl-trial-{t.index}-{os.urandom(4).hex()}")
            futures[f] = t
            ac.add(f)

        def _store(row: dict) -> None:
            nonlocal ran, trial_wall, trial_cpu, sim_s
            row["finished"] = datetime.now(timezone.utc).replace(tzinfo=None)
            if store.insert(row):
                ran += 1
                trial_wall += row.get("wall_s") or 0.0
                trial_cpu += row.get("cpu_s") or 0.0
                sim_s += row.get("sim_s") or 0.0
                keeper.add(row)
                if row.get("kept") or row.get("error") or not row.get("passed"):
                    keeper.prune()
                if bar is not None:
                    bar.add(row)

        def interrupted() -> None:
            if bar is not None:
                bar.end()
            left = n_total - sum(1 for i in store.stored() if i < n_total)
            print(f"sitl campaign: interrupted; {store.count()} trials stored in {folder}"
                  + (f"; the same command resumes the {left} missing" if left else ""), file=stream)

        try:
            ctrl_c.raise_if_requested()           # a Ctrl-C while the cluster started
            for _ in range(window):
                if not submit_next():
                    break
            results = iter(ac)
            while True:
                ctrl_c.raise_if_requested()       # one held while a row was stored
                ctrl_c.waiting = True
                try:
                    f = next(results)
                except StopIteration:
                    break
                finally:
                    ctrl_c.waiting = False
                t = futures.pop(f)
                try:
                    row = f.result()
                except VersionMismatch as e:
                    raise CampaignRunError(f"refusing a worker of another version: {e}") from None
                except TrialInterrupted:
                    submit(t)             # not stored: flown again
                    continue
                except (KilledWorker, FutureCancelledError) as e:
                    row = _error_row(c, t, folder, f"{type(e).__name__}: {e}", version)
                except Exception:
                    row = _error_row(c, t, folder, traceback.format_exc(), version)
                _store(row)
                submit_next()
        except KeyboardInterrupt:
            ctrl_c.requested = ctrl_c.closing = True
            for f in list(futures):
                f.cancel()
            interrupted()
            raise
        wall = time.perf_counter() - t0
        if bar is not None:
            bar.end()
        store.add_run(started=datetime.now(timezone.utc).replace(tzinfo=None), wall_s=wall,
                      workers=len(info), threads=threads, trials=ran, trial_wall_s=trial_wall,
                      trial_cpu_s=trial_cpu,
                      sim_s=sim_s, scheduler=scheduler or "LocalCluster", version=version)
        overhead = 1.0 - trial_wall / (wall * threads) if wall > 0 and threads else None
        result = {"ran": ran, "stored": store.count(), "folder": folder, "wall_s": wall,
                  "setup_s": t_setup, "trial_wall_s": trial_wall, "trial_cpu_s": trial_cpu,
                  "sim_s": sim_s, "threads": threads, "workers": len(info),
                  "sim_per_wall": sim_s / wall if wall > 0 else None, "overhead": overhead}
    finally:
        ctrl_c.closing = True     # from here a Ctrl-C is noted; a second one ends the process
        # bounded: after a Ctrl-C the workers may already be gone, and the driver must
        # still end (the same command resumes what is missing)
        try:
            if own_client:
                client.close(timeout=20)
            if cluster is not None:
                cluster.close(timeout=30)
        except Exception as e:                # noqa: BLE001 - closing only; the trials are stored
            print(f"sitl campaign: closing the cluster: {type(e).__name__}: {e}", file=stream)
    if ctrl_c.requested:          # a Ctrl-C after the last trial, while closing
        print(f"sitl campaign: interrupted; {store.count()} trials stored in {folder}", file=stream)
        raise KeyboardInterrupt
    return result
