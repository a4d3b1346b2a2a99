"""The Foxglove sink of ``attitude-view`` (the default): the messages of :class:`~attitude_client.view.model.View` on
the channels of a ``foxglove.Context``, and the Foxglove layout that shows them (:func:`layout`; the shipped
``layouts/demo.json`` is :func:`layout_json`). foxglove-sdk (the ``view`` extra: ``pip install
'attitude-client[view]'``, Python 3.10 or later) is imported only when a :class:`FoxgloveSink` is made; the layout
needs nothing.

A Foxglove WebSocket server (foxglove-sdk, ``foxglove.start_server``, started by :mod:`attitude_client.view.cli`;
subprotocol ``foxglove.sdk.v1``, the Foxglove WebSocket protocol under its current name) advertises, per vehicle ``V``
as it appears:

* ``/V/attitude`` — the estimate: ``q``, roll/pitch/yaw (3-2-1, deg), 1σ and 3σ per body axis (deg), gyro bias
  (deg/h), the estimate rate;
* ``/V/error`` — when the simulator publishes ``P/V/truth`` at the estimate's ``t``: the attitude error per body axis
  ``δα = 2·vec(q̂⁻¹ ⊗ q_true)`` (deg, the service's convention, ``proto/README.md``), its angle, ``±3σ``, whether it
  lies inside, the NEES;
* ``/V/diagnostics`` — the filter's own figures: ESS and particles (particle filters), NIS (Kalman filters), updates,
  re-initialisations, gated observations, the service's rejection total;
* ``/V/rejections`` — the inputs the service refused (``P/V/rejected``) since the view started, by code, and the last;

and for all vehicles ``/tf`` (``foxglove.FrameTransforms``: ``world → V`` the estimate, ``world → V/truth`` the truth,
each vehicle at its own place on a grid), ``/scene`` (``foxglove.SceneUpdate``: a body, its axes, the truth's axes and a
label) and ``/summary`` (a row per vehicle, once a second). Custom topics are JSON with a JSON Schema
(:func:`~attitude_client.view.schemas.schemas`); the 3D topics use Foxglove's own schemas (protobuf).
"""

from __future__ import annotations

import json
import math
from typing import Any, Sequence

from .model import AXIS_RGB, DEMO_VEHICLES, GRID_COLUMNS, GRID_SPACING, Pose
from .schemas import SCENE_TOPIC, SUMMARY_TOPIC, TF_TOPIC, VEHICLE_LEAVES, WORLD, schemas, vehicle_topics

__all__ = ["FoxgloveSink", "layout", "layout_json"]


# ----------------------------------------------------------------------------------------------------------------
# The Foxglove sink: a channel per topic of a foxglove.Context (foxglove-sdk)


class FoxgloveSink:
    """The view's messages on Foxglove channels: the JSON topics with their JSON Schemas, ``/tf``
    (``foxglove.FrameTransforms``) and ``/scene`` (``foxglove.SceneUpdate``) from the poses."""

    def __init__(self, context: Any):
        import foxglove
        from foxglove.channels import FrameTransformsChannel, SceneUpdateChannel

        self._fg = foxglove
        self.context = context
        self.schemas = schemas()
        self.channels: dict[str, Any] = {}
        self.tf = FrameTransformsChannel(TF_TOPIC, context=context)
        self.scene_channel = SceneUpdateChannel(SCENE_TOPIC, context=context)
        self.summary_channel = foxglove.Channel(SUMMARY_TOPIC, schema=self.schemas[SUMMARY_TOPIC], context=context)

    def _channel(self, vehicle: str, leaf: str) -> Any:
        topic = vehicle_topics(vehicle)[leaf]
        ch = self.channels.get(topic)
        if ch is None:
            ch = self.channels[topic] = self._fg.Channel(topic, schema=self.schemas[leaf], context=self.context)
        return ch

    def add_vehicle(self, vehicle: str, log_ns: int) -> None:  # noqa: ARG002
        # Every topic of a vehicle is advertised at once, when it first appears: a client (a layout's plot)
        # subscribes to them before their first message.
        for leaf in VEHICLE_LEAVES:
            self._channel(vehicle, leaf)

    def publish(self, vehicle: str, leaf: str, message: dict, log_ns: int) -> None:
        self._channel(vehicle, leaf).log(message, log_time=log_ns)

    def scene(self, poses: list[Pose], log_ns: int, republish: bool) -> None:  # noqa: ARG002 (both alike)
        m = self._fg.messages
        stamp = m.Timestamp(log_ns // 1_000_000_000, log_ns % 1_000_000_000)
        transforms, entities = [], []
        for p in poses:
            x, y, z = p.position
            for frame, q in ((p.vehicle, p.q), (f"{p.vehicle}/truth", p.truth)):
                if q is None:
                    continue
                transforms.append(
                    m.FrameTransform(
                        timestamp=stamp, parent_frame_id=WORLD, child_frame_id=frame,
                        translation=m.Vector3(x=x, y=y, z=z),
                        rotation=m.Quaternion(x=float(q[1]), y=float(q[2]), z=float(q[3]), w=float(q[0])),
                    )
                )
            entities.append(
                m.SceneEntity(
                    timestamp=stamp, frame_id=p.vehicle, id=p.vehicle, frame_locked=True,
                    cubes=[m.CubePrimitive(pose=_pose(m), size=m.Vector3(x=0.9, y=0.6, z=0.45),
                                           color=m.Color(r=0.75, g=0.75, b=0.8, a=0.6))],
                    arrows=_axes(m, length=1.3, diameter=0.07, alpha=1.0),
                )
            )
            if p.truth is not None:
                entities.append(
                    m.SceneEntity(
                        timestamp=stamp, frame_id=f"{p.vehicle}/truth", id=f"{p.vehicle}/truth", frame_locked=True,
                        arrows=_axes(m, length=1.6, diameter=0.03, alpha=0.45),
                    )
                )
            entities.append(
                m.SceneEntity(
                    timestamp=stamp, frame_id=WORLD, id=f"{p.vehicle}/label", frame_locked=True,
                    texts=[m.TextPrimitive(pose=_pose(m, (x, y, z + 1.9)), billboard=True, font_size=14.0,
                                           scale_invariant=True, color=m.Color(r=1, g=1, b=1, a=1), text=p.label)],
                )
            )
        self.tf.log(m.FrameTransforms(transforms=transforms), log_time=log_ns)
        self.scene_channel.log(m.SceneUpdate(entities=entities), log_time=log_ns)

    def summary(self, message: dict, log_ns: int) -> None:
        self.summary_channel.log(message, log_time=log_ns)


def _pose(m: Any, position: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Any:
    return m.Pose(position=m.Vector3(x=position[0], y=position[1], z=position[2]),
                  orientation=m.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0))


#: The orientation of each body axis's arrow (an arrow points along +x of its pose), x y z.
_ARROW_ROTATIONS = (
    (0.0, 0.0, 0.0, 1.0),
    (0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)),  # +90° about z: x → y
    (0.0, -math.sqrt(0.5), 0.0, math.sqrt(0.5)),  # −90° about y: x → z
)


def _axes(m: Any, length: float, diameter: float, alpha: float) -> list:
    out = []
    for (qx, qy, qz, qw), (r, g, b) in zip(_ARROW_ROTATIONS, AXIS_RGB):
        out.append(
            m.ArrowPrimitive(
                pose=m.Pose(position=m.Vector3(x=0.0, y=0.0, z=0.0), orientation=m.Quaternion(x=qx, y=qy, z=qz, w=qw)),
                shaft_length=0.8 * length, shaft_diameter=diameter, head_length=0.2 * length,
                head_diameter=2.5 * diameter, color=m.Color(r=r, g=g, b=b, a=alpha),
            )
        )
    return out


# ----------------------------------------------------------------------------------------------------------------
# The layout (Foxglove's layout file: configById, a mosaic of panels, as "Import from file" takes it)


def _mosaic(direction: str, items: Sequence[Any]) -> Any:
    """A balanced mosaic of ``items`` in ``direction`` (``row``: side by side, ``column``: stacked)."""
    if len(items) == 1:
        return items[0]
    half = len(items) // 2
    return {
        "direction": direction,
        "first": _mosaic(direction, items[:half]),
        "second": _mosaic(direction, items[half:]),
        "splitPercentage": round(100.0 * half / len(items), 2),
    }


_AXIS_COLOURS = {"x": "#e15759", "y": "#59a14f", "z": "#4e79a7"}
_SERIES_COLOURS = ("#4e79a7", "#f28e2c", "#e15759", "#76b7b2", "#59a14f", "#edc949", "#af7aa1", "#ff9da7")


def _path(value: str, label: str, colour: str | None = None, line: float | None = None) -> dict:
    p: dict[str, Any] = {"value": value, "enabled": True, "timestampMethod": "receiveTime", "label": label}
    if colour:
        p["color"] = colour
    if line:
        p["lineSize"] = line
    return p


def _plot(title: str, paths: list[dict]) -> dict:
    return {
        "title": title,
        "paths": paths,
        "showXAxisLabels": True,
        "showYAxisLabels": True,
        "showLegend": True,
        "legendDisplay": "floating",
        "showPlotValuesInLegend": False,
        "isSynced": True,
        "xAxisVal": "timestamp",
        "sidebarDimension": 240,
    }


def layout(vehicles: Sequence[str] = DEMO_VEHICLES, truth: bool = True) -> dict:
    """The Foxglove layout of the view for ``vehicles``: the 3D scene and the summary table on the left; on the
    right a plot per vehicle (``truth``: its error per body axis with ±3σ; otherwise its roll/pitch/yaw and, below,
    its 3σ per body axis), the ESS of every vehicle and the rejections."""
    vehicles = list(vehicles)
    if not vehicles:
        raise ValueError("a layout needs at least one vehicle")
    config: dict[str, Any] = {}
    n_cols = max(1, (len(vehicles) + 3) // 4)  # about four across at most per row
    centre_x = GRID_SPACING * (min(len(vehicles), GRID_COLUMNS) - 1) / 2.0
    config["3D!attitude"] = {
        "followTf": WORLD,
        "followMode": "follow-none",
        "scene": {"transforms": {"showLabel": True, "axisScale": 0.6}},
        "cameraState": {
            "distance": 6.0 + 2.0 * min(len(vehicles), GRID_COLUMNS),
            "perspective": True,
            "phi": 55.0,
            "thetaOffset": 35.0,
            "targetOffset": [centre_x, 0.0, 0.0],
            "target": [0.0, 0.0, 0.0],
            "targetOrientation": [0.0, 0.0, 0.0, 1.0],
            "fovy": 45.0,
            "near": 0.01,
            "far": 5000.0,
        },
        "topics": {TF_TOPIC: {"visible": True}, SCENE_TOPIC: {"visible": True}},
        "layers": {"grid": {"visible": True, "layerId": "foxglove.Grid", "size": 40, "divisions": 40}},
    }
    config["Table!summary"] = {"topicPath": f"{SUMMARY_TOPIC}.vehicles"}
    per_vehicle = []
    for name in vehicles:
        t = vehicle_topics(name)
        if truth:
            paths = []
            for axis, colour in _AXIS_COLOURS.items():
                paths.append(_path(f"{t['error']}.error_deg.{axis}", f"δα {axis}", colour, 1.5))
                paths.append(_path(f"{t['error']}.plus_3sigma_deg.{axis}", f"+3σ {axis}", colour, 0.5))
                paths.append(_path(f"{t['error']}.minus_3sigma_deg.{axis}", f"−3σ {axis}", colour, 0.5))
            pid = f"Plot!error-{name}"
            config[pid] = _plot(f"{name}: attitude error per body axis (deg) and ±3σ", paths)
            per_vehicle.append(pid)
        else:
            angles = [
                _path(f"{t['attitude']}.euler_deg.{a}", a, c)
                for a, c in zip(("roll", "pitch", "yaw"), _AXIS_COLOURS.values())
            ]
            sig = [_path(f"{t['attitude']}.three_sigma_deg.{a}", f"3σ {a}", c) for a, c in _AXIS_COLOURS.items()]
            config[f"Plot!euler-{name}"] = _plot(f"{name}: roll, pitch, yaw (deg)", angles)
            config[f"Plot!sigma-{name}"] = _plot(f"{name}: 3σ per body axis (deg)", sig)
            per_vehicle.append(
                {"direction": "column", "first": f"Plot!euler-{name}", "second": f"Plot!sigma-{name}",
                 "splitPercentage": 60}
            )
    colours = [_SERIES_COLOURS[i % len(_SERIES_COLOURS)] for i in range(len(vehicles))]
    config["Plot!ess"] = _plot(
        "effective sample size (particle filters)",
        [_path(f"{vehicle_topics(n)['diagnostics']}.ess", n, c) for n, c in zip(vehicles, colours)],
    )
    config["Plot!rejections"] = _plot(
        "rejected inputs since the view started",
        [_path(f"{vehicle_topics(n)['rejections']}.total", n, c) for n, c in zip(vehicles, colours)],
    )
    rows = [_mosaic("row", per_vehicle[i : i + n_cols]) for i in range(0, len(per_vehicle), n_cols)]
    right = {
        "direction": "column",
        "first": _mosaic("column", rows),
        "second": _mosaic("row", ["Plot!ess", "Plot!rejections"]),
        "splitPercentage": 72,
    }
    left = {"direction": "column", "first": "3D!attitude", "second": "Table!summary", "splitPercentage": 68}
    return {
        "configById": config,
        "globalVariables": {},
        "userNodes": {},
        "playbackConfig": {"speed": 1},
        "layout": {"direction": "row", "first": left, "second": right, "splitPercentage": 42},
    }


def layout_json(vehicles: Sequence[str] = DEMO_VEHICLES, truth: bool = True) -> str:
    """:func:`layout` as the file's text (the shipped ``layouts/demo.json`` is ``layout_json()``)."""
    return json.dumps(layout(vehicles, truth), indent=2, ensure_ascii=False) + "\n"
