"""A simple battery for the plant: a LiPo pack drained by the propulsion power.

    P = P_idle + P_max * u / eta         (u: throttle 0..1, or the mean motor command)
    I = P / V,   V = n_cells * ocv(soc) - I * R_int
    soc -= I dt / capacity

ocv(soc) is a per-cell open-circuit voltage curve (3.3 V empty, 4.2 V full, the flat
middle of a LiPo). Reported to the autopilot as BATTERY_STATUS over the HIL link (1 Hz);
the autopilot forwards it to the ground stations (BATTERY_STATUS, SYS_STATUS).
"""
from __future__ import annotations

import math


class Battery:
    def __init__(self, cells: int = 6, capacity_ah: float = 16.0, max_power_w: float = 1000.0,
                 idle_power_w: float = 8.0, efficiency: float = 0.8, r_int_ohm: float = 0.03):
        self.cells = cells
        self.capacity_ah = capacity_ah
        self.max_power_w = max_power_w
        self.idle_power_w = idle_power_w
        self.efficiency = efficiency
        self.r_int_ohm = r_int_ohm
        self.soc = 1.0                 # state of charge 0..1
        self.consumed_mah = 0.0
        self.energy_j = 0.0
        self.current_a = 0.0
        self.voltage_v = self.open_circuit_v()

    def open_circuit_v(self) -> float:
        s = min(max(self.soc, 0.0), 1.0)
        cell = 3.3 + 0.6 * s + 0.3 * s ** 6 - 0.25 * math.exp(-25.0 * s) + 0.25 * math.exp(-25.0)
        return self.cells * cell

    def update(self, u: float, dt_s: float) -> None:
        u = min(max(u, 0.0), 1.0)
        power = self.idle_power_w + self.max_power_w * u / self.efficiency
        ocv = self.open_circuit_v()
        self.current_a = power / max(ocv, 1.0)
        self.voltage_v = max(ocv - self.current_a * self.r_int_ohm, 0.0)
        used_ah = self.current_a * dt_s / 3600.0
        self.consumed_mah += used_ah * 1000.0
        self.energy_j += self.voltage_v * self.current_a * dt_s
        self.soc = max(self.soc - used_ah / self.capacity_ah, 0.0)

    @property
    def remaining_pct(self) -> int:
        return int(round(100.0 * self.soc))
