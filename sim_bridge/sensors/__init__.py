"""Sensor models: IMU, GPS, barometer, magnetometer and airspeed from plant truth."""
from .params import SensorParams  # noqa: F401
from .readings import GpsReading, SensorReadings  # noqa: F401
from .suite import SensorSuite  # noqa: F401
