"""Sensor and actuator fault models (MAV_CMD_INJECT_FAILURE and scenario events)."""
from .catalogue import (  # noqa: F401
    SUPPORTED, TYPES, UNITS, FaultSpecError, check_magnitudes, is_supported,
)
from .injector import FaultInjector  # noqa: F401
