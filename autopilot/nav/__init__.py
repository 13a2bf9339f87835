"""Navigation: INS/GPS error-state EKF and UKF -> NavState (seed eq 1.22, sec. 2.1).

``InsGpsEkf`` (ekf.py) and ``InsGpsUkf`` (ukf.py, filterpy) share one model and
interface (base.py); the error-state layout is defined once in layout.py, parameters
in config.py (``NAV_PARAMS``), innovation records in records.py. simulate.py is a small
sensor simulator for tests and tuning; ``python -m autopilot.nav.bench`` times them.
"""
from .config import NAV_PARAMS  # noqa: F401
from .ekf import InsGpsEkf  # noqa: F401
from .records import InnovationRecord  # noqa: F401


def __getattr__(name):
    # the UKF pulls in filterpy; import it only when asked for
    if name == "InsGpsUkf":
        from .ukf import InsGpsUkf
        return InsGpsUkf
    raise AttributeError(name)
