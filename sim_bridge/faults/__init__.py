"""Sensor and actuator fault models (MAV_CMD_INJECT_FAILURE and scenario events)."""
from .catalogue import (  # noqa: F401
    ALL_MAGNITUDES, SUPPORTED, TYPE_NAMES, TYPES, UNIT_NAMES, UNITS, FaultSpecError,
    check_magnitudes, is_supported, type_name, unit_name,
)
from .injector import FaultInjector  # noqa: F401
