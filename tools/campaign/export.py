"""``sitl campaign export DIR --format parquet|csv``: one row per stored trial.

Columns: ``trial``, ``seed``, ``passed`` (every criterion held, and no error),
``error`` (empty when none), ``wall_s``, ``cpu_s``, ``sim_s``, ``worker``, ``command``, then one
column per criterion (``criterion.NAME``), per flattened summary figure (its own name)
and per input (``input.KEY``). DuckDB writes both formats itself (``COPY ... TO``).
"""
from __future__ import annotations

from pathlib import Path

from .store import Store, _q

LEADING = ("trial", "seed", "passed", "error", "wall_s", "cpu_s", "sim_s", "worker", "command")
LEFT_OUT = ("summary_json", "inputs_json", "criteria_json", "version", "finished")


def export_columns(store: Store) -> list[str]:
    cols = store.columns()
    crit = [c for c in cols if c.startswith("criterion.")]
    inputs = [c for c in cols if c.startswith("input.")]
    figures = [c for c in cols if c not in LEADING and c not in LEFT_OUT and c not in crit and c not in inputs]
    return list(LEADING) + crit + figures + inputs


def export(folder: Path, fmt: str, out: Path | None = None) -> Path:
    store = Store(folder, read_only=True)
    try:
        out = Path(out) if out is not None else Path(folder) / f"trials.{fmt}"
        cols = []
        for c in export_columns(store):
            if c == "passed":
                cols.append('coalesce(passed AND error = \'\', false) AS passed')
            else:
                cols.append(_q(c))
        option = "(FORMAT PARQUET)" if fmt == "parquet" else "(FORMAT CSV, HEADER)"
        path_sql = str(out).replace("'", "''")
        store.db.execute(f"COPY (SELECT {', '.join(cols)} FROM trials ORDER BY trial) TO '{path_sql}' {option}")
    finally:
        store.close()
    return out
