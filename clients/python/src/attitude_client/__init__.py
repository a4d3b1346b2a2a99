"""Python client of the attitude service: estimates as numpy arrays, IMU samples from numpy arrays.

    from attitude_client import AttitudeClient
    with AttitudeClient("tcp/127.0.0.1:7447") as client:
        e = client.estimate("sc1")          # the latest estimate of vehicle sc1
        print(e.q, e.sigma_deg)             # [w, x, y, z] (body → reference), 1σ per body axis in degrees
        print(e.rotation().as_euler("ZYX", degrees=True))   # with SciPy installed

:mod:`attitude_client.client` has the conventions and the whole API; :mod:`attitude_client.estimate` the
quaternion order and frames; :mod:`attitude_client.replay` replays a recorded IMU trial (``attitude-replay``).
"""

from importlib import metadata as _metadata

from .client import (
    CACHE, HEARTBEAT_S, IMU_BATCH, KINDS, ROUTES, AttitudeClient, ServiceError, attitude_error_deg, route_of,
)
from .estimate import Estimate, attitude_matrix
from .stream import EstimateStream, MessageStream

try:
    __version__ = _metadata.version("attitude-client")
except _metadata.PackageNotFoundError:  # imported from a source tree that is not installed
    __version__ = "0+unknown"

__all__ = [
    "AttitudeClient",
    "CACHE",
    "Estimate",
    "EstimateStream",
    "HEARTBEAT_S",
    "IMU_BATCH",
    "KINDS",
    "MessageStream",
    "ROUTES",
    "ServiceError",
    "attitude_error_deg",
    "attitude_matrix",
    "route_of",
    "__version__",
]
