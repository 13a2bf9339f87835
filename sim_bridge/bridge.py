"""The simulator: plant + sensors + faults + scenario events behind the HIL link.

One lockstep step of ``SimBridge``:

1. apply the scenario events that are due (faults, as MAV_CMD_INJECT_FAILURE would);
2. sample the sensors from the plant's truth, pass them through the fault injector, and
   send HIL_GPS / HIL_STATE_QUATERNION / DISTANCE_SENSOR (a rangefinder reading, when
   one is fitted and due) / ESC_TELEMETRY_1_TO_4 (the propeller's rpm, likewise) /
   HIL_SENSOR (``send_current``);
3. wait for the HIL_ACTUATOR_CONTROLS answering this step;
4. pass the controls through the actuator faults and advance the plant by one HIL
   period (``advance``), which is ``substeps`` plant integration steps.

``run_step`` does all four with a blocking wait (two-process mode); an in-process run
calls ``send_current`` / ``advance`` itself and lets the autopilot run in between.
"""
from __future__ import annotations

from dataclasses import dataclass

from autopilot.link.codec import MAV

from .battery import Battery
from .hil import SimulatorHilEnd
from .plants.base import PlaneControls


BATTERY_STEP_US = 100_000    # battery model update period [us]


@dataclass
class FaultRecord:
    at_s: float
    unit: str
    type: str
    instance: int
    accepted: bool
    source: str          # "scenario" | "mavlink"
    held: float | None = None   # a stuck servo's or motor's position (normalised command)


class SimBridge:
    def __init__(self, plant, sensors, link: SimulatorHilEnd, faults=None, events=(),
                 hil_rate_hz: float = 100.0, vehicle: str = "plane", rangefinder=None, rpm=None):
        self.plant = plant
        self.sensors = sensors
        self.rangefinder = rangefinder     # sensors/rangefinder.py, or None (none fitted)
        self.rpm = rpm                     # sensors/rpm.py, or None (no ESC telemetry)
        self.link = link
        self.faults = faults
        self.events = sorted(events, key=lambda e: e.at_s)
        self._next_event = 0
        self.vehicle = vehicle
        self._plane = vehicle == "plane"
        self.hil_period_us = int(round(1e6 / hil_rate_hz))
        self._hil_period_s = self.hil_period_us * 1e-6
        self.substeps = max(1, int(round(self.hil_period_us * 1e-6 / plant.dt_s)))
        self._rotors = len(plant.rotor_scale) if hasattr(plant, "rotor_scale") else 0
        self._rotor_changes = -1           # the injector's actuator_changes at the last scales
        if hasattr(plant, "imu_mean_steps"):
            plant.imu_mean_steps = self.substeps   # IMU samples: means over the HIL period
        self.controls: tuple = (0.0, 0.0, 0.0, 0.0)
        self.fault_log: list[FaultRecord] = []
        self.state = plant.state()
        self.steps = 0
        # the propulsion battery, reported as BATTERY_STATUS once a second of sim time
        self.battery = Battery() if vehicle == "plane" else Battery(cells=4, capacity_ah=5.0, max_power_w=800.0)
        self.battery_period_us = 1_000_000
        self._next_battery_us = 0
        self._bat_u_s = self._bat_t_s = 0.0  # command x time [s] and time [s] since the last update

    @property
    def t_us(self) -> int:
        return self.state.t_us

    # ------------------------------------------------------------ fault entry ---
    def inject(self, unit: str, ftype: str, instance: int = 0, source: str = "scenario",
               **magnitudes) -> bool:
        ok = False
        if self.faults is not None:
            ok = bool(self.faults.inject(unit, ftype, instance, **magnitudes))
        held = None
        if ok and ftype == "stuck":
            held = self.faults.held_position(unit, instance)
        self.fault_log.append(FaultRecord(self.t_us * 1e-6, unit, ftype, instance, ok, source, held))
        return ok

    def _apply_due_events(self) -> None:
        t_s = self.t_us * 1e-6
        while self._next_event < len(self.events) and self.events[self._next_event].at_s <= t_s + 1e-9:
            e = self.events[self._next_event]
            self.inject(e.unit, e.type, e.instance, "scenario", **dict(e.magnitudes))
            self._next_event += 1

    def _handle_commands(self) -> None:
        """MAV_CMD_INJECT_FAILURE relayed by the autopilot: apply, then acknowledge."""
        while self.link.commands:
            cmd = self.link.commands.pop(0)
            if cmd.command != MAV.MAV_CMD_INJECT_FAILURE:
                self.link.send_command_ack(cmd.command, MAV.MAV_RESULT_UNSUPPORTED,
                                           cmd.get_srcSystem(), cmd.get_srcComponent())
                continue
            from .faults import unit_name, type_name  # names from FAILURE_UNIT / FAILURE_TYPE
            try:
                unit, ftype = unit_name(int(cmd.param1)), type_name(int(cmd.param2))
                ok = self.inject(unit, ftype, int(cmd.param3), "mavlink")
            except (ValueError, KeyError):
                ok = False
            result = MAV.MAV_RESULT_ACCEPTED if ok else MAV.MAV_RESULT_UNSUPPORTED
            self.link.send_command_ack(cmd.command, result, cmd.get_srcSystem(), cmd.get_srcComponent())

    # --------------------------------------------------------------- stepping ---
    def send_current(self) -> None:
        if self._next_event < len(self.events):
            self._apply_due_events()
        state = self.state
        readings = self.sensors.sample(state)
        if self.faults is not None:
            readings = self.faults.apply(readings)
        rf, rs = self.rangefinder, self.rpm
        self.link.send_step(readings, state, rf.sample(state) if rf is not None else None,
                            rs.sample(state) if rs is not None else None)

    def advance(self, controls: tuple | None) -> None:
        if controls is not None:
            self.controls = tuple(controls[:4])
        if self.link.commands:
            self._handle_commands()
        c = self.controls
        faults = self.faults
        if faults is not None:
            c = faults.apply_controls(c)          # (a tuple)
            if self._rotors and faults.actuator_changes != self._rotor_changes:
                self._rotor_changes = faults.actuator_changes
                self.plant.rotor_scale = faults.motor_thrust_scales(self._rotors)
        if self._plane:
            cmd = PlaneControls.make(*c)
            u = c[3]
        else:
            cmd = c
            u = sum(c[:4]) / 4.0 if len(c) >= 4 else 0.0
        # the battery integrates the mean command over BATTERY_STEP_US (its power is
        # linear in the command and its voltage changes over minutes)
        dt = self._hil_period_s
        self._bat_u_s += (u if self.link.armed else 0.0) * dt
        self._bat_t_s += dt
        t_us = self.state.t_us
        if self._bat_t_s * 1e6 >= BATTERY_STEP_US - 1 or t_us >= self._next_battery_us:
            self.battery.update(self._bat_u_s / self._bat_t_s, self._bat_t_s)
            self._bat_u_s = self._bat_t_s = 0.0
        if t_us >= self._next_battery_us:
            self._next_battery_us = t_us + self.battery_period_us
            self.link.send_battery(self.battery)
        self.state = self.plant.step(cmd, self.substeps)
        self.steps += 1

    def run_step(self) -> bool:
        """One blocking lockstep step; False if the autopilot never answered."""
        self.send_current()
        controls = self.link.wait_answer(self.t_us)
        self.advance(controls)
        return controls is not None
