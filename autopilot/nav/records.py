"""The innovation record every aiding source of the navigation filters produces.

One record per fused (or gated-out) measurement, the same shape for every source, as
PX4's ``EstimatorAidSource`` messages: what was observed, the innovation ``y = z - h(x)``,
its variance ``S`` (diagonal of ``H P H^T + R``), the test ratio against the gate and
whether the measurement was rejected and whether it changed the state. The fault
monitor and the ground-station streams read these, element by element: the vectors are
tuples of floats (about one record a step; four array views cost more than the record).

Sources: ``gps_pos`` (NED position, m), ``gps_vel`` (NED velocity, m/s), ``baro``
(altitude, m, up positive), ``mag`` (heading, rad), ``airspeed`` (true airspeed, m/s),
``sideslip`` (synthetic zero body-y air velocity, m/s; fixed-wing), ``fake_pos``
(position hold before the first GPS fix, m).
"""
from __future__ import annotations

import numpy as np

from autopilot.frozen import message

SOURCES = ("gps_pos", "gps_vel", "baro", "mag", "airspeed", "sideslip", "fake_pos")


@message
class InnovationRecord:
    t_us: int                          # filter time of the update [us]
    source: str                        # one of SOURCES
    observation: tuple[float, ...]          # z, in the source's unit (see module docstring)
    innovation: tuple[float, ...]           # y = z - h(x) [same unit]
    innovation_variance: tuple[float, ...]  # diag(S) = diag(H P H^T + R) [unit^2]
    test_ratio: tuple[float, ...]           # y^2 / (gate^2 * S) per component; > 1 fails
    rejected: bool                     # the gate test failed (any component > 1)
    fused: bool                        # the measurement changed the state (fusion or reset)


class InnovationLog:
    """Every innovation record of a flight as columns, one row per component (for the
    flight log and ``sitl report``'s innovations picture): time [s], source index in
    SOURCES, component, innovation, its standard deviation sqrt(S), the gate in standard
    deviations (from the test ratio: y^2 / (gate^2 S)), rejected."""

    COLUMNS = ("innov_t_s", "innov_source", "innov_comp", "innov_value", "innov_sd",
               "innov_gate", "innov_rejected")
    _INDEX = {name: i for i, name in enumerate(SOURCES)}

    def __init__(self):
        # the records as they come (a fusion's add is one extend); their rows are worked
        # out once, when the columns are asked for (the end of a flight)
        self._records: list[InnovationRecord] = []
        self.add = self._records.extend      # add(records): the list's own (no call around it)

    def _rows(self) -> list[tuple]:
        rows = []
        index = self._INDEX
        for r in self._records:
            src = float(index.get(r.source, -1))
            rej = 1.0 if r.rejected else 0.0
            t = r.t_us * 1e-6
            for k, (y, s, tr) in enumerate(zip(r.innovation, r.innovation_variance, r.test_ratio)):
                sd = s ** 0.5 if s > 0.0 else 0.0
                gate = abs(y) / (sd * tr ** 0.5) if sd > 0.0 and tr > 0.0 else float("nan")
                rows.append((t, src, float(k), y, sd, gate, rej))
        return rows

    def arrays(self) -> dict:
        a = np.array(self._rows(), dtype=float).reshape(-1, len(self.COLUMNS))
        return {c: a[:, i] for i, c in enumerate(self.COLUMNS)}
