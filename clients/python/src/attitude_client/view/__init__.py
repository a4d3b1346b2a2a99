"""A live view of a running attitude service in Foxglove or Rerun: every vehicle's attitude in 3D, and over time
each body axis's error (against the simulator's truth) with the filter's ±3σ, the effective sample size of the
particle filters and the rejection counts.

    attitude-service demo                                        # or any service; the user runs this
    attitude-view --connect tcp/127.0.0.1:7447                   # then Foxglove: Open connection → ws://localhost:8765
    attitude-view --rerun --connect tcp/127.0.0.1:7447           # or Rerun: a browser at the printed address
    attitude-view --demo [--bin PATH] [-- DEMO OPTIONS]          # starts `attitude-service demo` itself, then the same
    attitude-view --write-layout attitude.json [--layout-vehicles sc1,sc2] [--no-truth]

(installed with the package; the Foxglove server needs the ``view`` extra: ``pip install 'attitude-client[view]'``,
i.e. foxglove-sdk, Python 3.10 or later; the Rerun sink the ``view-rerun`` extra, rerun-sdk, Python 3.11 or later.)
``docs/view.md`` is the user's page: why both, how to run each, what each topic and entity holds.

One place per job: :class:`View` computes every message and hands it to a :class:`Sink`: :class:`FoxgloveSink` for
Foxglove, ``rerun_sink.RerunSink`` for Rerun (the same messages as Rerun entities). The modules, each importing only
those listed before it (the command line imports the Rerun sink only when asked for it):

* :mod:`.geometry` — the arithmetic: quaternions, the attitude error, Euler angles (numpy only);
* :mod:`.schemas` — the topics, the rejection codes and the JSON Schemas of the messages;
* :mod:`.model` — :class:`View`, :class:`Pose` and the :class:`Sink` protocol: what to show, computed once for every
  sink (its docstring: the messages' time and the rate limit);
* :mod:`.foxglove_sink` — :class:`FoxgloveSink` (its docstring: the topics) and the Foxglove layout;
* :mod:`.rerun_sink` — the Rerun sink, its blueprint and its server (its docstring: the entities);
* :mod:`.cli` — :func:`main`, the command ``attitude-view`` (also ``python -m attitude_client.view``).

How it works. One zenoh session follows ``P/<vehicles>/estimate``, ``P/<vehicles>/truth`` and
``P/<vehicles>/rejected`` in one :class:`~attitude_client.MessageStream` (zenoh's callbacks only append the raw
payload to a bounded buffer; everything else happens on the view's thread): :class:`View` turns what it takes into
the view's messages, and the sink serves them to Foxglove (a WebSocket server) or to Rerun (its gRPC server and web
viewer).

The names below are those the single module ``attitude_client.view`` had: ``from attitude_client.view import View``
and the like keep working.
"""

from __future__ import annotations

from .cli import main
from .foxglove_sink import FoxgloveSink, layout, layout_json
from .geometry import error_deg, euler_zyx_deg
from .model import AWAITING_KEPT, AXIS_RGB, DEMO_VEHICLES, GRID_COLUMNS, GRID_SPACING, TRUTHS_KEPT, Pose, Sink, View
from .schemas import (
    REJECTION_CODES, SCENE_TOPIC, SUMMARY_TOPIC, TF_TOPIC, VEHICLE_LEAVES, WORLD, schemas, vehicle_topics,
)

__all__ = [
    "View", "Sink", "Pose", "FoxgloveSink", "REJECTION_CODES", "schemas", "layout", "main", "error_deg",
    "euler_zyx_deg", "vehicle_topics",
    # Public before as well, outside __all__:
    "AWAITING_KEPT", "AXIS_RGB", "DEMO_VEHICLES", "GRID_COLUMNS", "GRID_SPACING", "SCENE_TOPIC", "SUMMARY_TOPIC",
    "TF_TOPIC", "TRUTHS_KEPT", "VEHICLE_LEAVES", "WORLD", "layout_json",
]
