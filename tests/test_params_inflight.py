"""Every parameter takes effect after a PARAM_SET in flight, or says it does not.

A ground station may PARAM_SET any parameter of the registry while the vehicle flies.
Each must either take effect at once (read from the store where it is used, or re-read
by the vehicle's ``_param_changed`` / handed on by its ``_param_follow`` to a block that
keeps its own copy) or be declared ``at_start`` (it takes effect at the next start, and
an accepted change is announced with a STATUSTEXT). The class test below flies both
vehicles with a store that records which names are read, then sets every parameter in
turn: a parameter read neither in flight nor when set, and not ``at_start``, fails it,
unless it is one of the few read only in a phase the short flight does not reach
(``PHASE_ONLY``, each with its reason). A parameter added later without either fails it.
"""
import numpy as np
import pytest

import tools.runner as runner
from autopilot.params import ParamStore
from tools.runner import RunConfig, Session

# names read since the last clear: from the store, and from the copies the navigation
# filter and the fault monitor keep of their parameters
_STORE_READS: set = set()
_COPY_READS: set = set()


class _Tracing:
    """Notes every name read (``[name]``, ``.get``; ``items`` reads through ``[]``) in
    the class's ``reads``."""

    __slots__ = ()
    reads: set

    def __getitem__(self, name):
        self.reads.add(name)
        return dict.__getitem__(self, name)

    def get(self, name, default=None):
        self.reads.add(name)
        return dict.get(self, name, default)


class TracingStore(_Tracing, ParamStore):
    """A ParamStore that notes the names read."""

    __slots__ = ()
    reads = _STORE_READS


class TracingCopy(_Tracing, dict):
    """A block's own copy of its parameters, noting the names read."""

    reads = _COPY_READS


# read only in a phase or a mode the short flights below do not reach (and read from the
# store there, or from a copy the block keeps current, when it is flown: a change
# applies from then on)
PHASE_ONLY = {
    # before arming (headless) and the take-off: the launch, its ground steering and
    # its bank limit near the ground, crash detection's launch and ground tests
    "ARM_SETTLE_S", "TKOFF_PITCH", "TKOFF_ALT_TOL", "TKOFF_LVL_BANK", "GROUND_STEER_ALT",
    "GSTEER_KP", "GSTEER_KD", "CRASH_LAUNCH_S", "CRASH_ALT", "CRASH_DELAY_S",
    # fixed-wing: the reactions to a stuck control surface or throttle (a fault found)
    "LOUT_ENABLE", "TOUT_ENABLE", "EOUT_ENABLE",
    # ... loitering (LOITER, GUIDED, a loiter item), RTL, a landing and its go-around,
    # the rangefinder (RNGFND1_TYPE 0 by default)
    "LOITER_RAD", "RTL_ALT", "RTL_AUTOLAND",
    "LAND_FLARE_ALT", "LAND_FLARE_SEC", "LAND_PITCH_DEG", "LAND_PITCH_MAX", "LAND_DISARMDELAY",
    "TECS_LAND_ARSPD", "TECS_LAND_SINK", "LAND_FLR_CLMB_KP", "LAND_FLR_LAG", "TECS_LAND_SRC",
    "TECS_LAND_SPDWGT", "LAND_ABORT_ALT", "LAND_AB_CHK_ALT", "LAND_AB_HIGH", "LAND_AB_LOW",
    "LAND_AB_XTRK", "LAND_AB_SPD", "RNGFND_LANDING", "RNGFND1_MIN_CM", "RNGFND1_MAX_CM",
    "RNGFND1_GNDCLEAR",
    # the monitor's failsafes, terminations, clearance and drift test: read from its copy
    # only once a fault is found (FaultMonitor.set_param keeps the copy current)
    "FDI_EL_TERM", "FDI_LAT_TERM", "FDI_GPS_FS", "FDI_DR_TIME", "FDI_CLR_T", "FDI_DRIFT",
    # quadrotor: on the ground, the pilot modes, RTL, LAND and the land detector; the
    # speed when the reference starts its next leg
    "QD_SPIN_ARM", "Q_RTL_ALT", "RTL_ALT_FINAL", "LAND_SPEED", "LAND_ALT_LOW", "LAND_DET_S",
    "PILOT_THR_HOV", "PILOT_SPEED_UP", "WPNAV_RADIUS", "WPNAV_SPEED",
    # both: the geofence (read while one is enabled or breached) and the rally points (RTL)
    "FENCE_TYPE", "FENCE_ACTION", "FENCE_ALT_MAX", "FENCE_ALT_MIN", "FENCE_RADIUS",
    "FENCE_MARGIN", "RALLY_LIMIT_KM", "RALLY_INCL_HOME",
    # the ground-station failsafe: armed, flying, once a ground station has been seen
    "FS_GCS_ENABL", "FS_GCS_TIMEOUT",
    # the filter: its alignment (before the flight; again after a reset), a source
    # rejected for long (the resets, the health's timeout), the declination given by hand
    # (EK_MAG_AUTODEC 0 only)
    "EK_ALIGN_T", "EK_ALIGN_GSPD", "EK_GPS_RST_T", "EK_ARSP_RST_T", "EK_REJ_TOUT", "EK_MAG_DEC",
}
# declared by the quadrotor (the filter's parameters are both vehicles') but unused: it
# has no airspeed sensor and no wind state
QUAD_UNUSED = {"EK_WIND_NSE", "EK_ARSP_NSE", "EK_ARSP_GATE", "EK_ARSP_RST_T", "EK_ARSP_MIN",
               "EK_BETA_NSE", "EK_BETA_GATE"}


def _other(decl, value: float) -> float:
    """A value of ``decl``'s range other than ``value``."""
    new = decl.max if value != decl.max else decl.min
    if decl.is_int:
        new = float(int(new))
    return new


def _fly(cfg: RunConfig, watch_from_s: float, watch_to_s: float, monkeypatch):
    """The session of ``cfg`` flown to ``watch_to_s`` with a tracing store; the names read
    between ``watch_from_s`` and then (store, copies)."""
    monkeypatch.setattr(runner, "ParamStore", TracingStore)
    s = Session(cfg)
    v = s.vehicle
    v.autostart = True                  # (serving ground stations, it flies by itself)
    filt = getattr(v.nav, "filt", v.nav)
    filt.params = TracingCopy(filt.params)
    mon = v.monitor
    if hasattr(mon, "p"):
        mon.p = TracingCopy(mon.p)
    while s.t_s < watch_from_s:
        s.step()
    assert v.armed and not v.landed, "the vehicle should be flying by now"
    _STORE_READS.clear()
    _COPY_READS.clear()
    while s.t_s < watch_to_s:
        s.step()
    return s, set(_STORE_READS), set(_COPY_READS)


def _audit(s: Session, store_reads: set, copy_reads: set) -> list[str]:
    """Set every parameter to another value in flight: the names neither read in flight
    nor when set, nor at_start nor phase-only (the class's failures)."""
    v = s.vehicle
    filt = getattr(v.nav, "filt", v.nav)
    copies = [filt.params] + ([v.monitor.p] if hasattr(v.monitor, "p") else [])
    bad = []
    for name in s.params.names():
        decl = s.params.declaration(name)
        old = dict.__getitem__(s.params, name)
        new = _other(decl, old)
        if name == "FENCE_ACTION":
            new = 0.0 if old != 0 else 1.0         # (every vehicle takes these two)
        n_notices = len(v.notices)
        _STORE_READS.clear()
        _COPY_READS.clear()
        assert v.set_param(name, new) is None, name
        set_reads = _STORE_READS | _COPY_READS
        if decl.at_start:
            # stored, said, and left alone by the blocks built from it
            assert dict.__getitem__(s.params, name) == new
            assert v.notices[n_notices:] and v.notices[-1][2] == f"{name} set: takes effect at the next start"
            assert all(dict.__getitem__(c, name) == old for c in copies if name in c), name
        else:
            assert len(v.notices) == n_notices, name
            # a copy that is read follows the store
            for c in copies:
                if name in c:
                    assert dict.__getitem__(c, name) == new, name
            unused = QUAD_UNUSED if v.vehicle_kind == "quad" else set()
            if name not in store_reads | copy_reads | set_reads | PHASE_ONLY | unused:
                bad.append(name)
        assert v.set_param(name, old) is None
    return bad


def test_phase_only_names_are_declared_and_not_at_start():
    from autopilot.gcs import GCS_PARAMS
    from autopilot.vehicle import plane_param_declarations
    from autopilot.vehicle_quad import quad_param_declarations
    decls = {p.name: p for p in plane_param_declarations() + quad_param_declarations()
             + list(GCS_PARAMS)}
    assert PHASE_ONLY <= set(decls)
    assert not [n for n in PHASE_ONLY if decls[n].at_start]


@pytest.mark.parametrize("vehicle, t0, t1", [("plane", 40.0, 60.0), ("quad", 25.0, 40.0)])
def test_every_parameter_applies_in_flight_or_is_at_start(vehicle, t0, t1, monkeypatch):
    """GIVEN a vehicle flying its default mission; WHEN each parameter is set to another
    value; THEN it is read in flight or when set (it applies at once), or it is declared
    at_start (stored, announced, its blocks unchanged), or read only in a phase the
    flight does not reach (PHASE_ONLY)."""
    # (serving ground stations on a free port: their service's parameters too)
    cfg = RunConfig(vehicle=vehicle, seed=1, duration_s=t1 + 10.0, gcs=("tcpin:127.0.0.1:0",))
    s, store_reads, copy_reads = _fly(cfg, t0, t1, monkeypatch)
    assert "FS_GCS_TIMEOUT" in s.params
    try:
        bad = _audit(s, store_reads, copy_reads)
    finally:
        s.close()
    assert not bad, f"set in flight, these take effect only at the next start: {bad}"


# ------------------------------------------------- representative effects, in numbers ---
def _fly_to(s: Session, t_s: float) -> None:
    while s.t_s < t_s:
        s.step()


def test_fixed_wing_fdi_tout_and_trim_arspd_set_in_flight_take_effect():
    """GIVEN the fixed-wing flying the default mission, the GPS to stop at 100 s
    (missions/fault_gps_off.toml); WHEN at 60 s a ground station sets FDI_TOUT 0.5 -> 3 s
    (the fault monitor's silence timeout, copied when it is built) and TRIM_ARSPD 25 ->
    27 m/s (the cruise airspeed the mission sequencer took at arming); THEN the silent GPS
    is flagged 3 s after its last fix, not 0.5 s, and the airspeed demand is 27 m/s from
    the set on."""
    from tools.runner import MISSIONS_DIR
    s = Session(RunConfig(scenario=MISSIONS_DIR / "fault_gps_off.toml", seed=1, duration_s=120.0))
    try:
        _fly_to(s, 60.0)
        v = s.vehicle
        assert v.params["FDI_TOUT"] == 0.5 and v.params["TRIM_ARSPD"] == 25.0
        n = len(v.notices)
        assert v.set_param("FDI_TOUT", 3.0) is None
        assert v.set_param("TRIM_ARSPD", 27.0) is None
        assert len(v.notices) == n                  # (applied at once: nothing to say)
        t_set = s.t_s
        _fly_to(s, 106.0)
        ep = v.monitor.episodes
        assert ep and ep[0].trigger == "gps_pos", v.monitor.events
        # the last fix at 100.0 s (5 Hz): flagged on the first step 3 s after it
        assert 102.9 <= ep[0].start_s <= 103.3, ep[0].start_s
        a = s.log.arrays()
        t, tgt = a["t_s"], a["tgt_airspeed_mps"]
        assert np.all(tgt[(t > 45.0) & (t < t_set)] == 25.0)
        assert np.all(tgt[(t > t_set) & (t < 100.0)] == 27.0)
    finally:
        s.close()


def _quad_sigma_vn(set_at_s: float | None) -> tuple[np.ndarray, np.ndarray]:
    """The quadrotor's default mission to 30 s, EK_ACC_NSE set 0.05 -> 0.5 m/s^2 at
    ``set_at_s`` (None: never): the log's times and 1-sigma north velocity."""
    s = Session(RunConfig(vehicle="quad", seed=1, duration_s=60.0))
    try:
        if set_at_s is not None:
            _fly_to(s, set_at_s)
            assert s.vehicle.armed and s.vehicle.params["EK_ACC_NSE"] == 0.05
            assert s.vehicle.set_param("EK_ACC_NSE", 0.5) is None
        _fly_to(s, 30.0)
        a = s.log.arrays()
        return a["t_s"], a["sig_vn_mps"]
    finally:
        s.close()


def test_quad_filter_noise_set_in_flight_takes_effect():
    """GIVEN the quadrotor flying its default mission; WHEN at 25 s EK_ACC_NSE (the
    filter's accelerometer noise, from which it works out its process noise) is set
    0.05 -> 0.5 m/s^2; THEN the filter's velocity uncertainty grows at once: the same
    flight as without the set up to 25 s, and from there a 1-sigma north velocity more
    than 1.4 times larger on average over the next 5 s (its GPS velocity fusions at 5 Hz
    hold it down)."""
    t0, sig0 = _quad_sigma_vn(None)
    t1, sig1 = _quad_sigma_vn(25.0)
    before, after = (t0 > 20.0) & (t0 <= 25.0), (t0 > 25.05) & (t0 <= 30.0)
    assert np.array_equal(t0, t1) and np.array_equal(sig0[before], sig1[before])
    ratio = float(np.mean(sig1[after]) / np.mean(sig0[after]))
    assert ratio > 1.4, ratio


# ------------------------------------------------------------ on the wire, exactly ---
def test_an_at_start_parameter_set_over_mavlink_is_stored_and_announced(tmp_path):
    """GIVEN a vehicle serving ground stations over TCP (a real ``sitl run --gcs``) and a
    pymavlink client; WHEN it sets FDI_BIAS_T (at_start) 4 -> 8 s; THEN the PARAM_VALUE
    echo carries 8, every ground station gets the STATUSTEXT NOTICE "FDI_BIAS_T set:
    takes effect at the next start", and the store keeps 8; a parameter that applies at
    once (NAVL1_PERIOD) is echoed with no such STATUSTEXT, and setting FDI_BIAS_T to the
    value it has says nothing."""
    from test_gcs_support import Sitl, connect, wait_for

    store = tmp_path / "store.parm"
    s = Sitl(tmp_path / "run", store=store)
    try:
        m = connect(s.url)
        said = lambda t: lambda msg: msg.text.startswith(t)  # noqa: E731
        m.mav.param_set_send(1, 1, b"NAVL1_PERIOD", 19.0, 9)
        echo = wait_for(m, "PARAM_VALUE", 5.0, lambda p: p.param_id == "NAVL1_PERIOD")
        assert echo is not None and echo.param_value == 19.0
        assert wait_for(m, "STATUSTEXT", 1.0, said("NAVL1_PERIOD")) is None
        m.mav.param_set_send(1, 1, b"FDI_BIAS_T", 8.0, 9)
        echo = wait_for(m, "PARAM_VALUE", 5.0, lambda p: p.param_id == "FDI_BIAS_T")
        assert echo is not None and echo.param_value == 8.0
        text = wait_for(m, "STATUSTEXT", 5.0, said("FDI_BIAS_T"))
        assert text is not None
        assert text.text == "FDI_BIAS_T set: takes effect at the next start"
        assert text.severity == 5                          # MAV_SEVERITY_NOTICE
        m.mav.param_set_send(1, 1, b"FDI_BIAS_T", 8.0, 9)    # the same value again
        assert wait_for(m, "PARAM_VALUE", 5.0, lambda p: p.param_id == "FDI_BIAS_T").param_value == 8.0
        assert wait_for(m, "STATUSTEXT", 1.0, said("FDI_BIAS_T")) is None
        m.close()
    finally:
        s.stop()
    assert "FDI_BIAS_T       8" in store.read_text()
