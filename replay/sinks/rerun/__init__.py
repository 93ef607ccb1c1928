"""The replay in Rerun: the recording (:mod:`replay.sinks.rerun.sink`), its layouts
(:mod:`replay.sinks.rerun.blueprint`) and live viewing (:mod:`replay.sinks.rerun.live`).

Only live viewing's names are imported here: the sink and the layouts import rerun-sdk,
which a replay without ``--rerun``/``--save``/``--connect``/``--serve`` never loads.
"""

from __future__ import annotations

from replay.sinks.rerun.live import (
    DEFAULT_BIND,
    DEFAULT_GRPC_PORT,
    DEFAULT_WEB_PORT,
    Liveness,
    ViewerServer,
    ViewerUnavailableError,
    check_display,
    check_reachable,
    grpc_address,
    reachable,
)

__all__ = [
    "DEFAULT_BIND",
    "DEFAULT_GRPC_PORT",
    "DEFAULT_WEB_PORT",
    "Liveness",
    "ViewerServer",
    "ViewerUnavailableError",
    "check_display",
    "check_reachable",
    "grpc_address",
    "reachable",
]
