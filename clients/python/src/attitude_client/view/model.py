"""The view of ``attitude-view``, independent of the transport: :class:`View` takes the service's messages (estimate,
truth, rejected), computes every message of the view once (the arithmetic, the truth matching, the rate limit) and
hands it to a :class:`Sink` with the 3D state (:class:`Pose`). The sinks
(:class:`~attitude_client.view.foxglove_sink.FoxgloveSink`, :class:`~attitude_client.view.rerun_sink.RerunSink`)
import this module; it imports neither of them.

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

import collections
import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Protocol

import numpy as np

from ..estimate import Estimate
from .geometry import _quat, _wxyz, _xyz, error_deg, euler_zyx_deg
from .schemas import REJECTION_CODES

__all__ = [
    "AWAITING_KEPT", "AXIS_RGB", "DEMO_VEHICLES", "GRID_COLUMNS", "GRID_SPACING", "TRUTHS_KEPT", "Pose", "Sink",
    "View",
]

#: The vehicles of ``attitude-service demo`` (ids and filters), for the shipped layout.
DEMO_VEHICLES = ("sc1", "sc2", "sc3", "sc4")

#: The place of vehicle i in the world frame: a grid GRID_COLUMNS wide, GRID_SPACING m apart.
GRID_COLUMNS = 8
GRID_SPACING = 3.0


# ----------------------------------------------------------------------------------------------------------------
# The view: what to show, computed once for every sink (the transport: foxglove_sink.py, rerun_sink.py)


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
    to ``sink`` (:class:`~attitude_client.view.foxglove_sink.FoxgloveSink`, or
    :class:`~attitude_client.view.rerun_sink.RerunSink`). :meth:`run` does both from a stream."""

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

    def _flush(self, v: _Vehicle, now: float, force: bool = False) -> None:
        if v.pending is None and not v.rejections_pending:
            return
        if not force and not self._due(v, now):
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

    def tick(self, now: float | None = None, force: bool = False) -> None:
        """Publishes what is due: held estimates and rejections, and every ``republish_s`` the 3D state of every
        vehicle and the summary; with ``force`` (the last tick) all of them at once."""
        now = time.monotonic() if now is None else now
        for name in list(self._held):
            self._flush(self.vehicles[name], now, force)
        if force or now - self._last_republish >= self.republish_s:
            self._last_republish = now
            log_ns = self._now_ns()
            poses = [self._pose(v) for v in self.vehicles.values() if v.last is not None]
            if poses:
                self.sink.scene(poses, log_ns, republish=True)
            self.sink.summary(self._summary(now), log_ns)

    def run(self, stream: Any, stop: threading.Event, hurry: threading.Event | None = None,
            say: Callable[[str], None] | None = None) -> int:
        """Takes ``(key, message)`` from ``stream`` (a :class:`~attitude_client.MessageStream`) until ``stop`` is
        set, publishing as it goes; then shows what was received before the stop, unless ``hurry`` is set
        meanwhile. Returns how many received messages were not shown (``hurry``), after telling ``say``."""
        tick_s = 0.02 if self.max_rate <= 0 else min(0.02, 0.5 / self.max_rate)
        while not stop.is_set():
            item = stream.get(timeout=tick_s)
            if item is not None:
                self.handle(*item)
                # Take what is buffered before the periodic work, but never for longer than a tick.
                self._take_buffered(stream, tick_s)
            self.dropped = stream.dropped
            self.tick()
        # Stopping: what was already received is still shown (a view stopped just after a burst, on a busy machine,
        # is behind: its last summary would otherwise not be the service's last estimates). Only what was buffered
        # at the stop, so that a live stream cannot keep it going; a second stop (``hurry``) gives up on the rest.
        left = len(stream)
        started, told = time.monotonic(), False
        while left > 0 and not (hurry is not None and hurry.is_set()):
            item = stream.get_nowait()
            if item is None:
                break
            self.handle(*item)
            left -= 1
            if not told and say is not None and time.monotonic() - started > 1.0:
                say(f"still showing {left} messages received before the stop (stop again to skip them)")
                told = True
        self.dropped = stream.dropped
        self.tick(force=True)
        unshown = max(left, 0) if hurry is not None and hurry.is_set() else 0
        if unshown and say is not None:
            say(f"{unshown} messages received before the stop were not shown (stopped twice)")
        return unshown

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
