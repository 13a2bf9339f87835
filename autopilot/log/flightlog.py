"""Columnar flight log: one row per loop step, saved as a NumPy ``.npz``.

Columns are declared once (name, unit/frame) and each step appends a tuple of numbers in
that order (floats, and ints or bools where a column holds a count, a code or a flag);
``save`` writes one float64 array per column plus a ``columns`` index, so
``np.load(path)["truth_n_m"]`` reads a column back. Appending tuples to a list is the
cheapest thing Python can do per step; conversion happens once, at the end (a
``float()`` per flag and count in the row cost more than the rest of its building).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np


class FlightLog:
    def __init__(self, columns: tuple[str, ...]):
        self.columns = tuple(columns)
        self.rows: list[tuple] = []
        # append(row): the list's own append (a method around it cost a Python call a row)
        self.append = self.rows.append
        self.events: list[tuple[float, str]] = []   # (t_s, text) for notable events

    def event(self, t_s: float, text: str) -> None:
        self.events.append((t_s, text))

    def arrays(self) -> dict[str, np.ndarray]:
        if not self.rows:
            return {c: np.zeros(0) for c in self.columns}
        if len(self.rows[0]) != len(self.columns):
            raise ValueError(f"flight log rows have {len(self.rows[0])} values for "
                             f"{len(self.columns)} columns")
        data = np.asarray(self.rows, dtype=float)
        return {c: data[:, i] for i, c in enumerate(self.columns)}

    def save(self, path: str | Path, extra: dict | None = None) -> None:
        arrays = self.arrays()
        arrays["columns"] = np.array(self.columns)
        arrays["event_t_s"] = np.array([e[0] for e in self.events], dtype=float)
        arrays["event_text"] = np.array([e[1] for e in self.events], dtype=str)
        for k, v in (extra or {}).items():
            arrays[k] = np.asarray(v)
        with open(path, "wb") as f:
            np.savez_compressed(f, **arrays)


class RowSchedule:
    """Which lockstep steps get a flight-log row.

    Rows are due every ``div``-th step (steps counted from 1). Truth
    (HIL_STATE_QUATERNION) is what the rows are for, and the simulator may send it only
    on some steps (``sim_bridge``: every ``div``-th step and with every HIL_GPS): while
    truth is arriving (seen within the last ``div`` steps), a row is taken only on a
    step that has truth, so a due row waits for the next truth, and every step that
    brings truth with a GPS fix gets a row (the fix is scored against truth at its own
    time). When no truth comes at all (another simulator), rows follow the step count
    alone and a fix goes with the next row.

    ``take(step, truth, gps) -> bool``, called once per step; ``div`` may be changed
    between steps (a parameter)."""

    __slots__ = ("div", "_next", "_truth_step")

    def __init__(self, div: int):
        self.div = max(1, int(div))
        self._next = self.div
        self._truth_step: int | None = None

    def take(self, step: int, truth: bool, gps: bool) -> bool:
        div = self.div
        if truth:
            self._truth_step = step
        elif self._truth_step is not None and step - self._truth_step <= div:
            return False                      # truth is paced by the simulator: wait for it
        due = step >= self._next
        if due:
            # the next due step on the lattice of multiples of div after this one
            self._next = (step // div + 1) * div
        return due or (gps and truth)
