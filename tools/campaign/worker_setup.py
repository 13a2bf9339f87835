"""Set-up of the worker processes a campaign driver starts itself (``sitl campaign run``
without ``--scheduler``): Dask runs ``dask_setup`` in each worker process as it starts
(the worker's ``preload``).

A terminal's Ctrl-C goes to its whole foreground process group, the driver and the
worker processes it started. A worker process that took it died with Dask's tracebacks
on the terminal, and its nanny started another one while the driver was closing the
cluster. Here the local workers ignore SIGINT: the driver alone answers Ctrl-C, drops
the flights in progress (a rerun flies them again) and stops its workers. Workers
started by hand (``dask worker``) keep Dask's own handling."""
from __future__ import annotations

import signal
import threading


def dask_setup(worker) -> None:  # noqa: ARG001 - Dask's preload interface
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
