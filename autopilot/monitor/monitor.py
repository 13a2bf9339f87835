"""The onboard fault monitor: detection, isolation, R and Q adaptation, reactions.

Course text ch. 8 sec. 2.2-2.3 (Hajiyev & Caliskan 2003, "Fault Diagnosis and
Reconfiguration in Flight Control Systems"); the statistics are :mod:`.stats`, the R
adaptation :mod:`.radapt`. Runs once per vehicle step, after navigation, on what the
navigation filter exposes: its innovation records, bias estimates and covariance. It is
never told about injected faults.

* Detection: the window chi-square statistic of each aiding sensor's normalised
  innovations (eqs 2.12-2.15), at a level set per flight hour (FDI_PFA, shared by all
  the window tests: the course text's per-test alpha alarms every hour or so in healthy
  flight); a channel fallen silent for FDI_TOUT; the rate of the gyro-bias estimate
  against its admissible rate (a gyro fault is a bias step the filter absorbs); the
  elevator's moment-balance residual (:mod:`.actuator`); the rotors' (:mod:`.motors`).
* Isolation: the channel with the largest sample-variance statistic over its threshold
  (eqs 2.16-2.17, the max rule); every channel over its threshold in the episode is
  named as well (``Episode.isolated_all``, several faulty channels), and a channel joins
  an open episode later over its own detection threshold. Clearance after FDI_CLR_T with
  every statistic low.
* Adaptation: an aiding-sensor fault gets noise scale factors on R (eqs 2.25-2.34,
  FDI_RADAPT); a drift of the velocity innovations is an IMU fault, met with a fading Q
  on the gyro-bias states (eq 2.40, FDI_QFADE) instead, since R adaptation would make
  the filter ignore the GPS that reveals it.
* Reactions: STATUSTEXT-ready events; GPS silent for FDI_DR_TIME -> RTL
  (dead reckoning meanwhile); an elevator fault -> the fixed-wing flies its height on
  the throttle (control/fixed_wing.py, "elevator out").

Channels (names used everywhere: log, STATUSTEXT, summary.json): ``CHANNELS``.

Why each choice, with the thresholds and the derivation: docs/monitor.md, "The monitor".
How well it works: docs/status.md, "Faults and the monitor".
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from operator import itemgetter

from autopilot.geo import G0
from autopilot.nav.records import InnovationLog
from autopilot.params import Param

from .actuator import BAL_TAU_S
from .radapt import R_MULTIPLE, RAdapter, attach
from .stats import WindowChi2, chi2_threshold, family_alpha

CHANNELS = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z", "mag", "baro",
            "airspeed", "gps_pos", "gps_vel", "aileron", "elevator", "rudder", "throttle",
            "motor_1", "motor_2", "motor_3", "motor_4")
CHANNEL_INDEX = {name: i for i, name in enumerate(CHANNELS)}

# MAV_SEVERITY
SEV_CRITICAL, SEV_WARNING, SEV_NOTICE, SEV_INFO = 2, 4, 5, 6

FDI_PARAMS = (
    Param("FDI_ENABLE", 1.0, 0.0, 1.0, "bool", "run the fault monitor", is_int=True, at_start=True),
    Param("FDI_ALPHA", 1e-4, 1e-9, 0.1, "", "level of significance of the per-step and isolation "
          "chi-square tests (run during an episode)", at_start=True),
    Param("FDI_PFA", 0.01, 1e-9, 1.0, "1/h", "false-alarm probability per flight hour of all window "
          "detection tests together (sets their alpha)", at_start=True),
    Param("FDI_WIN", 10.0, 3.0, 100.0, "samples", "sliding window width M of the chi-square tests",
          is_int=True, at_start=True),
    Param("FDI_DECIM", 10.0, 1.0, 50.0, "", "baro, mag, airspeed (fused at 25 Hz) enter every N-th sample",
          is_int=True, at_start=True),
    Param("FDI_ARSP_K", 4.0, 1.0, 100.0, "", "airspeed innovation variance inflation (turbulence)"),
    Param("FDI_ARSP_HMIN", 20.0, 0.0, 300.0, "m", "airspeed window test only this high above the origin "
          "(home) or higher: below it turbulence's gusts outrun the wind estimate (0: everywhere)"),
    Param("FDI_ARSP_HREF", 100.0, 0.0, 1000.0, "m", "under this height above the origin the airspeed "
          "innovations are scaled down by the low-altitude gusts' growth (MIL-F-8785C; 0: never)"),
    Param("FDI_MAG_FNSE", 0.005, 0.0, 1.0, "gauss", "magnetometer noise per axis per sample: where the "
          "local horizontal field makes the heading noise (this over B_h) exceed EK_MAG_NSE, the mag "
          "innovations are normalised by that instead (0: never)"),
    Param("FDI_TOUT", 0.5, 0.1, 10.0, "s", "a channel silent this long is flagged (sensor off)"),
    Param("FDI_BIAS_T", 4.0, 1.0, 60.0, "s", "window of the gyro bias-estimate change test", at_start=True),
    Param("FDI_ALPHA_B", 1e-5, 1e-12, 0.1, "", "level of significance of the gyro bias test"),
    Param("FDI_ACC_STAT", 1.0, 0.0, 1.0, "bool", "accelerometer bias-change test (as the gyros')",
          is_int=True),
    Param("FDI_BIAS_WU", 60.0, 0.0, 600.0, "s", "gyro bias test armed this long after alignment"),
    Param("FDI_START_T", 10.0, 0.0, 600.0, "s", "monitor starts this long after navigation is healthy"),
    Param("FDI_CLR_T", 2.0, 0.0, 60.0, "s", "a fault clears after this long with all statistics low"),
    Param("FDI_RADAPT", 2.0, 0.0, 2.0, "", "R adaptation: 0 off, 1 single, 2 multiple scale factors",
          is_int=True, at_start=True),
    Param("FDI_RWIN", 10.0, 1.0, 100.0, "samples", "R adaptation: innovations in the covariance estimate "
          "(1: one sample, as the seed)", is_int=True, at_start=True),
    Param("FDI_QFADE", 1000.0, 1.0, 1e6, "", "fading factor of the gyro-bias process noise while an "
          "inertial fault is suspected (1: off)", at_start=True),
    Param("FDI_DRIFT", 0.5, 0.0, 1.0, "", "velocity innovations whose window means hold this share of the "
          "statistic are a drift (inertial fault)"),
    Param("FDI_ACT_ID", 1.0, 0.0, 1.0, "bool", "elevator fault detection and identification "
          "(moment balance and two-stage KF)", is_int=True, at_start=True),
    Param("FDI_EL_MODEL", 1.0, 0.0, 2.0, "", "elevator identifier's prior: 0 none (the pitch balance "
          "learnt in flight, armed ~100 s after launch), 1 the Aerosonde's model, 2 the c172p's (armed from launch)",
          is_int=True, at_start=True),
    Param("FDI_ACT_THR", 3.0, 1.0, 100.0, "", "elevator residual window statistic over its chi-square "
          "threshold by this factor detects"),
    Param("FDI_LAT_ID", 1.0, 0.0, 1.0, "bool", "aileron and rudder fault detection and identification "
          "(the airframe's lateral balance, autopilot/monitor/lateral.py)", is_int=True, at_start=True),
    Param("FDI_THR_ID", 1.0, 0.0, 1.0, "bool", "throttle fault detection and identification (the "
          "airframe's thrust balance, autopilot/monitor/throttle.py)", is_int=True, at_start=True),
    Param("FDI_THR_RPM", 1.0, 0.0, 1.0, "bool", "the throttle's test on the propeller's measured "
          "speed (ESC telemetry, ESC_TELEMETRY_1_TO_4) when it is delivered, the thrust balance's "
          "when not; 0 the thrust balance's always (autopilot/monitor/throttle.py)", is_int=True),
    Param("FDI_EL_TERM", 0.0, 0.0, 1.0, "", "elevator identified stuck where the airframe's model has no "
          "level trim: 0 fly on (full throttle, wings level, descending), 1 flight termination (as "
          "ArduPlane's advanced failsafe, AFS_TERM_ACTION)", is_int=True),
    Param("FDI_LAT_TERM", 0.0, 0.0, 1.0, "", "aileron or rudder identified stuck where the airframe's "
          "model says the other surface cannot hold the wings level: 0 fly on (the other surface "
          "full against it), 1 flight termination (as FDI_EL_TERM)", is_int=True),
    Param("FDI_GPS_FS", 1.0, 0.0, 1.0, "", "GPS lost failsafe: 0 none, 1 RTL", is_int=True),
    Param("FDI_DR_TIME", 60.0, 0.0, 600.0, "s", "dead reckoning this long before the GPS failsafe"),
)
_DEFAULTS = {p.name: float(p.default) for p in FDI_PARAMS}
# the monitor's parameters that take effect at the next start only (FaultMonitor.set_param)
_AT_START = {p.name: p.at_start for p in FDI_PARAMS}

# aiding channel -> (innovation dimension, decimated, variance inflation key)
_AIDING = {"gps_pos": (3, False, None), "gps_vel": (3, False, None), "baro": (1, True, None),
           "mag": (1, True, None), "airspeed": (1, True, "FDI_ARSP_K")}
_GYROS = ("gyro_x", "gyro_y", "gyro_z")
_BIASED = _GYROS + ("accel_x", "accel_y", "accel_z")   # the bias-estimate channels
_INERTIAL = frozenset(CHANNELS[:6])
_BIAS_PERIOD_US = 100_000       # bias sampling period of the gyro channels [us]
# in an episode isolated to a gyro, another gyro this many times over the isolated one's
# statistic is the one to blame (_reisolate_gyro)
_REISOLATE_FACTOR = 3.0
# the bias estimates' variances from the diagonal of P, gyros' then accelerometers'
# (layout.GBIAS, layout.ABIAS, kept here to read P without importing nav), or the gyros'
# alone
_BIAS_VAR6, _BIAS_VAR3 = itemgetter(12, 13, 14, 9, 10, 11), itemgetter(12, 13, 14)
SILENT_RUN = 50                 # updates in a row at most FDI_TOUT apart before a silence
                                # counts (2 s of baro, mag, airspeed; 10 s of GPS)
NOTRIM_N = 3                    # provisional elevator readings (1 Hz, after the detection's)
                                # with no level trim in a row: said (and terminated)
RHO0_ISA = 1.225                # sea-level density [kg/m^3]
_GPS_HZ = 5.0                   # GPS fix rate (SensorParams.gps_rate_hz, u-blox M8N) [Hz]
_AUX_HZ = 25.0                  # baro, mag, airspeed fusion rate of the filter (nav/base.py) [Hz]


def window_tests_per_hour(decim: int) -> float:
    """Window detection tests per flight hour, all aiding channels: one per sample of
    gps_pos and gps_vel, one per FDI_DECIM-th fusion of baro, mag and airspeed."""
    return 3600.0 * (2 * _GPS_HZ + 3 * _AUX_HZ / max(decim, 1))

LOG_COLUMNS = ("fdi_detected", "fdi_isolated", "fdi_step_max", "fdi_gps_pos", "fdi_gps_vel",
               "fdi_baro", "fdi_mag", "fdi_airspeed", "fdi_iso_max", "fdi_gyro_x", "fdi_gyro_y",
               "fdi_gyro_z", "fdi_rscale_gps")
"""Flight-log columns of the monitor: detected (0/1), isolated channel index in CHANNELS
(-1 none), then statistics divided by their thresholds (> 1: H1): the largest per-step
statistic of this step (2.41), the window statistic per aiding channel (2.12; a
silent channel logs age / FDI_TOUT), the largest isolation statistic (2.17), the gyro
bias-change statistic per axis, and the largest R scale factor applied to gps_pos."""


def _gust_share(h_m: float) -> float:
    """The along-wind gusts' share of the airspeed innovation at height h_m, up to a
    constant: MIL-F-8785C's low-altitude model (h in ft, under 1000 ft) gives the
    intensity sigma_u = sigma_w / (0.177 + 0.000823 h)^0.4 and the scale length
    L_u = h / (0.177 + 0.000823 h)^1.2; a wind estimate that follows gusts slower than
    its own bandwidth leaves the part above it, sigma_u^2 times the gust bandwidth V / L_u
    over its own, in the innovation: proportional to (0.177 + 0.000823 h)^0.4 / h.
    Random plane missions in moderate turbulence alarmed on the airspeed 22-45 m above
    home (4 flights in 55 h, 1.00-1.09 times the threshold) where FDI_ARSP_K had been
    set from flights higher up; from 100 m (FDI_ARSP_HREF) down to 45 m this grows 1.9
    times, to 22 m 3.5 times."""
    h_ft = min(h_m, 304.8) / 0.3048
    return (0.177 + 0.000823 * h_ft) ** 0.4 / h_ft


@dataclass
class Episode:
    """One detection, from detection to clearance: the running fault log."""

    start_s: float
    trigger: str                   # channel whose statistic crossed first
    isolated: str | None = None
    isolated_s: float | None = None
    end_s: float | None = None
    kind: str | None = None        # "sensor", "inertial" or "actuator"
    identified: dict | None = None  # actuator fault parameters, latest estimate
    ident_log: list | None = None   # (t_s, identified) once a second
    isolated_all: list | None = None  # every channel over its isolation threshold at the
                                      # isolation, or over its detection threshold later
                                      # (the most to blame first)


class _Aiding:
    __slots__ = ("name", "win", "decim", "k", "gain", "last_us", "silent", "refill",
                 "ratio", "adapted", "rdet", "riso", "hmin", "run")

    def __init__(self, name: str, s: int, M: int, alpha: float, decim: int, gain: float,
                 alpha_det: float):
        self.name = name
        self.win = WindowChi2(s, M, alpha, alpha_det)
        self.decim = decim
        self.k = 0
        self.gain = gain              # 1 / sqrt(variance inflation)
        self.last_us: int | None = None
        self.silent = False
        self.refill = False           # back from silence, window not yet full
        self.ratio = 0.0
        self.adapted = False
        self.rdet = 0.0               # latest window statistic / threshold (2.12)
        self.riso = 0.0               # latest isolation statistic / threshold (2.17)
        self.hmin = 0.0               # window test only this high above the origin [m]
        self.run = 0                  # updates in a row at most FDI_TOUT apart


class FaultMonitor:
    """``FaultMonitor(params, nav)``; ``update(t_us, armed)`` once per step after the
    navigation update. Outputs: ``detected``, ``isolated``, ``events``, ``episodes``,
    ``failsafe``, ``log_row()``."""

    def __init__(self, params=None, nav=None):
        p = dict(_DEFAULTS)
        if params is not None:
            for name in p:
                if name in params:
                    p[name] = float(params[name])
        self.p = p
        self.nav = nav
        M = int(p["FDI_WIN"])
        alpha = p["FDI_ALPHA"]
        decim = int(p["FDI_DECIM"])
        # the window test runs at every sample of the flight: its level from the
        # family-wise false-alarm probability per hour (module docstring)
        self.alpha_det = family_alpha(p["FDI_PFA"], window_tests_per_hour(decim))
        self.aiding: dict[str, _Aiding] = {}
        for name, (s, fast, kkey) in _AIDING.items():
            gain = 1.0 / math.sqrt(p[kkey]) if kkey else 1.0
            self.aiding[name] = _Aiding(name, s, M, alpha, decim if fast else 1, gain, self.alpha_det)
        # the airspeed's window test not near the ground: moderate turbulence's gusts there
        # are shorter than the wind estimate follows (MIL-F-8785C low altitude: scale length
        # L_u 67 m at 10 m against 263 m at 100 m) and the innovations are the gusts
        # (docs/monitor.md, "How each channel is watched")
        self.aiding["airspeed"].hmin = p["FDI_ARSP_HMIN"]
        self._arsp_ch = self.aiding["airspeed"]
        self._arsp_href = p["FDI_ARSP_HREF"]
        self._arsp_fref = _gust_share(self._arsp_href) if self._arsp_href > 0.0 else 0.0
        self._aiding_list = tuple(self.aiding.values())
        self._mag_ch = self.aiding["mag"]
        # the heading noise the local field gives the magnetometer (_mag_gain)
        self._mag_nse = float(params["EK_MAG_NSE"]) if params is not None and "EK_MAG_NSE" in params else 0.03
        self._mag_gain: float | None = None
        self.tout_us = int(p["FDI_TOUT"] * 1e6)
        self._start_us = p["FDI_START_T"] * 1e6
        # gyro bias channels
        self.bias_n = max(1, int(round(p["FDI_BIAS_T"] * 1e6 / _BIAS_PERIOD_US)))
        self.thr_bias = chi2_threshold(p["FDI_ALPHA_B"], 1)
        q = 2e-5
        if params is not None and "EK_GYRB_NSE" in params:
            q = float(params["EK_GYRB_NSE"])
        self.q_bias_T = q * q * p["FDI_BIAS_T"]
        qa = 1e-3
        if params is not None and "EK_ACCB_NSE" in params:
            qa = float(params["EK_ACCB_NSE"])
        self._q_T = [self.q_bias_T] * 3 + [qa * qa * p["FDI_BIAS_T"]] * 3
        self._acc_on = p["FDI_ACC_STAT"] >= 1
        self.accel_ratio = [0.0, 0.0, 0.0]
        self._bias_ring: list = []            # (t_us, bias estimate, its variance) every 0.1 s
        self._anchor = None                   # the ring's oldest entry at detection
        self._bias_next_us = 0
        self._bias_wu_us = p["FDI_BIAS_WU"] * 1e6
        self.bias_ratio = [0.0, 0.0, 0.0]
        # the aiding channels' scan's inputs unchanged since (update): armed then, and the
        # time after which a channel may fall silent (-1: scan at every step); its findings
        self._eval_armed = None
        self._eval_until_us = -1
        self._scan: tuple = ()
        # R adaptation
        self.radapt = RAdapter(int(p["FDI_RADAPT"]), int(p["FDI_RWIN"]))
        self.radapt_ok = nav is not None and int(p["FDI_RADAPT"]) != 0 and attach(nav, self.radapt)
        # the hook on the filter only while a source is adapted (update): with none it
        # returns None at every fusion, and the filter fuses without it as with it; the
        # window it keeps is filled from the records meanwhile (RAdapter.observe)
        self._r_hook_on = False
        if self.radapt_ok:
            nav.r_scale_hook = None
        # Q adaptation (fading of the gyro-bias process noise, seed eqs 2.35-2.40)
        self.qfade_on = False
        self._faded_ep = 0              # the episodes' count when the fading last came on
        self._iso_faded = False         # the episode's isolation taken while the fading was on
        self._lam = None
        if nav is not None and p["FDI_QFADE"] > 1.0 and hasattr(nav, "q_scale_hook"):
            lam = [1.0] * int(getattr(nav, "n", 21))
            for i in range(12, 15):       # layout.GBIAS
                lam[i] = p["FDI_QFADE"]
            import numpy as np
            self._lam = np.array(lam)
            nav.q_scale_hook = self._q_hook
        # actuator (elevator) identification, autopilot/monitor/actuator.py
        self.elevator = None
        self.airframe = None
        if p["FDI_ACT_ID"] >= 1:
            from .actuator import ElevatorIdentifier
            from .airframe import MODELS
            model = self.airframe = MODELS.get(int(p["FDI_EL_MODEL"]))
            self.elevator = ElevatorIdentifier(alpha=p["FDI_ALPHA"], window=M, p_fa=p["FDI_PFA"],
                                               model=model)
        # aileron and rudder identification, autopilot/monitor/lateral.py
        self.lateral = None
        if p["FDI_ACT_ID"] >= 1 and p["FDI_LAT_ID"] >= 1 and int(p["FDI_EL_MODEL"]) >= 1:
            from .lateral import LAT_MODELS, LateralIdentifier
            lat = LAT_MODELS.get(int(p["FDI_EL_MODEL"]))
            if lat is not None:
                self.lateral = LateralIdentifier(lat, alpha=p["FDI_ALPHA"], window=M, p_fa=p["FDI_PFA"],
                                                 prop=self.airframe, nav=self.nav)
                self.lateral_model = lat
        # the throttle's, autopilot/monitor/throttle.py
        self.throttle = None
        if p["FDI_ACT_ID"] >= 1 and p["FDI_THR_ID"] >= 1 and int(p["FDI_EL_MODEL"]) >= 1:
            from .throttle import THRUST_MODELS, ThrottleIdentifier
            thm = THRUST_MODELS.get(int(p["FDI_EL_MODEL"]))
            if thm is not None:
                self.throttle = ThrottleIdentifier(thm, alpha=p["FDI_ALPHA"], window=M, p_fa=p["FDI_PFA"])
        self._act_idents = tuple(i for i in (self.lateral, self.throttle) if i is not None)
        # the three balances' 50 Hz step in one compiled call where they can (balances.py)
        self._balances = None
        if p["FDI_ACT_ID"] >= 1:
            from .balances import Balances
            if Balances.fits(self.elevator, self.lateral, self.throttle):
                self._balances = Balances(self.elevator, self.lateral, self.throttle)
        self.throttle_out: dict | None = None  # a stuck throttle's reaction (_throttle_reaction)
        self.stuck_surface: dict = {}          # "aileron"/"rudder"/"throttle" -> stuck position (latched)
        self.surface_out: dict | None = None   # the reaction to it (_lateral_reaction)
        self._ident_next_s = 0.0
        self.elevator_fault_s: float | None = None     # an elevator actuator fault found (latched)
        self.elevator_stuck_rad: float | None = None   # latched once identified stuck
        self.elevator_trim_mps: float | None = None    # level trim airspeed of that (model)
        self.elevator_bank_max_rad: float | None = None  # steepest level turn at that trim
        self.elevator_full_throttle = False   # the model has no level trim: full throttle
        self.terminate = False                # flight termination asked (FDI_EL_TERM, FDI_LAT_TERM)
        self._el_trim_said = 0        # the reaction said: 0 not yet, 1 a trim, 2 none
        self._el_notrim_n = 0
        self._el_k = 0                        # vehicle steps seen by observe_controls
        self._suspended = False               # the identifiers suspended (observe_controls)
        self._act_stale = True                # the balances' peaks and decision not yet
                                              # taken on their latest statistics
        # decision state
        self.enabled = bool(p["FDI_ENABLE"])
        self.detected = False
        self.isolated: str | None = None
        self.episodes: list[Episode] = []
        self.events: list[tuple[float, int, str]] = []
        self.failsafe: str | None = None
        self._healthy_us: int | None = None
        self._aligned_us: int | None = None
        self._running = False                 # (update: _start)
        self._quiet_us: int | None = None
        self._gps_silent_us: int | None = None
        self._fs_done = False
        self._lat_none_said = False           # "cannot hold the wings level" said
        self._step_max = 0.0
        self._iso_max = 0.0
        # largest detection statistic / threshold per channel while no fault is detected:
        # the margin of the healthy flight (sitl bench --false-alarms)
        self.peaks: dict[str, float] = {}
        self.innovation_log = InnovationLog()

    def _mag_gain_at_origin(self) -> float:
        """1 / the factor by which the heading noise of the place exceeds the filter's
        EK_MAG_NSE (1 where it does not): the heading from a field measured with noise
        FDI_MAG_FNSE per axis errs by that over the horizontal field B_h (IGRF at the
        navigation origin), and the filter's heading noise is a fixed angle. Where B_h is
        weak (0.093 gauss at 33.6 S 3.0 E, the South Atlantic anomaly: 0.054 rad per
        sample against 0.03) the normalised innovations had 1.6-1.8 times the unit sd
        and the window test alarmed in fault-free flight. The unscaled R is still the
        filter's; only the test's normalisation changes. Fixed once the origin is known."""
        origin = getattr(self.nav, "origin", None)
        if origin is None:
            return 1.0
        fnse = self.p["FDI_MAG_FNSE"]
        gain = 1.0
        if fnse > 0.0 and self._mag_nse > 0.0:
            from autopilot.geo.magfield import igrf_field_ned_gauss
            bn, be, _bd = igrf_field_ned_gauss(origin.lat0_rad, origin.lon0_rad, origin.alt0_m)
            bh = math.hypot(bn, be)
            sd = fnse / bh if bh > 0.0 else float("inf")
            gain = min(1.0, self._mag_nse / sd)
        self._mag_gain = gain
        return gain

    def set_param(self, name: str, value: float) -> None:
        """A parameter changed in flight (the vehicle's ``_param_follow``): the monitor's
        copy takes it and what it worked out from it follows, from its next step. Those
        it is built from (its windows, thresholds, identifiers, the R and Q adaptation:
        ``at_start`` in FDI_PARAMS) keep the value it was started with. The filter's noise
        parameters it reads (EK_MAG_NSE, EK_GYRB_NSE, EK_ACCB_NSE) are followed too."""
        p = self.p
        if name in p:
            if _AT_START[name]:
                return
            p[name] = float(value)
        if name == "FDI_TOUT":
            self.tout_us = int(p["FDI_TOUT"] * 1e6)
            self._eval_until_us = -1          # (the scan's silence horizon: update)
        elif name == "FDI_START_T":
            self._start_us = p["FDI_START_T"] * 1e6
        elif name == "FDI_BIAS_WU":
            self._bias_wu_us = p["FDI_BIAS_WU"] * 1e6
        elif name == "FDI_ALPHA_B":
            self.thr_bias = chi2_threshold(p["FDI_ALPHA_B"], 1)
        elif name == "FDI_ACC_STAT":
            self._acc_on = p["FDI_ACC_STAT"] >= 1
        elif name == "FDI_ARSP_K":
            self._arsp_ch.gain = 1.0 / math.sqrt(p["FDI_ARSP_K"])
        elif name == "FDI_ARSP_HMIN":
            self._arsp_ch.hmin = p["FDI_ARSP_HMIN"]
        elif name == "FDI_ARSP_HREF":
            self._arsp_href = p["FDI_ARSP_HREF"]
            self._arsp_fref = _gust_share(self._arsp_href) if self._arsp_href > 0.0 else 0.0
        elif name in ("FDI_MAG_FNSE", "EK_MAG_NSE"):
            if name == "EK_MAG_NSE":
                self._mag_nse = float(value)
            self._mag_gain = None
            self._mag_gain_at_origin()        # (until the origin is known: at the first sample)
        elif name == "EK_GYRB_NSE":
            self.q_bias_T = float(value) ** 2 * p["FDI_BIAS_T"]
            self._q_T[:3] = [self.q_bias_T] * 3
        elif name == "EK_ACCB_NSE":
            self._q_T[3:] = [float(value) ** 2 * p["FDI_BIAS_T"]] * 3
        self._eval_armed = None               # the next step evaluates afresh

    @property
    def dead_reckoning(self) -> bool:
        """The GPS has fallen silent (flagged after FDI_TOUT): navigation dead-reckons."""
        return self.detected and self.aiding["gps_pos"].silent

    # ------------------------------------------------------------------- step ---
    def update(self, t_us: int, armed: bool = True) -> None:
        nav = self.nav
        if nav is None:
            return
        if nav.innovations:                   # (most steps have none)
            if getattr(nav, "aligned", False):
                self.innovation_log.add(nav.innovations)   # for the flight log (every record)
            if self.radapt_ok and not self._r_hook_on:
                self.radapt.observe(nav.innovations)
        if not self._running and not self._start(t_us):
            return
        step_max = 0.0
        okf = self.radapt.okf_sd
        aiding = self.aiding
        height = None
        changed = False                   # a window pushed or reset this step
        for r in nav.innovations:
            ch = aiding.get(r.source)
            if ch is None:
                continue
            if ch.last_us is not None and t_us - ch.last_us <= self.tout_us:
                ch.run += 1
            elif ch.last_us is None or t_us > ch.last_us:
                ch.run = 0
            ch.last_us = t_us
            ch.k += 1
            if ch.k < ch.decim:
                continue
            ch.k = 0
            if ch.hmin > 0.0 or ch is self._arsp_ch:
                if height is None:
                    pos = getattr(nav, "position_ned", None)
                    height = -float(pos[2]) if pos is not None else 1e9
                if height < ch.hmin:
                    # too low for this channel's test: its window starts again up there
                    if ch.win.n:
                        ch.win.reset()
                        ch.rdet = ch.riso = 0.0
                        changed = True
                    continue
            sl = okf.get(r.source)
            if sl is None:
                sl = r.innovation_variance
            y = r.innovation
            if min(sl) <= 0.0:
                continue                      # not a covariance: no statistic
            g = ch.gain
            if ch is self._mag_ch:
                g *= self._mag_gain if self._mag_gain is not None else self._mag_gain_at_origin()
            elif ch is self._arsp_ch and height < self._arsp_href:
                # the gusts' share of the airspeed innovation grows towards the ground
                # (_gust_share): scaled back to what FDI_ARSP_K allows at FDI_ARSP_HREF
                g *= math.sqrt(self._arsp_fref / _gust_share(max(height, 1.0)))
            # Delta = diag(S)^-1/2 e   (2.13), with the unscaled R
            d = [g * yi / math.sqrt(si) for yi, si in zip(y, sl)]
            w = ch.win
            w.push(d)
            changed = True
            ch.rdet = w.ratio_det
            ch.riso = w.ratio_iso
            rs = w.chi / w.thr_step
            if rs > step_max:
                step_max = rs
        self._step_max = step_max
        # with no fault detected, no window moved, armed as it was and no channel able to
        # fall silent yet, the aiding channels' scan would find what it found last time;
        # the evaluation then runs only where the bias test is due, on that scan
        scan = changed or self.detected or armed != self._eval_armed or t_us > self._eval_until_us
        if scan or t_us >= self._bias_next_us:
            self._evaluate(t_us, armed, scan)
            if self._r_hook_on != bool(self.radapt.active):
                self._r_hook_on = not self._r_hook_on
                nav.r_scale_hook = self.radapt.hook if self._r_hook_on else None

    def _start(self, t_us: int) -> bool:
        """Whether the monitor runs from this step on: enabled, FDI_START_T after the
        navigation is healthy (the alignment's and health's times noted here). Once it
        runs it runs on (update asks only until then)."""
        if not self.enabled:
            return False
        nav = self.nav
        if self._aligned_us is None:
            if not getattr(nav, "aligned", False):
                return False
            self._aligned_us = t_us
        if self._healthy_us is None:
            if not getattr(nav, "healthy", False):
                return False
            self._healthy_us = t_us
        if t_us - self._healthy_us < self._start_us:
            return False
        self._running = True
        return True

    def observe_rpm(self, sample) -> None:
        """The propeller's measured speed (an ``RpmSample``, ESC telemetry): the throttle's
        residual when FDI_THR_RPM is set (autopilot/monitor/throttle.py)."""
        if self.throttle is not None and self.p["FDI_THR_RPM"] >= 1:
            self.throttle.measure_rpm(sample.t_us, sample.rpm)

    def observe_controls(self, t_us: int, nav_state, controls: tuple, flying: bool) -> None:
        """Once per step after control: the commands sent (aileron, elevator, rudder,
        throttle; normalised). Feeds the elevator identifier when FDI_ACT_ID is set."""
        el = self.elevator
        if el is None or nav_state is None or len(controls) < 2:
            return
        # the identifier samples at half the loop rate (50 Hz): its signals are low-passed
        # at 1 s and sampled at 10 Hz
        self._el_k += 1
        if self._el_k & 1:
            return
        # a sensor (or inertial) fault makes their inputs suspect: they learn nothing then
        # (suspend(on) with the state they have changes nothing: asked on a change only)
        sensor_fault = self.detected and self.episodes[-1].kind != "actuator"
        if sensor_fault != self._suspended:
            self._suspended = sensor_fault
            el.suspend(sensor_fault)
            for ident in self._act_idents:
                ident.suspend(sensor_fault)
        f = getattr(self.nav, "specific_force_b", None)
        learning = flying and bool(nav_state.healthy)
        # (each step says whether it renewed its statistics: _act_stale)
        if self._balances is not None and len(controls) >= 4:
            # the three balances in one call, the elevator's with them (balances.py)
            if self._balances.step(t_us, nav_state, controls, learning, f):
                self._act_stale = True
        else:
            for ident in self._act_idents if len(controls) >= 4 else ():
                if ident.step(t_us, nav_state, controls, learning, f):
                    self._act_stale = True
            if el.step(t_us, nav_state, float(controls[1]), learning,
                       float(controls[3]) if len(controls) > 3 else 0.0,
                       None if f is None else -float(f[2]) / G0):
                self._act_stale = True
        if not el.ready or not self.enabled or self._healthy_us is None:
            return
        t_s = t_us * 1e-6
        if not self.detected:
            if not self._act_stale:
                return
            act_thr = self.p["FDI_ACT_THR"]
            peaks = self.peaks
            r_el = el.ratio / act_thr
            if r_el > peaks.get("elevator", 0.0):
                peaks["elevator"] = r_el
            best, r_best = None, 0.0
            for ident in self._act_idents:
                for name, ax in ident.axes.items():
                    r = ax.ratio / act_thr
                    if r > peaks.get(name, 0.0):
                        peaks[name] = r
                    if r > r_best:
                        best, r_best = name, r
            # the balances' statistics are renewed at 2 Hz, this runs at 50: with none over
            # its threshold the peaks and the decision stand until one is renewed
            self._act_stale = r_best > 1.0 or r_el > 1.0
            # the navigation quiet (asked only when a balance is over its threshold)
            quiet = ((r_best > 1.0 or r_el > 1.0) and all(ch.ratio < 1.0 for ch in self._aiding_list)
                     and max(self.bias_ratio) < 1.0 and max(self.accel_ratio) < 1.0)
            if quiet and r_best > 1.0 and r_best > r_el:
                self._lateral_detected(t_us, best, r_best)
                return
            if quiet and r_el > 1.0:
                # residual of the pitch model high, navigation innovations white: an
                # actuator fault (the INS/GPS filter is insensitive to actuator faults)
                self.detected = True
                self._quiet_us = None
                ep = Episode(round(t_s, 3), "elevator", "elevator", round(t_s, 3), kind="actuator",
                             isolated_all=["elevator"])
                ep.ident_log = []
                self.episodes.append(ep)
                self.isolated = "elevator"
                self.elevator_fault_s = t_s
                el.freeze(t_us)
                self.events.append((t_s, SEV_WARNING, f"FDI: fault detected on elevator "
                                                      f"(statistic {el.ratio / self.p['FDI_ACT_THR']:.1f}x threshold)"))
                self.events.append((t_s, SEV_CRITICAL, "FDI: elevator actuator fault isolated, "
                                                       "Q adaptation on"))
                self._elevator_provisional(t_s, count=False)
            return
        ep = self.episodes[-1]
        if ep.kind == "actuator" and ep.isolated in ("aileron", "rudder", "throttle"):
            if t_s >= self._ident_next_s:
                self._ident_next_s = t_s + 1.0
                self._lateral_identify(t_s, ep)
            return
        if ep.kind == "actuator" and t_s >= self._ident_next_s:
            self._ident_next_s = t_s + 1.0
            ep.identified = el.identified(stuck=self.elevator_stuck_rad is not None)
            ep.ident_log.append((round(t_s, 3), ep.identified))
            stuck = ep.identified.get("stuck_rad")
            if stuck is not None:
                if self.elevator_stuck_rad is None:
                    self.events.append((t_s, SEV_CRITICAL, f"FDI: elevator identified stuck at "
                                                           f"{stuck:.3f} rad"))
                self.elevator_stuck_rad = stuck
                self._elevator_trim(t_s, stuck)
            else:
                self._elevator_provisional(t_s)

    def _lateral_detected(self, t_us: int, name: str, ratio: float) -> None:
        """The lateral balance's residual over its threshold on ``name`` with the
        navigation innovations white: an aileron or rudder actuator fault (an episode that
        stays open, as the elevator's)."""
        t_s = t_us * 1e-6
        self.detected = True
        self._quiet_us = None
        ep = Episode(round(t_s, 3), name, name, round(t_s, 3), kind="actuator", isolated_all=[name])
        ep.ident_log = []
        self.episodes.append(ep)
        self.isolated = name
        for ident in self._act_idents:
            ident.freeze(t_us)
        self.elevator.freeze(t_us)
        # the first identification 1 s on (the throttle's on the rotor's speed later: its
        # spin-up or down settled, ThrottleIdentifier.first_ident_s)
        self._ident_next_s = t_s + getattr(self._ident_of(name), "first_ident_s", 1.0)
        self.events.append((t_s, SEV_WARNING, f"FDI: fault detected on {name} "
                                              f"(statistic {ratio:.1f}x threshold)"))
        self.events.append((t_s, SEV_CRITICAL, f"FDI: {name} actuator fault isolated"))
        # the reaction at once, from the deflection flown over the last second: a stuck
        # aileron rolls the aircraft over within seconds (measured: 0.1 rad, 74 deg of bank
        # 4 s after the onset), before the identification
        h = self._ident_of(name).axes[name].hist
        t_end = h[-1][0] - 1_000_000 if h else 0
        zs = [z for (t, z, _) in h if t >= t_end]
        if zs:
            if name == "throttle":
                self._throttle_reaction(t_s, min(max(sum(zs) / len(zs), 0.0), 1.0), final=False)
            else:
                self._lateral_reaction(t_s, name, sum(zs) / len(zs), final=False)

    def _ident_of(self, name: str):
        return next(i for i in self._act_idents if name in i.axes)

    def _throttle_reaction(self, t_s: float, value: float, final: bool) -> None:
        """The reaction to a throttle held at ``value`` (control/fixed_wing.py,
        "throttle out"). Where the model (thrust curve against the level drag) says the
        throttle cannot hold level flight, the aircraft descends at the airspeed, and the
        failsafe is RTL (ArduPlane's RTL, with RTL_AUTOLAND its landing), as ArduPlane's
        battery / throttle failsafes choose; where it can, the height is held on the
        pitch and the airspeed left to float to the fastest level flight the stuck thrust
        gives (``v_top``; TECS's height priority, control/fixed_wing.py,
        TOUT_ARSPD_MAX), or with TOUT_ARSPD_MAX 0 the fastest airspeed from the cruise
        down whose level drag it meets (``v_fly``) flown on the pitch. Said by
        STATUSTEXT."""
        m = self.throttle.model
        # the fastest airspeed, from the cruise (the model's: the Aerosonde's 25 m/s,
        # TRIM_ARSPD's default; the c172p's 45) down to 1.3 times the slowest level flight
        # (the stall margin), where the stuck throttle's thrust still meets the level
        # drag: the airspeed to fly on the pitch
        v_min = 1.3 * (self.airframe.v_level_min_mps if self.airframe is not None else 15.0)
        v_c = m.v_cruise
        v_fly, excess = None, -1e9
        for i in range(51):
            v = v_c - i * (v_c - v_min) / 50.0
            e = m.thrust_at(value, v) - m.level_drag(v)
            if e >= 0.0:
                v_fly, excess = v, e
                break
            excess = max(excess, e)
        level = v_fly is not None
        v = v_fly if level else v_c
        # where the stuck thrust holds level flight, the height is held on the pitch and
        # the airspeed left to float to where that thrust meets the level drag (TECS's
        # height priority, control/fixed_wing.py): ``v_top``, the fastest level flight it
        # gives (at full throttle the airframe's top speed, the Aerosonde's 34.5 m/s).
        # Flying the airspeed on the pitch instead left the height free: stuck at full the
        # aircraft climbed 3 m/s for as long as the flight lasted (638 m over by the
        # default mission's end), at 0.3 it drifted 46 m under and 84 m over the mission's
        # height
        v_top = None
        if level:
            v_top = v
            # (searched to 60 m/s, or the airframe's fastest level flight if faster)
            v_cap = 60.0
            if self.airframe is not None and self.airframe.v_level_max_mps > v_cap:
                v_cap = self.airframe.v_level_max_mps
            while v_top < v_cap and m.thrust_at(value, v_top + 0.5) - m.level_drag(v_top + 0.5) > 0.0:
                v_top += 0.5
        # the glide: at the best lift-to-drag ratio's airspeed, C_L = sqrt(C_D0 / k)
        # (Beard & McLain eq 4.11's polar), the controller never under ARSPD_FBW_MIN
        cl_md = math.sqrt(m.CD0 / m.k_CD)
        v_glide = math.sqrt(2.0 * m.mass_kg * G0 / (RHO0_ISA * m.wing_area_m2 * cl_md))
        self.throttle_out = {"stuck": value, "level": level, "v_glide": v_glide, "v_fly": v,
                             "v_top": v_top}
        sink = max(-excess * v_c / (m.mass_kg * G0), 0.0)
        if level:
            self.events.append((t_s, SEV_WARNING, f"FDI: throttle {'stuck' if final else 'out'} at {value:.2f}: "
                                                  f"height held on the pitch, airspeed free "
                                                  f"(level flight up to {v_top:.0f} m/s)"))
        else:
            self.events.append((t_s, SEV_CRITICAL, f"FDI: throttle {'stuck' if final else 'out'} at {value:.2f}: "
                                                   f"no level flight ({sink:.1f} m/s sink at {v_c:.0f} m/s): "
                                                   f"airspeed on the pitch"
                                                   + (", failsafe RTL" if final else "")))
            # the failsafe on the identification, not on the detection's provisional
            # reading (the first second's deflection carries the onset's transient)
            if final and not self._fs_done:
                self._fs_done = True
                self.failsafe = "RTL"

    def _lateral_reaction(self, t_s: float, name: str, value: float, final: bool) -> None:
        """The reaction the airframe's model gives ``name`` held at ``value`` [rad]:
        the other surface's deflection that holds the wings level (LateralAero.counter;
        for a stuck aileron the roll loop then acts through the rudder, with the
        rolling-moment ratio of the two, LateralAero.roll_gain), and the steepest bank
        the authority left on it gives: ROLL_LIMIT_DEG scaled by the share of its travel
        not used to counter (a decision: the rolling moment of a coordinated turn is
        small, what limits a turn is the margin left to roll out of it), not under
        10 deg. Said by STATUSTEXT at the detection (provisional) and at the stuck
        identification."""
        m = self.lateral_model
        counter, share = self._lateral_counter(name, value)
        other = "rudder" if name == "aileron" else "aileron"
        self.surface_out = {"surface": name, "stuck_rad": value, "counter_rad": counter,
                            "roll_gain": m.roll_gain(name), "authority": share}
        if share <= 0.0:
            self._lateral_no_counter(t_s, name, value, counter, final)
        else:
            what = "roll on the rudder" if name == "aileron" else "yaw damper off"
            self.events.append((t_s, SEV_WARNING, f"FDI: {name} {'stuck' if final else 'out'} at {value:.3f} rad: "
                                                  f"{other} {counter:+.3f} rad to counter, {what}, "
                                                  f"{share:.0%} of its travel left for turns"))

    def _lateral_identify(self, t_s: float, ep: Episode) -> None:
        """Once a second: the surface's identification; stuck latches (said once)."""
        name = ep.isolated
        ident = self._ident_of(name).identified(name, stuck=name in self.stuck_surface)
        if ident is None:
            return
        ep.identified = ident
        ep.ident_log.append((round(t_s, 3), ident))
        stuck = ident.get("stuck_rad", ident.get("stuck"))
        if stuck is not None and name == "throttle":
            if name not in self.stuck_surface:
                self.events.append((t_s, SEV_CRITICAL, f"FDI: throttle identified stuck at {stuck:.2f}"))
                self._throttle_reaction(t_s, stuck, final=True)
            self.stuck_surface[name] = stuck
        elif stuck is not None:
            if name not in self.stuck_surface:
                self.events.append((t_s, SEV_CRITICAL, f"FDI: {name} identified stuck at {stuck:.3f} rad"))
                self._lateral_reaction(t_s, name, stuck, final=True)
            elif self.surface_out is not None:
                # the position refined as the reading settles (a large offset is first read
                # short, the balance's signals low-passed: stuck at 0.3 rad, read 0.095,
                # 0.149, 0.186, 0.256, 0.294 once a second from the first identification);
                # not said again unless nothing can counter it now
                counter, share = self._lateral_counter(name, stuck)
                self.surface_out.update(stuck_rad=stuck, counter_rad=counter, authority=share)
                if share <= 0.0:
                    self._lateral_no_counter(t_s, name, stuck, counter, True)
            self.stuck_surface[name] = stuck

    def _lateral_counter(self, name: str, value: float) -> tuple[float, float]:
        """(the other surface's deflection [rad] that holds the wings level against
        ``name`` held at ``value`` [rad], the share of its travel left after it)."""
        from .actuator import MAX_DEFLECTION_RAD
        counter = self.lateral_model.counter(name, value)
        return counter, 1.0 - abs(counter) / MAX_DEFLECTION_RAD

    def _lateral_no_counter(self, t_s: float, name: str, value: float, counter: float,
                            final: bool) -> None:
        """``name`` held where the other surface cannot hold the wings level: said once;
        flight termination on FDI_LAT_TERM, once identified stuck there (not on the
        detection's provisional reading, which still carries the onset's transient)."""
        other = "rudder" if name == "aileron" else "aileron"
        if not self._lat_none_said:
            self._lat_none_said = True
            self.events.append((t_s, SEV_CRITICAL, f"FDI: {name} stuck at {value:.3f} rad: the {other} "
                                                   f"cannot hold the wings level ({counter:.2f} rad needed)"))
        if final and self.p["FDI_LAT_TERM"] >= 1 and not self.terminate:
            self.terminate = True
            self.events.append((t_s, 0, f"FDI: {name} stuck: the {other} cannot hold the wings "
                                        f"level: flight termination"))

    def _elevator_provisional(self, t_s: float, count: bool = True) -> None:
        """Until the surface is identified stuck: the reaction of the deflection the
        aircraft flies with now (the balance's z over the last second). A stuck surface's
        dive starts at the onset, seconds before the identification, and the least height
        loss needs the reaction then; a weakened one is flown by its pitch loop, and z is
        the deflection that holds the present speed, so its trim speed is about that."""
        if self.elevator_stuck_rad is not None or self.elevator is None:
            return
        h = self.elevator.balance.hist
        if not h:
            return
        t_end = h[-1][0] - 1_000_000
        last = [(t, z) for (t, z, _) in h if t >= t_end]
        z = sum(z for _, z in last) / len(last)
        if len(last) >= 2 and last[-1][0] > last[0][0]:
            # z is the balance of signals low-passed at BAL_TAU_S, which lags the surface
            # by that much (a stuck one's z still 0.013 rad off 2 s after the onset); the
            # first-order filter's input is x = x_lp + tau dx_lp/dt, so the deflection
            # itself, averaged over the same second, is the mean plus tau times the slope
            z += BAL_TAU_S * (last[-1][1] - last[0][1]) / ((last[-1][0] - last[0][0]) * 1e-6)
        self._elevator_trim(t_s, z, final=False, count=count)

    def _elevator_trim(self, t_s: float, stuck: float, final: bool = True, count: bool = True) -> None:
        """The reaction the airframe's model gives an elevator held at ``stuck``
        (docs/monitor.md, "Elevator identification"): its level trim airspeed (the
        speed the throttle's phugoid damping acts about); the steepest level turn, where
        the trim speed of the load factor 1 / cos(bank) reaches the fastest level flight,
        ``cos(bank_max) = (V_trim / V_level_max)^2``; and, where no level trim exists,
        full throttle (the least height loss: at the trim speed the flight-path angle
        grows with the thrust) and, with FDI_EL_TERM, flight termination. Said once, at
        the stuck identification (``final``) or at the NOTRIM_N-th provisional reading in
        a row with no level trim."""
        m = self.airframe
        if m is None:
            return
        v = m.trim_airspeed(stuck)
        none = v is None or v > m.v_level_max_mps
        self.elevator_trim_mps = v
        self.elevator_full_throttle = none
        self.elevator_bank_max_rad = 0.0 if none else math.acos(min((v / m.v_level_max_mps) ** 2, 1.0))
        if not final:
            # a deflection with no level trim for NOTRIM_N provisional readings in a row:
            # the dive needs no identification to be answered (a weakened surface held
            # there is no more flyable than a stuck one)
            if count:
                self._el_notrim_n = self._el_notrim_n + 1 if none else 0
            if self._el_notrim_n < NOTRIM_N or self._el_trim_said:
                return
        elif self._el_trim_said == (none or v < m.v_level_min_mps) + 1:
            return      # (said again only where the identification changed the verdict)
        self._el_trim_said = (none or v < m.v_level_min_mps) + 1
        if none or v < m.v_level_min_mps:
            what = "none" if v is None else f"{v:.0f} m/s"
            if self.p["FDI_EL_TERM"] >= 1:
                self.terminate = True
                self.events.append((t_s, 0, f"FDI: elevator stuck: no level trim ({what}): "
                                            f"flight termination"))
            elif none:
                self.events.append((t_s, SEV_CRITICAL, f"FDI: elevator stuck: no level trim ({what}): "
                                                       f"full throttle, wings level, descending"))
            else:
                self.events.append((t_s, SEV_CRITICAL, f"FDI: elevator stuck: no level trim ({what}, "
                                                       f"under the stall)"))
        else:
            self.events.append((t_s, SEV_WARNING, f"FDI: elevator stuck: level trim {v:.0f} m/s, "
                                                  f"bank up to {math.degrees(self.elevator_bank_max_rad):.0f} deg"))

    def announce(self, t_s: float, severity: int, text: str) -> None:
        """A reaction of the vehicle to a finding of the monitor (e.g. its controller
        reconfigured): into the running fault log, so the log and the ground stations
        get it with the monitor's own messages."""
        self.events.append((t_s, severity, text))

    def _q_hook(self, dt: float):
        """The filter's q_scale_hook: Lambda while an inertial fault is suspected."""
        return self._lam if self.qfade_on else None

    # ------------------------------------------------------------- statistics ---
    def _bias_stats(self, t_us: int) -> None:
        """The bias-estimate change test of the gyros and, with FDI_ACC_STAT, the
        accelerometers (a fault of either is a bias step the filter absorbs): per axis,
        gamma_b = d^2 / (q_b^2 T + sigma_b^2) against chi2_{FDI_ALPHA_B, 1}."""
        if t_us < self._bias_next_us:
            return
        self._bias_next_us = t_us + _BIAS_PERIOD_US
        nav = self.nav
        # (each read of the filter's bias properties builds an array: read once)
        bg = getattr(nav, "gyro_bias", None)
        if bg is None:
            return
        ba = getattr(nav, "accel_bias", None) if self._acc_on else None
        acc = ba is not None
        b = bg.tolist() + (ba.tolist() if acc else [])
        var = (_BIAS_VAR6 if acc else _BIAS_VAR3)(nav.P.diagonal().tolist())
        ring = self._bias_ring
        ring.append((t_us, b, var))
        if len(ring) <= self.bias_n:
            return
        old = ring.pop(0)
        if (t_us - self._aligned_us) < self._bias_wu_us:
            return
        ratios = [0.0] * len(b)
        anchor = self._anchor
        if anchor is not None and len(anchor[1]) == len(b):
            # during an episode: the change since FDI_BIAS_T before the detection,
            # against what a healthy filter allows over that time from the sigma it had
            # then (the fading of Q inflates the present sigma, not this one)
            t_a, b_a, v_a = anchor
            span = (t_us - t_a) * 1e-6 / self.p["FDI_BIAS_T"]
            for i in range(len(b)):
                d = b[i] - b_a[i]
                ratios[i] = d * d / (self._q_T[i] * span + v_a[i]) / self.thr_bias
        else:
            _t, b_old, v_old = old
            q_T, thr = self._q_T, self.thr_bias
            for i in range(len(b)):
                d = b[i] - b_old[i]
                # gamma_b = d^2 / (q_b T + sigma_b^2), sigma_b the larger of its values at
                # the window's ends: a filter that learns a bias moves its estimate by up
                # to the sigma it had before (a consistent filter's change over T has the
                # variance sigma_b(t - T)^2 - sigma_b(t)^2 + q_b T); with the present sigma
                # alone, the lateral accelerometer bias learnt in a turn (0.055 m/s^2 in
                # 2 s, its sigma 0.033 -> 0.010) read 1.1 times the threshold
                ratios[i] = d * d / (q_T[i] + max(var[i], v_old[i])) / thr
        self.bias_ratio = ratios[:3]
        self.accel_ratio = ratios[3:6] if acc else [0.0, 0.0, 0.0]

    def _evaluate(self, t_us: int, armed: bool, scan: bool) -> None:
        """The decisions (detection, isolation, adaptation, failsafe, clearance) on the
        statistics: the aiding channels' scanned again where ``scan`` (update), the bias
        test's where due."""
        self._bias_stats(t_us)
        if scan:
            self._scan = self._scan_aiding(t_us, armed)
        over, over_ratio, busy, iso, iso_ratio, iso_max, iso_over, det_over = self._scan
        iso_over, det_over = list(iso_over), list(det_over)     # (the bias channels join below)
        # the largest statistic per channel while no fault is detected (self.peaks)
        peaks = None if self.detected else self.peaks
        for name, r in zip(_BIASED, self.bias_ratio + self.accel_ratio):
            if peaks is not None and r > peaks.get(name, 0.0):
                peaks[name] = r
            if r > 1.0 and r > over_ratio:
                over, over_ratio = name, r
            if r > iso_max:
                iso_max = r
            if r > 1.0:
                iso_over.append((r, name))
                det_over.append((r, name))
            if r > iso_ratio:
                iso, iso_ratio = name, r
        self._iso_max = iso_max
        t_s = t_us * 1e-6
        if over is not None and not self.detected:
            self.detected = True
            self._quiet_us = None
            if self._bias_ring:
                self._anchor = self._bias_ring[0]
            self.episodes.append(Episode(round(t_s, 3), over))
            self.events.append((t_s, SEV_WARNING, f"FDI: fault detected on {over} "
                                                  f"(statistic {over_ratio:.1f}x threshold)"))
        if not self.detected:
            return
        ep = self.episodes[-1]
        if iso is not None and (ep.isolated is None
                                or (iso in _INERTIAL and ep.isolated not in _INERTIAL
                                    and ep.kind != "actuator")):
            # an inertial fault shows in every aiding innovation, an aiding fault hardly
            # moves the bias estimates: an inertial channel over its threshold overrides
            # an earlier isolation to an aiding channel. Not an actuator's, which the
            # navigation's innovations do not show: there it joins the episode's list
            # (below). Overridden, the stuck elevator's episode became an inertial one,
            # its identification stopped and it cleared (fault_elevator_stuck_launch.toml
            # trial 7, 0.044 rad: accel_z 8.8 s after the detection, in the dive)
            ep.isolated, ep.isolated_s = iso, round(t_s, 3)
            ep.kind = "inertial" if (iso in _INERTIAL or self.qfade_on) else "sensor"
            self.isolated = iso
            self._iso_faded = self.qfade_on      # (taken on faded statistics: _reisolate_gyro)
            # the most to blame first, then every other channel over its threshold now;
            # an inertial fault drives every aiding innovation: those are its symptoms,
            # not faulty channels, and an earlier isolation to one of them is withdrawn
            others = [n for _r, n in sorted(iso_over, reverse=True) if n != iso]
            if iso in _INERTIAL:
                ep.isolated_all = [iso] + [n for n in others if n in _INERTIAL]
            else:
                ep.isolated_all = (ep.isolated_all or []) + [
                    n for n in [iso] + others if n not in (ep.isolated_all or ())]
            also = [n for n in ep.isolated_all if n != iso]
            self.events.append((t_s, SEV_CRITICAL, f"FDI: {iso} fault isolated"
                                + (f"; also {', '.join(also)}" if also else "")))
            if iso in _INERTIAL and self.radapt.active:
                self.radapt.active.clear()
                for ch in self._aiding_list:
                    ch.adapted = False
                self.events.append((t_s, SEV_NOTICE, "FDI: inertial fault: R adaptation off"))
        elif ep.kind == "inertial" and ep.isolated in _GYROS and self._iso_faded:
            self._reisolate_gyro(t_s, ep, iso_over)
        elif ep.isolated is not None and not self.qfade_on and ep.isolated not in _INERTIAL:
            # multi-channel isolation: a further channel over its own *detection*
            # threshold joins the episode's list (the most to blame stays ep.isolated).
            # The isolation test (2.16-2.17, at FDI_ALPHA per test) is one decision
            # taken once a fault is detected; repeated at every sample of an episode
            # that lasts minutes (an actuator's stays open to the flight's end) a
            # healthy channel crosses it by chance: the stuck aileron (seed 2) named
            # gps_vel 250 s into the episode, its detection statistic never over 0.82
            # (seeds 3, 7, 9 alike). A channel joining later is a new finding, held
            # to the test that would have opened an episode of its own (the window test
            # at the level per flight hour, FDI_PFA; the silence; the bias tests, whose
            # detection and isolation statistic is one). Not in an inertial episode: the
            # faded gyro-bias states all move then, and the aiding innovations are the
            # fault's symptoms
            for _r, name in sorted(det_over, reverse=True):
                if name not in ep.isolated_all:
                    ep.isolated_all.append(name)
                    self.events.append((t_s, SEV_CRITICAL, f"FDI: {name} fault isolated too "
                                                           f"({', '.join(ep.isolated_all)})"))
        # sensor or inertial (process) fault: a drift of the velocity innovations
        self._discriminate(t_s)
        # R adaptation: the aiding channels over their threshold in this episode, while
        # it names an aiding channel. Not in an actuator episode that names none: the
        # per-step test (at FDI_ALPHA) repeated over an episode that stays open to the
        # flight's end switched the adaptation on by chance and left it on (the stuck
        # throttle at 0.3, seeds 2, 6, 7: gps_pos 5.7 s, gps_vel 208 s, gps_pos 74 s into
        # the episode, on healthy fixes)
        if (self.radapt_ok and self.isolated is not None and self.isolated not in _INERTIAL
                and not self.qfade_on
                and (ep.kind != "actuator" or any(n in self.aiding for n in ep.isolated_all or ()))):
            for ch in self._aiding_list:
                # the RAKF runs where the per-step statistic says H1 (2.41-2.43)
                if not ch.adapted and not ch.silent and ch.win.chi > ch.win.thr_step:
                    ch.adapted = True
                    self.radapt.active.add(ch.name)
                    self.events.append((t_s, SEV_NOTICE, f"FDI: {ch.name} noise scale adaptation on"))
        # GPS lost: dead reckoning, then the failsafe
        gps = self.aiding["gps_pos"]
        if gps.silent:
            if self._gps_silent_us is None:
                self._gps_silent_us = t_us
            elif (not self._fs_done and self.p["FDI_GPS_FS"] >= 1
                  and t_us - self._gps_silent_us >= self.p["FDI_DR_TIME"] * 1e6):
                self._fs_done = True
                self.failsafe = "RTL"
                self.events.append((t_s, SEV_CRITICAL, "FDI: GPS lost, dead reckoning: failsafe RTL"))
        else:
            self._gps_silent_us = None
        # clearance (an actuator episode stays open: the surface does not heal itself)
        if self.episodes[-1].kind == "actuator":
            return
        if over is None and not busy:
            if self._quiet_us is None:
                self._quiet_us = t_us
            if t_us - self._quiet_us >= self.p["FDI_CLR_T"] * 1e6:
                self._clear(t_s)
        else:
            self._quiet_us = None

    def _scan_aiding(self, t_us: int, armed: bool) -> tuple:
        """The aiding channels' silences and statistics against their thresholds: (the
        channel most over its detection threshold or None, its ratio, any channel silent
        or refilling its window, the one most over its isolation threshold or None, its
        ratio, the largest isolation ratio, [(ratio, channel)] over the isolation
        threshold, [(ratio, channel)] over the detection threshold); the peaks renewed
        while no fault is detected."""
        tout = self.tout_us
        over = None
        over_ratio = 0.0
        busy = False
        iso = None
        iso_ratio = 1.0
        iso_max = 0.0
        iso_over = []                  # (ratio, channel) over the isolation threshold
        det_over = []                  # (ratio, channel) over the detection threshold
        heard = getattr(self.nav, "heard_us", None)
        until = 1 << 62                # the earliest time a channel may fall silent
        peaks = None if self.detected else self.peaks
        for ch in self._aiding_list:
            last = ch.last_us
            # silent: it had been updating regularly (SILENT_RUN updates in a row) and
            # stopped; a source the filter fuses only now and then (the magnetometer
            # where the field is nearly vertical: heading fusion needs B_h^2 / |B|^2 over
            # 0.05) has no rate to fall silent from. A sensor the filter still hears
            # (its samples arriving, fused or not: nav.heard_us) is not silent: where
            # the field's horizontal share hovers about that limit for minutes, runs of
            # fusions longer than SILENT_RUN alternate with gaps over FDI_TOUT (random
            # plane trials 327 and 454, inclination 77.5 deg: 16 `mag` alarms in 2 flights)
            if heard is not None and last is not None:
                h = heard.get(ch.name)
                if h is not None and h > last:
                    last = h
            if last is not None and last + tout < until:
                until = last + tout
            if armed and last is not None and t_us - last > tout and (ch.run >= SILENT_RUN or ch.silent):
                if not ch.silent:
                    ch.silent = True
                    ch.win.reset()
                    ch.rdet = ch.riso = 0.0
                ratio = ir = (t_us - last) / tout
            else:
                if ch.silent:
                    ch.silent = False
                    ch.refill = True
                if ch.refill and ch.win.n >= ch.win.M:
                    ch.refill = False
                ratio = ch.rdet
                ir = ch.riso
            ch.ratio = ratio
            if peaks is not None and ratio > peaks.get(ch.name, 0.0):
                peaks[ch.name] = ratio
            if ch.silent or ch.refill:
                busy = True
            if ratio > 1.0 and ratio > over_ratio:
                over, over_ratio = ch.name, ratio
            if ratio > 1.0:
                det_over.append((ratio, ch.name))
            if ir > iso_max:
                iso_max = ir
            if ir > 1.0:
                iso_over.append((ir, ch.name))
            if ir > iso_ratio:
                iso, iso_ratio = ch.name, ir
        self._eval_armed = armed
        self._eval_until_us = -1 if busy else until
        return over, over_ratio, busy, iso, iso_ratio, iso_max, iso_over, det_over

    def _reisolate_gyro(self, t_s: float, ep: Episode, iso_over: list) -> None:
        """An episode isolated to a gyro names the gyro whose bias estimate has moved most
        since the detection (the statistics against the anchor, FDI_BIAS_T before it), as
        the evidence grows: the first to cross its threshold need not be the faulty one.
        With the gyro-bias states faded all three estimates move at first, and the first
        turn moves the others': a pitch-gyro bias of 0.02-0.03 rad/s, detected on the GPS
        velocity's drift, crossed on gyro_x first (gyro_x 1.4 against gyro_y 1.3 times
        its threshold, 4 s after the onset, the aircraft rolling into a turn), then
        gyro_y led from 7 s on (36 against 11 at 8 s, 160 against 0.1 at 10 s:
        missions/campaigns/fault_gyro_y_bias.toml, trial 1). Another gyro must be
        _REISOLATE_FACTOR times over the isolated one's statistic to take its place: the
        wrong axis can lead by twice for a second or two while the right one catches up
        (trial 26: gyro_x 173 against gyro_y 79 at 8 s after the onset, gyro_y 545 against
        229 at 11 s). Only where the isolation was taken while the gyro-bias states were
        faded: one the bias test took before (a pitch-gyro bias of 0.027 rad/s isolated
        0.2 s after the detection, trial 38) was right, and the fading that came on after
        it moved gyro_x's statistic three times over gyro_y's for 3.6 s. Only among the
        gyros, whose statistics the fading moves alike: an accelerometer's bias is not
        faded, and the faded gyro estimates' statistics outgrew a rightly isolated
        accel_z's three times over and back (fault_accel_z_bias.toml, 9 of its first 24
        trials). ``iso_over``: (statistic, channel) of every channel over its isolation
        threshold now (_evaluate), of which the inertial ones are named with it."""
        ratios = self.bias_ratio
        k = max(range(3), key=ratios.__getitem__)
        best, old = _GYROS[k], ep.isolated
        if best == old or ratios[k] <= _REISOLATE_FACTOR * ratios[_GYROS.index(old)]:
            return
        ep.isolated, ep.isolated_s = best, round(t_s, 3)
        self.isolated = best
        ep.isolated_all = [best] + [n for _r, n in sorted(iso_over, reverse=True)
                                    if n != best and n in _INERTIAL]
        also = [n for n in ep.isolated_all if n != best]
        self.events.append((t_s, SEV_CRITICAL, f"FDI: {best} fault isolated instead of {old}"
                            + (f"; also {', '.join(also)}" if also else "")))

    def _discriminate(self, t_s: float) -> None:
        """Sensor vs inertial fault (module docstring): Q fading on the gyro-bias
        states while the velocity innovations drift; off once they are back under
        their threshold after the fault was isolated to a gyro. Also when the gyro's
        own bias test isolated it before the drift showed, once an episode: without
        the fading the filter took the bias in too slowly, and a pitch-gyro bias of
        0.027 rad/s, isolated 0.2 s after the GPS velocity's detection, flew the
        aircraft into the ground 38 s later (fault_gyro_y_bias.toml, trial 38)."""
        vel = self.aiding["gps_vel"]
        if not self.qfade_on:
            iso = self.isolated
            if (self._lam is not None and not vel.silent
                    and (iso not in _INERTIAL or (iso in _GYROS and self._faded_ep != len(self.episodes)))
                    and vel.rdet > 1.0 and vel.win.mean_share > self.p["FDI_DRIFT"]):
                self.qfade_on = True
                self._faded_ep = len(self.episodes)
                self.episodes[-1].kind = "inertial"
                self.events.append((t_s, SEV_NOTICE, "FDI: velocity innovations drift: inertial fault "
                                                     "suspected, gyro bias fading on (Q adaptation)"))
                if self.radapt.active:
                    self.radapt.active.clear()
                    for ch in self._aiding_list:
                        ch.adapted = False
                    self.events.append((t_s, SEV_NOTICE, "FDI: R adaptation off"))
        elif self.isolated in _GYROS and vel.rdet < 1.0:
            self.qfade_on = False
            self.events.append((t_s, SEV_NOTICE, "FDI: gyro bias absorbed, fading off"))

    def _clear(self, t_s: float) -> None:
        ep = self.episodes[-1]
        self._anchor = None
        if self.qfade_on:
            self.qfade_on = False
            self.events.append((t_s, SEV_NOTICE, "FDI: fading off"))
        ep.end_s = round(t_s, 3)
        self.detected = False
        self._eval_until_us = -1          # the next step evaluates (the peaks resume)
        self.isolated = None
        self._quiet_us = None
        self._fs_done = False
        if self.radapt.active:
            self.radapt.active.clear()
            for ch in self._aiding_list:
                ch.adapted = False
            self.events.append((t_s, SEV_NOTICE, "FDI: back to the optimal filter"))
        self.events.append((t_s, SEV_INFO, f"FDI: fault cleared ({ep.isolated or ep.trigger})"))

    # -------------------------------------------------------------------- log ---
    def log_row(self) -> tuple:
        gps_pos, gps_vel, baro, mag, airspeed = self._aiding_list    # (_AIDING's order)
        iso = CHANNEL_INDEX[self.isolated] if self.isolated is not None else -1
        s = self.radapt.last.get("gps_pos")
        b = self.bias_ratio
        return (float(self.detected), float(iso), self._step_max, gps_pos.ratio, gps_vel.ratio,
                baro.ratio, mag.ratio, airspeed.ratio, self._iso_max, b[0], b[1], b[2],
                float(s.max()) if s is not None else 1.0)

    def thresholds(self) -> dict:
        """The chi-square thresholds in use (for the summary and the report)."""
        out = {name: {"detect": ch.win.thr_det, "step": ch.win.thr_step, "isolate": ch.win.thr_iso}
               for name, ch in self.aiding.items()}
        for name in _BIASED if self._acc_on else _GYROS:
            out[name] = {"bias": self.thr_bias}
        return out
