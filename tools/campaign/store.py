"""The campaign folder's DuckDB file: one row per trial, committed as each one finishes.

``trials`` has fixed columns (trial, seed, passed, error, wall_s, sim_s, worker,
version, finished, command, the full summary / inputs / criteria as JSON) and one column
per flattened summary key (its own name), per input (``input.KEY``) and per criterion
(``criterion.NAME``), added as they first appear. ``trial`` is the primary key and a
row is only ever inserted (``ON CONFLICT DO NOTHING``), never updated: a trial is stored
once, and a rerun of the campaign runs the indices that are missing. ``meta`` holds the
campaign file's text (a rerun with another file is refused); ``runs`` one row per
``sitl campaign run`` (its wall time and workers: the throughput figures).

Only the driver opens the file (DuckDB takes a lock on it: a second driver on the same
folder is refused), and commits after every trial: DuckDB's write-ahead log makes a
committed row survive a ``kill -9`` of the driver.
"""
from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

DB_NAME = "campaign.duckdb"
FIXED = {"trial": "INTEGER PRIMARY KEY", "seed": "BIGINT", "passed": "BOOLEAN", "error": "VARCHAR",
         "wall_s": "DOUBLE", "cpu_s": "DOUBLE", "sim_s": "DOUBLE", "worker": "VARCHAR", "version": "VARCHAR",
         "finished": "TIMESTAMP", "command": "VARCHAR", "summary_json": "VARCHAR",
         "inputs_json": "VARCHAR", "criteria_json": "VARCHAR"}


class StoreError(RuntimeError):
    pass


def _q(name: str) -> str:
    return '"' + name.replace('"', '""') + '"'


def _sql_type(v) -> str | None:
    if v is None:
        return None
    if isinstance(v, bool):
        return "BOOLEAN"
    if isinstance(v, (int, float)):
        return "DOUBLE"
    return "VARCHAR"


def text_hash(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class Store:
    def __init__(self, folder: Path, read_only: bool = False):
        import duckdb
        self.folder = Path(folder)
        path = self.folder / DB_NAME
        if read_only and not path.exists():
            raise StoreError(f"{self.folder}: no {DB_NAME} (not a campaign folder)")
        self.folder.mkdir(parents=True, exist_ok=True)
        try:
            self.db = duckdb.connect(str(path), read_only=read_only)
        except duckdb.IOException as e:
            raise StoreError(f"{path}: cannot open ({e}); is another `sitl campaign run` using "
                             f"this folder?") from None
        if not read_only:
            self.db.execute("CREATE TABLE IF NOT EXISTS meta (key VARCHAR PRIMARY KEY, value VARCHAR)")
            cols = ", ".join(f"{_q(k)} {t}" for k, t in FIXED.items())
            self.db.execute(f"CREATE TABLE IF NOT EXISTS trials ({cols})")
            self.db.execute("CREATE TABLE IF NOT EXISTS runs (started TIMESTAMP, wall_s DOUBLE, "
                            "workers INTEGER, threads INTEGER, trials INTEGER, trial_wall_s DOUBLE, "
                            "sim_s DOUBLE, scheduler VARCHAR, version VARCHAR, trial_cpu_s DOUBLE)")
            # folders of an earlier version of this store: the columns added since
            self.db.execute("ALTER TABLE trials ADD COLUMN IF NOT EXISTS cpu_s DOUBLE")
            self.db.execute("ALTER TABLE runs ADD COLUMN IF NOT EXISTS trial_cpu_s DOUBLE")
        self._columns = {r[0]: r[1] for r in self.db.execute(
            "SELECT column_name, data_type FROM information_schema.columns WHERE table_name = 'trials'"
        ).fetchall()}

    def close(self) -> None:
        self.db.close()

    # --- the campaign ---------------------------------------------------------------
    def meta(self) -> dict:
        return dict(self.db.execute("SELECT key, value FROM meta").fetchall())

    def bind(self, campaign_text: str, campaign_path: str, trials: int) -> None:
        """Record the campaign file on the first run; refuse another file later."""
        m = self.meta()
        h = text_hash(campaign_text)
        if "text_hash" in m and m["text_hash"] != h:
            raise StoreError(f"{self.folder} holds the campaign of another file (or an earlier version "
                             f"of {campaign_path}): rerun with that file, or give another --out")
        if "text_hash" not in m:
            self.db.executemany("INSERT INTO meta VALUES (?, ?)",
                                [("text_hash", h), ("campaign_text", campaign_text),
                                 ("campaign_path", str(campaign_path)), ("trials", str(trials))])

    # --- trials ---------------------------------------------------------------------
    def stored(self) -> set[int]:
        return {r[0] for r in self.db.execute("SELECT trial FROM trials").fetchall()}

    def count(self) -> int:
        return self.db.execute("SELECT count(*) FROM trials").fetchone()[0]

    def insert(self, row: dict) -> bool:
        """Insert one trial (fixed columns + ``flat`` summary, ``inputs``,
        ``criteria``) in one transaction; False if the trial is already stored."""
        flat = row.get("flat") or {}
        wide = {}
        for k, v in flat.items():
            if k in FIXED:
                continue
            wide[k] = v
        for k, v in (row.get("inputs") or {}).items():
            wide[f"input.{k}"] = v
        for k, v in (row.get("criteria") or {}).items():
            wide[f"criterion.{k}"] = v
        self.db.execute("BEGIN TRANSACTION")
        try:
            if self.db.execute("SELECT 1 FROM trials WHERE trial = ?", [row["trial"]]).fetchone():
                self.db.execute("ROLLBACK")
                return False
            values = {}
            for k, v in wide.items():
                t = _sql_type(v)
                if isinstance(v, float) and not math.isfinite(v):
                    v = None
                if k not in self._columns:
                    if t is None:
                        continue          # the column gets its type from a real value
                    self.db.execute(f"ALTER TABLE trials ADD COLUMN {_q(k)} {t}")
                    self._columns[k] = t
                col_t = self._columns[k]
                if t is not None and col_t != t and not (col_t == "VARCHAR"):
                    v = None              # a value of another type: kept in summary_json
                elif col_t == "VARCHAR" and v is not None:
                    v = str(v)
                values[k] = v
            fixed = {"trial": row["trial"], "seed": row["seed"], "passed": row.get("passed"),
                     "error": row.get("error") or "", "wall_s": row.get("wall_s"), "cpu_s": row.get("cpu_s"),
                     "sim_s": row.get("sim_s"), "worker": row.get("worker"),
                     "version": row.get("version"), "finished": row.get("finished"),
                     "command": row.get("command"),
                     "summary_json": json.dumps(row.get("summary"), sort_keys=True)
                     if row.get("summary") is not None else None,
                     "inputs_json": json.dumps(row.get("inputs"), sort_keys=True),
                     "criteria_json": json.dumps(row.get("criteria"), sort_keys=True)}
            allv = {**fixed, **values}
            cols = ", ".join(_q(k) for k in allv)
            marks = ", ".join("?" for _ in allv)
            self.db.execute(f"INSERT INTO trials ({cols}) VALUES ({marks}) ON CONFLICT DO NOTHING",
                            list(allv.values()))
            self.db.execute("COMMIT")
        except Exception:
            self.db.execute("ROLLBACK")
            raise
        return True

    def add_run(self, **r) -> None:
        self.db.execute("INSERT INTO runs VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                        [r["started"], r["wall_s"], r["workers"], r["threads"], r["trials"],
                         r["trial_wall_s"], r["sim_s"], r["scheduler"], r["version"], r["trial_cpu_s"]])

    # --- reading --------------------------------------------------------------------
    def columns(self) -> list[str]:
        return [r[0] for r in self.db.execute(
            "SELECT column_name FROM information_schema.columns WHERE table_name = 'trials' "
            "ORDER BY ordinal_position").fetchall()]

    def rows(self, where: str = "", order: str = "trial") -> list[dict]:
        cur = self.db.execute(f"SELECT * FROM trials {where} ORDER BY {order}")
        names = [d[0] for d in cur.description]
        return [dict(zip(names, r)) for r in cur.fetchall()]

    def runs(self) -> list[dict]:
        cur = self.db.execute("SELECT * FROM runs ORDER BY started")
        names = [d[0] for d in cur.description]
        return [dict(zip(names, r)) for r in cur.fetchall()]
