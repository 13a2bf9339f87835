"""Ground-station service: heartbeat, streams, commands, missions, parameters, arming,
modes and the ground-station failsafe, over TCP / UDP to MAVProxy, MAVSDK, QGC and
pymavlink scripts (the vehicle looks like ArduPilot on the wire: docs/ground-stations.md).

    links.py      sockets: TCP server for many clients, udpout, udpin (bytes only)
    core.py       the protocol core, sans-IO: commands, status, failsafe, stream schedule
    mission.py    the mission service state machine (upload / download / clear / current)
    params.py     the parameter service (list, read, set with echo), GCS parameters
    telemetry.py  what each streamed message says, from the VehicleApi
    tlog.py       the .tlog of the link
    service.py    glue: links + codec + core, polled between lockstep steps
"""
from .links import DEFAULT_URLS, LinkUrlError, parse_url
from .params import GCS_PARAMS, load_lenient
from .service import GcsService

__all__ = ["DEFAULT_URLS", "GCS_PARAMS", "GcsService", "LinkUrlError", "load_lenient", "parse_url"]
