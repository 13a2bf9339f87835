"""Onboard fault monitor (seed ch. 8 sec. 2.2-2.3): chi-square detection on the
navigation filter's normalised innovations, isolation by per-channel variance
statistics and gyro-bias watch, R adaptation (robust KF with noise scale factors),
STATUSTEXT-ready events and the GPS-lost failsafe. See :mod:`.monitor`."""
from .monitor import (CHANNELS, FDI_PARAMS, LOG_COLUMNS, SEV_CRITICAL, SEV_INFO, SEV_NOTICE,
                      SEV_WARNING, Episode, FaultMonitor)
from .radapt import RAdapter
from .stats import WindowChi2, chi2_threshold

__all__ = ["CHANNELS", "FDI_PARAMS", "LOG_COLUMNS", "SEV_CRITICAL", "SEV_INFO", "SEV_NOTICE",
           "SEV_WARNING", "Episode", "FaultMonitor", "RAdapter",
           "WindowChi2", "chi2_threshold"]
