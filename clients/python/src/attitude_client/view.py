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

One place per job: :class:`View` computes every message (below) and hands it to a :class:`Sink`:
:class:`FoxgloveSink` here, ``view_rerun.RerunSink`` for Rerun (the same messages as Rerun entities).

How it works. One zenoh session follows ``P/<vehicles>/estimate``, ``P/<vehicles>/truth`` and
``P/<vehicles>/rejected`` in one :class:`~attitude_client.MessageStream` (zenoh's callbacks only append the raw
payload to a bounded buffer; everything else happens on this module's thread). A Foxglove WebSocket server
(foxglove-sdk, ``foxglove.start_server``; subprotocol ``foxglove.sdk.v1``, the Foxglove WebSocket protocol under its
current name) advertises, per vehicle ``V`` as it appears:

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
(:func:`schemas`); the 3D topics use Foxglove's own schemas (protobuf).

Time. Every message is logged at the wall-clock time the view publishes it (ns since 1970, never decreasing), not at
the estimate's ``t``: ``t`` is on each sender's clock (the service never compares it with its own), it differs from
vehicle to vehicle and may start at 0, while Foxglove shows a live connection on one time axis that must advance. The
estimate's ``t`` (and ``seq``) is in every message, for a plot against it or an exact match.

Rate. A vehicle's topics are published at most ``--max-rate`` times a second (default 30; 0: every estimate). The
latest estimate is never lost: one that arrives too soon is held and published when its turn comes, so the view
always ends on the service's last estimate. ``/tf``, ``/scene`` and ``/summary`` are also repeated every
``--republish`` s (default 1) so that a Foxglove connecting later sees every vehicle at once.
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import os
import shlex
import shutil
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping, Protocol, Sequence

import numpy as np

from .client import AttitudeClient
from .estimate import Estimate

__all__ = [
    "View", "Sink", "Pose", "FoxgloveSink", "REJECTION_CODES", "schemas", "layout", "main", "error_deg",
    "euler_zyx_deg", "vehicle_topics",
]

#: The rejection codes of the contract (``proto/README.md``, ``proto/schemas/error.schema.json``; a test keeps the
#: two equal). ``/V/rejections`` counts each of them (zero included) so that a plot has every series from the start.
REJECTION_CODES = (
    "invalid_utf8",
    "invalid_json",
    "bad_request",
    "non_finite",
    "zero_vector",
    "bad_sigma",
    "payload_too_large",
    "batch_too_large",
    "invalid_vehicle_id",
    "unknown_vehicle",
    "not_initialized",
    "too_many_vehicles",
    "out_of_order",
    "duplicate",
    "time_jump",
    "out_of_range",
    "queue_full",
    "mixed_inputs",
    "filter_error",
    "wrong_route",
    "samples_missed",
    "gap",
    "internal",
)

#: Fixed topics (every vehicle's frames and scene, the table).
TF_TOPIC = "/tf"
SCENE_TOPIC = "/scene"
SUMMARY_TOPIC = "/summary"
WORLD = "world"

#: Per-vehicle topics: ``/V/<leaf>``.
VEHICLE_LEAVES = ("attitude", "error", "diagnostics", "rejections")

#: The vehicles of ``attitude-service demo`` (ids and filters), for the shipped layout.
DEMO_VEHICLES = ("sc1", "sc2", "sc3", "sc4")

#: The place of vehicle i in the world frame: a grid GRID_COLUMNS wide, GRID_SPACING m apart.
GRID_COLUMNS = 8
GRID_SPACING = 3.0


def vehicle_topics(vehicle: str) -> dict[str, str]:
    """``{leaf: "/V/leaf"}`` for the per-vehicle topics."""
    return {leaf: f"/{vehicle}/{leaf}" for leaf in VEHICLE_LEAVES}


# ----------------------------------------------------------------------------------------------------------------
# Arithmetic (numpy only; the test holds it against SciPy)


def _wxyz(q: Any) -> np.ndarray:
    if isinstance(q, Mapping):
        return np.array([q["w"], q["x"], q["y"], q["z"]], dtype=float)
    return np.asarray(q, dtype=float)


def _hamilton(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a · b`` of ``[w, x, y, z]`` quaternions."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ]
    )


def error_deg(q_est: Any, q_true: Any) -> tuple[np.ndarray, float]:
    """The attitude error of an estimate against the truth, the service's convention (``proto/README.md``):
    ``δq = q_true ⊗ q̂⁻¹`` (Shuster), i.e. the Hamilton ``q̂⁻¹ · q_true`` with ``w ≥ 0``, and ``δα = 2·vec(δq)``
    about the body axes. Returns ``(δα in deg (3,), the error angle in deg)``."""
    qe = _wxyz(q_est)
    qt = _wxyz(q_true)
    dq = _hamilton(qe * np.array([1.0, -1.0, -1.0, -1.0]), qt)
    dq /= np.linalg.norm(dq)
    if dq[0] < 0:
        dq = -dq
    angle = 2.0 * math.atan2(float(np.linalg.norm(dq[1:])), float(dq[0]))
    return np.degrees(2.0 * dq[1:]), math.degrees(angle)


def euler_zyx_deg(q: Any) -> tuple[float, float, float]:
    """Roll, pitch and yaw (deg) of the body in the reference frame, the 3-2-1 sequence: ``R(q) = Rz(yaw) Ry(pitch)
    Rx(roll)`` (SciPy's ``Rotation.as_euler("ZYX")`` reversed)."""
    w, x, y, z = _wxyz(q) / np.linalg.norm(_wxyz(q))
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return math.degrees(roll), math.degrees(pitch), math.degrees(yaw)


def _xyz(v: Sequence[float]) -> dict[str, float]:
    return {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}


def _quat(q: np.ndarray) -> dict[str, float]:
    return {"w": float(q[0]), "x": float(q[1]), "y": float(q[2]), "z": float(q[3])}


# ----------------------------------------------------------------------------------------------------------------
# The JSON Schemas of the custom topics (their ``title`` is the schema name Foxglove shows)


def _obj(title: str | None, properties: dict[str, Any], required: Iterable[str], description: str = "") -> dict:
    schema: dict[str, Any] = {"type": "object"}
    if title:
        schema["title"] = title
    if description:
        schema["description"] = description
    schema["properties"] = properties
    schema["required"] = list(required)
    return schema


_NUM = {"type": "number"}
_INT = {"type": "integer"}
_STR = {"type": "string"}
_BOOL = {"type": "boolean"}


def _vec(description: str) -> dict:
    return _obj(None, {"x": _NUM, "y": _NUM, "z": _NUM}, ("x", "y", "z"), description)


_QUAT = _obj(None, {"w": _NUM, "x": _NUM, "y": _NUM, "z": _NUM}, ("w", "x", "y", "z"), "[w, x, y, z]: body in reference")
_COMMON = {
    "vehicle": {**_STR, "description": "the vehicle id"},
    "t": {**_NUM, "description": "the estimate's time, s, on the vehicle's clock"},
    "seq": {**_INT, "description": "the estimate's seq (estimates published for the vehicle so far)"},
}


def schemas() -> dict[str, dict]:
    """``{leaf or fixed topic: JSON Schema}`` of the JSON topics: ``attitude``, ``error``, ``diagnostics``,
    ``rejections`` (per vehicle) and ``/summary``."""
    codes = {code: _INT for code in REJECTION_CODES}
    return {
        "attitude": _obj(
            "attitude_view.Attitude",
            {
                **_COMMON,
                "filter": {**_STR, "description": "mekf, usque or qpf, with the fiducial: qpf:average"},
                "q": _QUAT,
                "euler_deg": _obj(
                    None, {"roll": _NUM, "pitch": _NUM, "yaw": _NUM}, ("roll", "pitch", "yaw"),
                    "3-2-1 Euler angles of the body in the reference frame, deg",
                ),
                "sigma_deg": _vec("attitude 1σ per body axis, deg"),
                "three_sigma_deg": _vec("3σ per body axis, deg"),
                "bias_deg_h": _vec("estimated gyro bias, deg/h, body axes"),
                "rate_hz": {**_NUM, "description": "estimates per second of wall time (the last 10 s)"},
                "received": {**_INT, "description": "estimates of this vehicle the view received"},
            },
            ("vehicle", "t", "seq", "filter", "q", "euler_deg", "sigma_deg", "three_sigma_deg", "bias_deg_h",
             "rate_hz", "received"),
            "a vehicle's estimate (P/V/estimate)",
        ),
        "error": _obj(
            "attitude_view.Error",
            {
                **_COMMON,
                "error_deg": _vec("δα = 2·vec(q̂⁻¹ ⊗ q_true) per body axis, deg"),
                "plus_3sigma_deg": _vec("+3σ per body axis, deg"),
                "minus_3sigma_deg": _vec("−3σ per body axis, deg"),
                "angle_deg": {**_NUM, "description": "the error angle, deg"},
                "within_3sigma": {**_BOOL, "description": "every axis's error inside its ±3σ"},
                "nees": {**_NUM, "description": "δαᵀ P⁻¹ δα with P the attitude block of cov (χ²₃ when consistent)"},
                "truth_q": _QUAT,
            },
            ("vehicle", "t", "seq", "error_deg", "plus_3sigma_deg", "minus_3sigma_deg", "angle_deg",
             "within_3sigma", "truth_q"),
            "the estimate against the simulator's truth (P/V/truth) at the same t",
        ),
        "diagnostics": _obj(
            "attitude_view.Diagnostics",
            {
                **_COMMON,
                "filter": _STR,
                "ess": {**_NUM, "description": "effective sample size 1/Σwᵢ² of the last update (particle filters)"},
                "particles": {**_INT, "description": "particle count (particle filters)"},
                "ess_fraction": {**_NUM, "description": "ess / particles"},
                "nis": {**_NUM, "description": "normalised innovation squared of the last update (Kalman filters)"},
                "nis_dof": _INT,
                "propagations": _INT,
                "updates": _INT,
                "resamples": _INT,
                "reinits": {**_INT, "description": "re-initialisations, every cause"},
                "gated": {**_INT, "description": "observations refused by the innovation gate, every sensor"},
                "rollbacks": _INT,
                "held": {**_INT, "description": "samples waiting in the reorder window"},
                "rejected": {**_INT, "description": "the vehicle's inputs the service refused since it exists"},
            },
            ("vehicle", "t", "seq", "filter", "propagations", "updates", "reinits", "gated", "rollbacks", "held",
             "rejected"),
            "what the filter knows about itself (the estimate's diagnostics)",
        ),
        "rejections": _obj(
            "attitude_view.Rejections",
            {
                "vehicle": _STR,
                "total": {**_INT, "description": "rejections (P/V/rejected) since the view started"},
                "by_code": _obj(None, codes, REJECTION_CODES, "the same by code"),
                "last": _obj(None, {"code": _STR, "message": _STR, "key": _STR}, ("code", "message", "key"),
                             "the last rejection"),
            },
            ("vehicle", "total", "by_code", "last"),
            "the vehicle's refused inputs, counted by the view",
        ),
        SUMMARY_TOPIC: _obj(
            "attitude_view.Summary",
            {
                "vehicles": {
                    "type": "array",
                    "items": _obj(
                        None,
                        {
                            "vehicle": _STR,
                            "filter": _STR,
                            "t": _NUM,
                            "seq": _INT,
                            "error_deg": {"type": ["number", "null"], "description": "error angle; null: no truth"},
                            "three_sigma_deg": {**_NUM, "description": "the largest 3σ of the three axes"},
                            "within_3sigma": {"type": ["boolean", "null"]},
                            "ess": {"type": ["number", "null"]},
                            "rejected": {**_INT, "description": "rejections since the view started"},
                            "rate_hz": _NUM,
                        },
                        ("vehicle", "filter", "t", "seq", "error_deg", "three_sigma_deg", "within_3sigma", "ess",
                         "rejected", "rate_hz"),
                    ),
                },
                "dropped": {**_INT, "description": "messages the view dropped because it fell behind"},
            },
            ("vehicles", "dropped"),
            "a row per vehicle",
        ),
    }


# ----------------------------------------------------------------------------------------------------------------
# The view: what to show, computed once for every sink (the transport: Foxglove here, Rerun in view_rerun.py)


@dataclass(frozen=True)
class Pose:
    """What the 3D scene shows of a vehicle: its place on the grid (``position``, m, in ``world``), the estimate
    ``q`` and the truth at the estimate's ``t`` (``[w, x, y, z]``, body in reference; ``truth`` None without one), and
    the label (id, filter, error and 3σ, ESS)."""

    vehicle: str
    position: tuple[float, float, float]
    q: np.ndarray
    truth: np.ndarray | None
    label: str
    t: float
    seq: int


class Sink(Protocol):
    """Where the view's messages go. The messages are those of :func:`schemas` (plain dicts, JSON as published);
    ``log_ns`` is the view's wall clock (ns since 1970, never decreasing)."""

    def add_vehicle(self, vehicle: str, log_ns: int) -> None:
        """A vehicle first heard of: announce its topics before their first message."""

    def publish(self, vehicle: str, leaf: str, message: dict, log_ns: int) -> None:
        """A message of ``/V/<leaf>`` (``attitude``, ``error``, ``diagnostics``, ``rejections``)."""

    def scene(self, poses: list[Pose], log_ns: int, republish: bool) -> None:
        """The 3D state of ``poses`` (one vehicle after its estimate or truth, or every vehicle: ``republish``)."""

    def summary(self, message: dict, log_ns: int) -> None:
        """The ``/summary`` table (``republish_s`` apart)."""


@dataclass
class _Vehicle:
    name: str
    slot: int
    truths: "collections.OrderedDict[float, np.ndarray]" = field(default_factory=collections.OrderedDict)
    received: int = 0
    arrivals: "collections.deque[float]" = field(default_factory=lambda: collections.deque(maxlen=256))
    pending: Estimate | None = None  # the newest estimate, not yet published
    last: Estimate | None = None  # the last estimate published
    last_sent: float = -math.inf  # monotonic time of the last publication
    last_error: dict | None = None  # the /V/error message of `last`, if any
    # Estimates published before their truth came (truth and estimates travel on different keys, from different
    # publishers): the error is published when the truth comes.
    awaiting: "collections.OrderedDict[float, Estimate]" = field(default_factory=collections.OrderedDict)
    rejections: collections.Counter = field(default_factory=collections.Counter)
    last_rejection: dict | None = None
    rejections_pending: bool = False

    def position(self) -> tuple[float, float, float]:
        row, col = divmod(self.slot, GRID_COLUMNS)
        return (GRID_SPACING * col, -GRID_SPACING * row, 0.0)

    def rate_hz(self, now: float) -> float:
        recent = [a for a in self.arrivals if now - a <= 10.0]
        if len(recent) < 2 or recent[-1] <= recent[0]:
            return 0.0
        return (len(recent) - 1) / (recent[-1] - recent[0])


#: Truths kept per vehicle (to match estimates by t), and published estimates waiting for their truth.
TRUTHS_KEPT = 512
AWAITING_KEPT = 64


class View:
    """The view of one service, independent of the transport: feed it ``(key, message)`` pairs (:meth:`handle`) and
    call :meth:`tick`; it computes every message (the arithmetic, the truth matching, the rate limit) and hands them
    to ``sink`` (:class:`FoxgloveSink`, or ``view_rerun.RerunSink``). :meth:`run` does both from a stream."""

    def __init__(self, sink: Sink, prefix: str = "attitude", max_rate: float = 30.0, republish_s: float = 1.0):
        self.sink = sink
        self.prefix = prefix.strip("/")
        self.max_rate = float(max_rate)
        self.republish_s = float(republish_s)
        self.vehicles: dict[str, _Vehicle] = {}
        self._held: set[str] = set()  # vehicles with an estimate or rejections not yet published
        self.malformed = 0
        self.dropped = 0  # set by run() from the stream
        self._last_log_ns = 0
        self._last_republish = -math.inf

    # -- time ------------------------------------------------------------------------------------------
    def _now_ns(self) -> int:
        now = max(time.time_ns(), self._last_log_ns)
        self._last_log_ns = now
        return now

    def _vehicle(self, name: str) -> _Vehicle:
        v = self.vehicles.get(name)
        if v is None:
            v = self.vehicles[name] = _Vehicle(name, len(self.vehicles))
            self.sink.add_vehicle(name, self._now_ns())
        return v

    # -- input -----------------------------------------------------------------------------------------
    def _split(self, key: str) -> tuple[str, str] | None:
        head = self.prefix + "/"
        if not key.startswith(head):
            return None
        parts = key[len(head):].split("/")
        if len(parts) != 2:
            return None
        return parts[0], parts[1]

    def handle(self, key: str, message: Any, now: float | None = None) -> None:
        """One message of the service or the simulator, as received on ``key``."""
        now = time.monotonic() if now is None else now
        split = self._split(key)
        if split is None or not isinstance(message, dict):
            self.malformed += 1
            return
        name, leaf = split
        try:
            if leaf == "estimate":
                self._on_estimate(Estimate.from_json(message), now)
            elif leaf == "truth":
                self._on_truth(name, message, now)
            elif leaf == "rejected" and message.get("code") != "gap":
                # (A gap is told on the same key but is no refusal: the sample was used.)
                self._on_rejected(name, message, now)
        except (KeyError, TypeError, ValueError):
            self.malformed += 1

    def _on_estimate(self, e: Estimate, now: float) -> None:
        v = self._vehicle(e.vehicle)
        v.received += 1
        v.arrivals.append(now)
        v.pending = e
        self._flush(v, now)

    def _on_truth(self, name: str, msg: dict, now: float) -> None:
        v = self._vehicle(name)
        t = float(msg["t"])
        v.truths[t] = _wxyz(msg["q"])
        v.truths.move_to_end(t)
        while len(v.truths) > TRUTHS_KEPT:
            v.truths.popitem(last=False)
        e = v.awaiting.pop(t, None)
        if e is not None:
            log_ns = self._now_ns()
            self._publish_error(v, e, log_ns)
            if e is v.last:
                self.sink.scene([self._pose(v)], log_ns, republish=False)

    def _on_rejected(self, name: str, msg: dict, now: float) -> None:
        v = self._vehicle(name)
        code = str(msg["code"])
        v.rejections[code] += 1
        v.last_rejection = {"code": code, "message": str(msg.get("message", "")), "key": str(msg.get("key", ""))}
        v.rejections_pending = True
        self._flush(v, now)

    # -- output ----------------------------------------------------------------------------------------
    def _due(self, v: _Vehicle, now: float) -> bool:
        return self.max_rate <= 0 or now - v.last_sent >= 1.0 / self.max_rate

    def _flush(self, v: _Vehicle, now: float) -> None:
        if v.pending is None and not v.rejections_pending:
            return
        if not self._due(v, now):
            self._held.add(v.name)
            return
        self._held.discard(v.name)
        v.last_sent = now
        log_ns = self._now_ns()
        if v.pending is not None:
            e, v.pending = v.pending, None
            self._publish_estimate(v, e, log_ns, now)
        if v.rejections_pending:
            v.rejections_pending = False
            self._publish_rejections(v, log_ns)

    def _publish_estimate(self, v: _Vehicle, e: Estimate, log_ns: int, now: float) -> None:
        v.last = e
        v.last_error = None
        label = _filter_label(e)
        sigma = np.asarray(e.sigma_deg, dtype=float)
        roll, pitch, yaw = euler_zyx_deg(e.q)
        bias = np.degrees(e.bias) * 3600.0 if e.bias is not None else np.zeros(3)
        self.sink.publish(
            v.name,
            "attitude",
            {
                "vehicle": v.name,
                "t": e.t,
                "seq": int(e.seq or 0),
                "filter": label,
                "q": _quat(e.q),
                "euler_deg": {"roll": roll, "pitch": pitch, "yaw": yaw},
                "sigma_deg": _xyz(sigma),
                "three_sigma_deg": _xyz(3.0 * sigma),
                "bias_deg_h": _xyz(bias),
                "rate_hz": v.rate_hz(now),
                "received": v.received,
            },
            log_ns,
        )
        d = e.diagnostics
        diag: dict[str, Any] = {
            "vehicle": v.name,
            "t": e.t,
            "seq": int(e.seq or 0),
            "filter": label,
            "propagations": int(d.get("propagations", 0)),
            "updates": int(d.get("updates", 0)),
            "reinits": int(sum((d.get("reinits") or {}).values())),
            "gated": int(sum(g.get("gated", 0) for g in (d.get("gate") or {}).values())),
            "rollbacks": int(d.get("rollbacks", 0)),
            "held": int(d.get("held", 0)),
            "rejected": int(sum((d.get("rejected") or {}).values())),
        }
        for name, cast in (("ess", float), ("particles", int), ("nis", float), ("nis_dof", int), ("resamples", int)):
            if d.get(name) is not None:
                diag[name] = cast(d[name])
        if "ess" in diag and diag.get("particles"):
            diag["ess_fraction"] = diag["ess"] / diag["particles"]
        self.sink.publish(v.name, "diagnostics", diag, log_ns)
        if e.t in v.truths:
            self._publish_error(v, e, log_ns)
        else:
            v.awaiting[e.t] = e
            while len(v.awaiting) > AWAITING_KEPT:
                v.awaiting.popitem(last=False)
        self.sink.scene([self._pose(v)], log_ns, republish=False)

    def _publish_error(self, v: _Vehicle, e: Estimate, log_ns: int) -> None:
        truth = v.truths[e.t]
        err, angle = error_deg(e.q, truth)
        three = 3.0 * np.asarray(e.sigma_deg, dtype=float)
        nees = None
        if e.cov is not None:
            rad = np.radians(err)
            try:
                nees = float(rad @ np.linalg.solve(np.asarray(e.cov)[:3, :3], rad))
            except np.linalg.LinAlgError:
                pass
        msg: dict[str, Any] = {
            "vehicle": v.name,
            "t": e.t,
            "seq": int(e.seq or 0),
            "error_deg": _xyz(err),
            "plus_3sigma_deg": _xyz(three),
            "minus_3sigma_deg": _xyz(-three),
            "angle_deg": angle,
            "within_3sigma": bool(np.all(np.abs(err) <= three)),
            "truth_q": _quat(truth if truth[0] >= 0 else -truth),
        }
        if nees is not None and math.isfinite(nees):
            msg["nees"] = nees
        if e is v.last:
            v.last_error = msg
        self.sink.publish(v.name, "error", msg, log_ns)

    def _publish_rejections(self, v: _Vehicle, log_ns: int) -> None:
        by_code = {code: 0 for code in REJECTION_CODES}
        for code, n in v.rejections.items():
            by_code[code] = n  # a code this version does not know is still counted
        self.sink.publish(
            v.name,
            "rejections",
            {"vehicle": v.name, "total": sum(v.rejections.values()), "by_code": by_code, "last": v.last_rejection},
            log_ns,
        )

    def _pose(self, v: _Vehicle) -> Pose:
        e = v.last
        assert e is not None
        text = f"{v.name}  {_filter_label(e)}"
        if v.last_error is not None:
            text += f"\nerror {v.last_error['angle_deg']:.3g}°  3σ {3.0 * float(np.max(e.sigma_deg)):.3g}°"
        else:
            text += f"\n3σ {3.0 * float(np.max(e.sigma_deg)):.3g}°"
        if e.ess is not None:
            text += f"\nESS {e.ess:.0f}"  # a third line: the labels of neighbours stay apart
        return Pose(v.name, v.position(), np.asarray(e.q, dtype=float), v.truths.get(e.t), text, e.t, int(e.seq or 0))

    def _summary(self, now: float) -> dict:
        rows = []
        for v in self.vehicles.values():
            if v.last is None:
                continue
            e = v.last
            rows.append(
                {
                    "vehicle": v.name,
                    "filter": _filter_label(e),
                    "t": e.t,
                    "seq": int(e.seq or 0),
                    "error_deg": None if v.last_error is None else v.last_error["angle_deg"],
                    "three_sigma_deg": 3.0 * float(np.max(e.sigma_deg)),
                    "within_3sigma": None if v.last_error is None else v.last_error["within_3sigma"],
                    "ess": e.ess,
                    "rejected": sum(v.rejections.values()),
                    "rate_hz": v.rate_hz(now),
                }
            )
        return {"vehicles": rows, "dropped": int(self.dropped)}

    def tick(self, now: float | None = None) -> None:
        """Publishes what is due: held estimates and rejections, and every ``republish_s`` the 3D state of every
        vehicle and the summary."""
        now = time.monotonic() if now is None else now
        for name in list(self._held):
            self._flush(self.vehicles[name], now)
        if now - self._last_republish >= self.republish_s:
            self._last_republish = now
            log_ns = self._now_ns()
            poses = [self._pose(v) for v in self.vehicles.values() if v.last is not None]
            if poses:
                self.sink.scene(poses, log_ns, republish=True)
            self.sink.summary(self._summary(now), log_ns)

    def run(self, stream: Any, stop: threading.Event) -> None:
        """Takes ``(key, message)`` from ``stream`` (a :class:`~attitude_client.MessageStream`) until ``stop`` is
        set, publishing as it goes."""
        tick_s = 0.02 if self.max_rate <= 0 else min(0.02, 0.5 / self.max_rate)
        while not stop.is_set():
            item = stream.get(timeout=tick_s)
            if item is not None:
                self.handle(*item)
                # Take what is buffered before the periodic work, but never for longer than a tick.
                self._take_buffered(stream, tick_s)
            self.dropped = stream.dropped
            self.tick()
        # Stopping: what was already received is still shown, for at most two seconds (a view stopped just
        # after a burst, on a busy machine, otherwise lost the tail it had not yet handled).
        self._take_buffered(stream, 2.0)
        self.dropped = stream.dropped
        self.tick()

    def _take_buffered(self, stream: Any, seconds: float) -> None:
        """Handles what ``stream`` already holds, for at most ``seconds``."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            item = stream.get_nowait()
            if item is None:
                break
            self.handle(*item)


def _filter_label(e: Estimate) -> str:
    if e.filter is None:
        return "?"
    return f"{e.filter}:{e.fiducial}" if e.fiducial else str(e.filter)


#: Body axes: x red, y green, z blue (the colours of both sinks' 3D axes and of the per-axis plots).
AXIS_RGB = ((0.9, 0.15, 0.15), (0.2, 0.8, 0.2), (0.2, 0.4, 1.0))


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


# ----------------------------------------------------------------------------------------------------------------
# The command


def _service_binary(given: str | None) -> str:
    for candidate in (given, os.environ.get("ATTITUDE_SERVICE_BIN")):
        if candidate:
            if not (Path(candidate).is_file() and os.access(candidate, os.X_OK)):
                raise SystemExit(f"attitude-view: {candidate} is not an executable attitude-service")
            return candidate
    found = shutil.which("attitude-service")
    if found is None:
        raise SystemExit(
            "attitude-view: --demo runs `attitude-service demo`, and no attitude-service is on PATH: pass --bin "
            "(e.g. --bin target/release/attitude-service) or set ATTITUDE_SERVICE_BIN"
        )
    return found


def _say(text: str) -> None:
    print(f"attitude-view: {text}", file=sys.stderr, flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    demo_args: list[str] = []
    if "--" in argv:
        cut = argv.index("--")
        argv, demo_args = argv[:cut], argv[cut + 1 :]
    ap = argparse.ArgumentParser(
        prog="attitude-view",
        description="A live view of a running attitude service: in Foxglove (a Foxglove WebSocket server, the default) "
                    "or in Rerun's web viewer (--rerun).",
        epilog="Options after `--` go to `attitude-service demo` (with --demo). docs/view.md has the details.",
    )
    ap.add_argument("--connect", default="tcp/127.0.0.1:7447",
                    help="zenoh endpoint of the service (default tcp/127.0.0.1:7447; with --demo, where the demo listens)")
    ap.add_argument("--prefix", default="attitude", help="the service's key prefix (default attitude)")
    ap.add_argument("--vehicles", default="*",
                    help="the vehicles to follow, one key chunk with zenoh wildcards, e.g. 'sc*' (default: all)")
    ap.add_argument("--sink", choices=("foxglove", "rerun"), default="foxglove",
                    help="foxglove: a Foxglove WebSocket server (default); rerun: Rerun's gRPC server and web viewer")
    ap.add_argument("--rerun", dest="sink", action="store_const", const="rerun", help="the same as --sink rerun")
    ap.add_argument("--host", default="127.0.0.1",
                    help="address the view's servers listen on (default 127.0.0.1; 0.0.0.0 for other machines)")
    ap.add_argument("--port", type=int, default=8765, help="the Foxglove WebSocket server's port (default 8765, Foxglove's)")
    ap.add_argument("--web-port", type=int, default=9090, help="--rerun: the web viewer's HTTP port (default 9090, Rerun's)")
    ap.add_argument("--grpc-port", type=int, default=9876, help="--rerun: the gRPC server's port (default 9876, Rerun's)")
    ap.add_argument("--memory-limit", default="1GiB",
                    help="--rerun: the log the gRPC server keeps for viewers that connect later, beyond which it drops "
                         "the oldest (default 1GiB; e.g. 4GB, 25%%)")
    ap.add_argument("--max-rate", type=float, default=30.0,
                    help="publications per vehicle per second at most (default 30; 0: every estimate). The latest "
                         "estimate is always published")
    ap.add_argument("--republish", type=float, default=1.0,
                    help="seconds between repetitions of the 3D scene and the summary (default 1)")
    ap.add_argument("--buffer", type=int, default=65536,
                    help="messages buffered between zenoh and the view; beyond, the oldest are dropped (default 65536)")
    ap.add_argument("--wait", type=float, default=10.0,
                    help="seconds to wait for the service at start (default 10; the view then runs anyway)")
    ap.add_argument("--demo", action="store_true",
                    help="start `attitude-service demo --listen <--connect>` and view it; the view keeps serving "
                         "after the demo ends, until Ctrl-C")
    ap.add_argument("--bin", help="the attitude-service binary for --demo (default: $ATTITUDE_SERVICE_BIN, then PATH)")
    ap.add_argument("--write-layout", metavar="FILE", type=Path,
                    help="write the Foxglove layout for --layout-vehicles to FILE ('-': standard output) and exit")
    ap.add_argument("--write-blueprint", metavar="FILE", type=Path,
                    help="write the Rerun blueprint for --layout-vehicles to FILE (.rbl) and exit")
    ap.add_argument("--layout-vehicles",
                    help="comma-separated vehicle ids of the layout (default sc1,sc2,sc3,sc4: the demo's; with "
                         "--rerun, the vehicles as they appear)")
    ap.add_argument("--no-truth", action="store_true",
                    help="a layout for vehicles without a truth: roll/pitch/yaw and 3σ instead of the error")
    args = ap.parse_args(argv)

    layout_vehicles = None
    if args.layout_vehicles is not None:
        layout_vehicles = [n.strip() for n in args.layout_vehicles.split(",") if n.strip()]
    if args.write_layout is not None:
        names = layout_vehicles or list(DEMO_VEHICLES)
        text = layout_json(names, truth=not args.no_truth)
        if str(args.write_layout) == "-":
            sys.stdout.write(text)
        else:
            args.write_layout.write_text(text, encoding="utf-8")
            _say(f"wrote {args.write_layout} ({len(names)} vehicles)")
        return 0
    if demo_args and not args.demo:
        ap.error("options after `--` are for --demo")
    if args.max_rate < 0 or args.republish <= 0 or args.buffer < 1:
        ap.error("--max-rate must be ≥ 0, --republish > 0 and --buffer ≥ 1")
    if args.sink == "rerun" or args.write_blueprint is not None:
        try:
            import rerun  # noqa: F401  (rerun-sdk refuses Python before 3.11 with a RuntimeError)

            from . import view_rerun
        except (ImportError, RuntimeError):
            _say("the Rerun view needs rerun-sdk: pip install 'attitude-client[view-rerun]' (Python 3.11 or later)")
            return 2
        if args.write_blueprint is not None:
            names = layout_vehicles or list(DEMO_VEHICLES)
            view_rerun.write_blueprint(args.write_blueprint, names, truth=not args.no_truth)
            _say(f"wrote {args.write_blueprint} ({len(names)} vehicles)")
            return 0
    else:
        try:
            import foxglove
        except ImportError:
            _say("the view needs foxglove-sdk: pip install 'attitude-client[view]' (Python 3.10 or later)")
            return 2

    stop = threading.Event()

    def on_signal(signum, frame):  # noqa: ARG001
        stop.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)

    demo: subprocess.Popen | None = None
    if args.demo:
        binary = _service_binary(args.bin)
        cmd = [binary, "demo", "--listen", args.connect, "--prefix", args.prefix, *demo_args]
        _say("starting " + " ".join(shlex.quote(c) for c in cmd))
        demo = subprocess.Popen(cmd)

    try:
        client = AttitudeClient(args.connect, prefix=args.prefix)
    except Exception as e:  # a malformed endpoint or prefix
        _say(f"cannot open a zenoh session to {args.connect}: {e}")
        if demo is not None:
            demo.send_signal(signal.SIGINT)
            demo.wait()
        return 2
    server = None
    stream = None
    sink: Any = None
    try:
        # Subscribe first, then reach the service: once it answers, it knows the subscriptions.
        stream = client.messages(("estimate", "truth", "rejected"), vehicles=args.vehicles, maxsize=args.buffer)
        deadline = time.monotonic() + args.wait
        while not stop.is_set():
            if demo is not None and demo.poll() is not None:
                _say(f"the demo exited with {demo.returncode} before its service answered")
                return 1
            try:
                client.health(timeout=0.5)
                break
            except TimeoutError:
                if time.monotonic() > deadline:
                    _say(f"no service answered on {args.connect} (prefix {args.prefix}) within {args.wait:g} s; "
                         "waiting for estimates anyway")
                    break
        following = f"following {args.prefix}/{args.vehicles} on {args.connect}"
        if args.sink == "rerun":
            try:
                server = view_rerun.RerunServer(args.host, args.grpc_port, args.web_port, args.memory_limit)
            except (OSError, RuntimeError) as e:
                _say(f"cannot start Rerun's server on {args.host} (ports {args.grpc_port}, {args.web_port}): {e}")
                return 1
            _, sink = view_rerun.open_recording(server, layout_vehicles, truth=not args.no_truth)
            _say(f"Rerun's web viewer on {server.url} (gRPC {server.grpc_url}); {following}. Open the first address "
                 f"in a browser (or a Rerun viewer: rerun {server.grpc_url}).")
        else:
            context = foxglove.Context()
            try:
                server = foxglove.start_server(name="attitude-view", host=args.host, port=args.port, context=context)
            except Exception as e:  # the port is taken, the address is wrong
                _say(f"cannot start the Foxglove WebSocket server on {args.host}:{args.port}: {e}")
                return 1
            sink = FoxgloveSink(context)
            _say(f"Foxglove WebSocket server on ws://{args.host}:{server.port}; {following}. In Foxglove: Open "
                 f"connection → Foxglove WebSocket → ws://localhost:{server.port}, then import the layout "
                 "(attitude-view --write-layout FILE).")
        view = View(sink, prefix=args.prefix, max_rate=args.max_rate, republish_s=args.republish)

        def watch_demo() -> None:
            while not stop.is_set() and demo is not None:
                if demo.poll() is not None:
                    _say(f"the demo ended (exit code {demo.returncode}); still serving what it showed until Ctrl-C")
                    return
                stop.wait(0.2)

        if demo is not None:
            threading.Thread(target=watch_demo, name="demo-watch", daemon=True).start()
        view.run(stream, stop)
        if view.malformed:
            _say(f"{view.malformed} messages were not understood")
    finally:
        if stream is not None:
            stream.close()
        if sink is not None and hasattr(sink, "close"):
            sink.close()  # Rerun: the last messages reach the server before it stops
        if server is not None:
            server.stop()
        client.close()
        if demo is not None and demo.poll() is None:
            demo.send_signal(signal.SIGINT)
            try:
                demo.wait(timeout=10)
            except subprocess.TimeoutExpired:
                demo.kill()
                demo.wait()
    return 0


if __name__ == "__main__":  # python -m attitude_client.view
    sys.exit(main())
