"""Stop 39's navigation room: the innovation log keeps the records as they come (one
``extend`` per fusion) and works out its rows when the columns are asked for
(autopilot/nav/records.py)."""
from __future__ import annotations

import math

import numpy as np

from autopilot.nav.records import SOURCES, InnovationLog, InnovationRecord


def _rows_written_out(records) -> list[tuple]:
    """The log's rows by their definition (InnovationLog's docstring)."""
    rows = []
    for r in records:
        src = float(SOURCES.index(r.source)) if r.source in SOURCES else -1.0
        for k, (y, s, tr) in enumerate(zip(r.innovation, r.innovation_variance, r.test_ratio)):
            sd = math.sqrt(s) if s > 0.0 else 0.0
            gate = abs(y) / (sd * math.sqrt(tr)) if sd > 0.0 and tr > 0.0 else math.nan
            rows.append((r.t_us * 1e-6, src, float(k), y, sd, gate, 1.0 if r.rejected else 0.0))
    return rows


def test_the_columns_are_every_record_added_so_far_row_by_row():
    # GIVEN records of several sources, a zero variance and a zero ratio among them
    recs = [InnovationRecord.make(1_000_000, "gps_pos", (1.0, 2.0, 3.0), (0.3, -0.2, 0.1),
                                  (0.25, 0.25, 0.04), (0.0144, 0.0064, 0.01), False, True),
            InnovationRecord.make(1_040_000, "baro", (100.0,), (-0.5,), (0.0,), (0.0,), False, True),
            InnovationRecord.make(1_040_000, "airspeed", (20.0,), (4.0,), (1.0,), (1.6,), True, False),
            InnovationRecord.make(1_080_000, "unknown", (0.0,), (0.1,), (0.01,), (0.0,), False, True)]
    log = InnovationLog()
    # WHEN they are added in two fusions, the columns asked for between and after
    log.add(recs[:2])
    first = log.arrays()
    log.add(recs[2:])
    a = log.arrays()
    # THEN each time one row per component of every record so far, as defined
    assert len(first["innov_t_s"]) == 4
    want = np.array(_rows_written_out(recs))
    got = np.column_stack([a[c] for c in InnovationLog.COLUMNS])
    assert got.shape == (6, 7)
    assert np.array_equal(got, want, equal_nan=True)
    assert np.isnan(a["innov_gate"][3]) and a["innov_sd"][3] == 0.0      # baro: S = 0
    assert a["innov_source"][5] == -1.0 and a["innov_rejected"].tolist() == [0, 0, 0, 0, 1, 0]


def test_an_empty_log_has_empty_columns():
    a = InnovationLog().arrays()
    assert set(a) == set(InnovationLog.COLUMNS) and all(len(v) == 0 for v in a.values())
