"""The client: a zenoh session speaking the attitude service's JSON messages (contract v1, ``proto/README.md``).

    from attitude_client import AttitudeClient
    with AttitudeClient("tcp/127.0.0.1:7447") as client:
        client.wait_for_service()
        client.reset("sc1", filter="mekf", q=(1, 0, 0, 0), sigma_deg=0.1, t=0.0)
        print(client.get_attitude("sc1"))  # {'vehicle': 'sc1', 't': 0.0, 'q': {'w': 1.0, ..}, 'sigma_deg': [..]}

Two levels. The typed one speaks numpy: :meth:`AttitudeClient.estimate` returns an
:class:`~attitude_client.Estimate` (``q`` as ``[w, x, y, z]``, ``cov`` 6×6, ``.rotation()`` for SciPy),
:meth:`AttitudeClient.estimates` iterates over estimates as they are published (also ``async for``), and
:meth:`AttitudeClient.publish_imu` takes one sample or whole arrays (``t`` (n,), ``gyr``/``acc``/``mag``
(n, 3)), batched for you. The wire level returns the service's JSON as parsed: ``get_attitude``,
``get_state``, ``get_all``, ``vehicles``, ``health``, ``reset`` and the ``subscribe_*`` callbacks.

Measurements go in with ``publish_gyro(vehicle, t, omega)`` / ``publish_gyro_batch`` and
``publish_vectors(vehicle, t, [(body, ref, sigma), ...])`` / ``publish_vectors_batch``, or, for a vehicle
with a raw IMU, ``publish_imu(vehicle, t, gyr, acc, mag)`` instead (the service derives the references and
noise models itself; a vehicle is fed either gyro samples or IMU samples, never both). Every vector accepts
a list, a tuple or a numpy array. Puts are asynchronous: the service processes them after they arrive, so
a query right after a put may not reflect it yet (wait for its estimate instead). On a new session, call
:meth:`AttitudeClient.wait_for_service` before publishing: zenoh drops puts that it does not know a
subscriber for yet.

Inputs go through zenoh-ext **advanced publishers** (one per key, made at its first put): each put carries a
sequence number, the last ``cache`` puts of each key stay in the client's memory, and a heartbeat every
``heartbeat_s`` tells the service the newest number. A put lost on the way (a link that drops, a reconnection, a
restart of the service within the cache) is then detected by the service and fetched again from the cache;
what cannot be is reported on ``P/V/rejected`` (``samples_missed``). ``recovery=False`` sends plain puts instead
(``proto/README.md``, "Loss, recovery and back-pressure"). Puts use congestion control ``BLOCK``: a service
that cannot keep up slows the sender rather than losing its puts.

Keys are ``P/V/<leaf>`` with ``P`` the service's key prefix (``prefix``, default ``attitude``) and ``V`` a
vehicle id (1-64 characters of ``[A-Za-z0-9_-]``). With ``routed=True`` (for a dynamic fleet of services,
``serve --fleet``) inputs go on their routed keys ``P/V/<leaf>/<r>`` instead, ``r`` the vehicle's route
(:func:`route_of`), and the client also sends them batched per route for the fleet's standby members
(``P/@/standby/<r>/inputs``, every ``flush_s``): each input then reaches the route's owner and its standby
members only, not every member (``proto/README.md``, Routed inputs). A single service takes routed inputs
too. Quaternions on the wire are ``{"w", "x", "y", "z"}``:
the orientation of the body in the reference frame (Hamilton), i.e. ``b = A(q) r`` with ``A(q)`` the
transpose of the Hamilton rotation matrix of ``q``. Replies normalise ``w >= 0``.

Queries raise :class:`ServiceError` for an error reply of the service (``code``, ``message``, ``key``;
codes are listed in ``proto/README.md``, e.g. ``unknown_vehicle``, ``not_initialized``, ``bad_request``);
a query that nobody answers before its timeout raises :class:`TimeoutError`. Concrete queries are retried
until their timeout when no queryable is reachable yet (right after the session opens, before zenoh has
propagated the service's declarations), so a client may be created before the service runs;
:meth:`AttitudeClient.wait_for_service` waits explicitly.

Subscription callbacks run on zenoh's threads: keep them short (append to a list, put into a
``queue.Queue``) and never call blocking client methods from them (:meth:`AttitudeClient.estimates` does
that for you). Close the client (or use it as a context manager); a client still open when the
interpreter exits is closed then, because zenoh's callback thread would otherwise keep the process alive.
"""

from __future__ import annotations

import json
import logging
import math
import struct
import threading
import time
import weakref
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np
import zenoh
import zenoh.ext

from .estimate import Estimate
from .stream import EstimateStream, MessageStream, recovering_subscriber

__all__ = [
    "AttitudeClient", "ServiceError", "KINDS", "IMU_BATCH", "ROUTES", "CACHE", "HEARTBEAT_S", "attitude_error_deg",
    "route_of",
]

log = logging.getLogger("attitude_client")

#: Leaves that answer per-vehicle queries (``P/V/<kind>``, also as ``P/*/<kind>``).
KINDS = ("attitude", "covariance", "state")

_JSON = zenoh.Encoding.APPLICATION_JSON

#: IMU samples per put when :meth:`AttitudeClient.publish_imu` is given arrays: about 150 bytes each,
#: well inside the service's default ``limits.input`` (1 MiB, 10 000 items per batch).
IMU_BATCH = 500


#: Puts kept per input key for the service to fetch again (advanced publishers): at ``IMU_BATCH`` samples per put
#: and 100 Hz, over 20 minutes of a vehicle's samples; 256 puts of 500 samples are about 20 MB.
CACHE = 256

#: Seconds between an advanced publisher's heartbeats (sent only when it put something since): the longest
#: before the service notices that the last put of a burst was lost and fetches it.
HEARTBEAT_S = 0.25

#: Routes of the vehicles: a routed key's last chunk is one of ``0``..``f``.
ROUTES = 16

#: The input leaves (what ``routed=True`` sends on routed keys).
_INPUTS = ("gyro", "vectors", "imu")

_M64 = (1 << 64) - 1


def route_of(vehicle: str) -> int:
    """The route of ``vehicle`` (0-15): SplitMix64's finaliser of the 64-bit FNV-1a of its id's UTF-8 bytes,
    mod 16 (``proto/README.md``, Routed inputs; the service computes the same)."""
    h = 0xCBF29CE484222325
    for b in vehicle.encode():
        h = ((h ^ b) * 0x100000001B3) & _M64
    h = ((h ^ (h >> 30)) * 0xBF58476D1CE4E5B9) & _M64
    h = ((h ^ (h >> 27)) * 0x94D049BB133111EB) & _M64
    h ^= h >> 31
    return h % ROUTES


def _record(vehicle: str, leaf: str, payload: bytes) -> bytes:
    """One record of a standby batch: u16 key length, key ``V/<leaf>``, u32 payload length, payload."""
    key = f"{vehicle}/{leaf}".encode()
    return struct.pack("<H", len(key)) + key + struct.pack("<I", len(payload)) + payload


#: Codes the service tells on ``P/V/rejected`` that are no refusal (the input was used; proto/README.md, "Errors").
EVENT_CODES = frozenset({"gap"})


class ServiceError(Exception):
    """An error reply of the service: a stable ``code``, a readable ``message`` and the ``key`` concerned."""

    def __init__(self, code: str, message: str, key: str | None = None):
        super().__init__(f"{code}: {message}" + (f" ({key})" if key else ""))
        self.code = code
        self.message = message
        self.key = key

    def __repr__(self) -> str:
        return f"ServiceError(code={self.code!r}, message={self.message!r}, key={self.key!r})"


def _vec3(v: Any, what: str) -> list[float]:
    """Three floats from any sequence (list, tuple, numpy array)."""
    out = [float(x) for x in v]
    if len(out) != 3:
        raise ValueError(f"{what} must have 3 components, got {len(out)}")
    return out


def _observation(o: Any) -> dict:
    """An observation from a dict ``{body, ref, sigma[, sensor]}`` or a tuple ``(body, ref, sigma[, sensor])``."""
    if isinstance(o, Mapping):
        body, ref, sigma, sensor = o["body"], o["ref"], o["sigma"], o.get("sensor")
    else:
        if len(o) not in (3, 4):
            raise ValueError("an observation tuple is (body, ref, sigma) or (body, ref, sigma, sensor)")
        body, ref, sigma = o[0], o[1], o[2]
        sensor = o[3] if len(o) == 4 else None
    obs = {"body": _vec3(body, "body"), "ref": _vec3(ref, "ref"), "sigma": float(sigma)}
    if sensor is not None:
        obs["sensor"] = str(sensor)
    return obs


def _imu_sample(t: float, gyr: Any, acc: Any, mag: Any = None) -> dict:
    """A wire IMU sample ``{"t", "gyr", "acc"[, "mag"]}``."""
    sample = {"t": float(t), "gyr": _vec3(gyr, "gyr"), "acc": _vec3(acc, "acc")}
    if mag is not None:
        sample["mag"] = _vec3(mag, "mag")
    return sample


def _rows(value: Any, n: int, what: str, nan_rows: bool = False) -> np.ndarray:
    """An (n, 3) float array of ``n`` samples' vectors."""
    a = np.asarray(value, dtype=float)
    if a.shape != (n, 3):
        raise ValueError(f"{what} must have shape ({n}, 3) for {n} times, got {a.shape}")
    if nan_rows:
        partial = np.isfinite(a).any(axis=1) & ~np.isfinite(a).all(axis=1)
        if partial.any():
            raise ValueError(f"{what}: row {int(np.argmax(partial))} is partly non-finite (a whole NaN row leaves it out)")
    return a


def _quaternion(q: Any) -> dict:
    """A wire quaternion from a dict ``{w, x, y, z}`` or a sequence ``(w, x, y, z)`` (scalar first)."""
    if isinstance(q, Mapping):
        return {k: float(q[k]) for k in ("w", "x", "y", "z")}
    w, x, y, z = (float(c) for c in q)
    return {"w": w, "x": x, "y": y, "z": z}


def _dumps(value: Any) -> bytes:
    # NaN and infinities are not JSON: refuse them here rather than send something the service rejects.
    try:
        return json.dumps(value, allow_nan=False, separators=(",", ":")).encode()
    except ValueError as e:
        raise ValueError(f"cannot send a non-finite number: {e}") from None


def _error_from(payload: bytes, key: str | None) -> Exception:
    """The exception for an error reply: the service's JSON error, or zenoh's own (``Timeout``)."""
    text = payload.decode("utf-8", errors="replace")
    try:
        msg = json.loads(text)
    except ValueError:
        msg = None
    if isinstance(msg, dict) and "code" in msg:
        return ServiceError(str(msg["code"]), str(msg.get("message", "")), msg.get("key", key))
    if "timeout" in text.lower():
        return TimeoutError(f"no reply to {key} in time ({text})")
    return ServiceError("unknown", text, key)


class AttitudeClient:
    """A zenoh session speaking to the attitude service.

    ``endpoint``: the zenoh endpoint of the service (or of a router in front of it). With
    ``connect=True`` (the default) the session connects to it; with ``connect=False`` it listens on it
    instead (for a service started with ``serve --connect``). The session is a zenoh peer with multicast
    scouting off. ``prefix``: the service's key prefix (``service.key_prefix``). ``timeout``: default
    timeout of queries, s. ``config``: an optional ``zenoh.Config`` used instead of the one built here.
    ``routed``: send inputs on their routed keys and batched for a fleet's standby members (see the module's
    text), the batches every ``flush_s`` seconds from a thread of the client's. ``recovery``: send inputs
    through advanced publishers that keep their last ``cache`` puts per key and send a heartbeat every
    ``heartbeat_s`` (see the module's text); False: plain puts. (Routed inputs are plain puts: a fleet's
    route subscriptions are plain.)
    """

    def __init__(
        self,
        endpoint: str = "tcp/127.0.0.1:7447",
        prefix: str = "attitude",
        connect: bool = True,
        timeout: float = 5.0,
        config: zenoh.Config | None = None,
        routed: bool = False,
        flush_s: float = 0.25,
        recovery: bool = True,
        cache: int = CACHE,
        heartbeat_s: float = HEARTBEAT_S,
    ):
        prefix = prefix.strip("/")
        if not prefix or any(c in prefix for c in "*$?#"):
            raise ValueError(f"invalid key prefix {prefix!r}")
        self.prefix = prefix
        self.endpoint = endpoint
        self.timeout = float(timeout)
        if config is None:
            config = zenoh.Config()
            config.insert_json5("mode", '"peer"')
            config.insert_json5("scouting/multicast/enabled", "false")
            if connect:
                config.insert_json5("connect/endpoints", json.dumps([endpoint]))
            else:
                config.insert_json5("listen/endpoints", json.dumps([endpoint]))
        self.recovery = bool(recovery)
        if self.recovery and not (int(cache) >= 1 and heartbeat_s > 0):
            raise ValueError("cache must be at least 1 and heartbeat_s positive")
        self.cache = int(cache)
        self.heartbeat_s = float(heartbeat_s)
        self._publishers: dict[str, Any] = {}
        self._publishers_lock = threading.Lock()
        self.session = zenoh.open(config)
        self.routed = bool(routed)
        self._batches: dict[int, list[bytes]] = {}
        self._batch_lock = threading.Lock()
        self._flusher = None
        self._stop = threading.Event()
        if self.routed:
            if not flush_s > 0:
                raise ValueError("flush_s must be positive")
            self._flusher = threading.Thread(
                target=self._flush_every, args=(float(flush_s),), name="attitude-client-batches", daemon=True
            )
            self._flusher.start()
        # zenoh runs Python callbacks on a non-daemon thread that lives as long as its subscriber: a
        # script that ends without close() would hang in the interpreter's shutdown, which joins
        # non-daemon threads before `atexit` runs. Close the session at that point instead.
        register = getattr(threading, "_register_atexit", None)
        if register is not None:
            try:
                register(_close_at_exit, weakref.ref(self))
            except RuntimeError:  # already shutting down
                pass

    # ------------------------------------------------------------------------------------------
    # Life cycle

    def close(self) -> None:
        """Closes the zenoh session (subscribers declared through it stop); a routed client first sends
        what its batches still hold."""
        if self._flusher is not None:
            self._stop.set()
            self._flusher.join(timeout=5)
            self._flusher = None
            if not self.session.is_closed():
                self.flush()
        with self._publishers_lock:
            publishers, self._publishers = self._publishers, {}
        if not self.session.is_closed():
            for p in publishers.values():
                try:
                    p.undeclare()
                except Exception:  # the session closed under us
                    pass
            self.session.close()

    def __enter__(self) -> "AttitudeClient":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def key(self, vehicle: str, leaf: str) -> str:
        """``P/V/<leaf>``."""
        return f"{self.prefix}/{vehicle}/{leaf}"

    def routed_key(self, vehicle: str, leaf: str) -> str:
        """``P/V/<leaf>/<r>``, ``r`` the vehicle's route as one hex digit."""
        return f"{self.prefix}/{vehicle}/{leaf}/{route_of(vehicle):x}"

    def flush(self) -> None:
        """Sends the routes' batches now (a routed client does it every ``flush_s`` and when closed)."""
        with self._batch_lock:
            batches, self._batches = self._batches, {}
        for route, records in sorted(batches.items()):
            self.session.put(
                f"{self.prefix}/@/standby/{route:x}/inputs",
                b"".join(records),
                encoding=zenoh.Encoding.APPLICATION_OCTET_STREAM,
                congestion_control=zenoh.CongestionControl.BLOCK,
            )

    def _flush_every(self, period: float) -> None:
        while not self._stop.wait(period):
            try:
                self.flush()
            except Exception:  # the session closed under us: nothing more to send
                log.debug("batch flush failed", exc_info=True)
                return

    def wait_for_service(self, timeout: float = 10.0) -> dict:
        """Polls ``P/@/health`` until the service answers; returns the health reply or raises TimeoutError."""
        return self.health(timeout=timeout)

    def wait_listened(self, timeout: float = 10.0) -> dict:
        """Waits until the service knows of a subscriber of its estimates (``P/@/health`` ``listened``) and
        returns that health reply. The service puts estimates only while one matches, and its zenoh learns of
        a new subscriber on its own time (behind a router, later than a query's round trip): call this after
        subscribing, before the inputs whose estimates you count on. Raises TimeoutError."""
        deadline = time.monotonic() + timeout
        while True:
            h = self.health(timeout=max(0.1, deadline - time.monotonic()))
            if h.get("listened", True):  # (a service older than the field puts estimates regardless)
                return h
            if time.monotonic() > deadline:
                raise TimeoutError(f"the service at {self.prefix} sees no subscriber of its estimates after {timeout} s")
            time.sleep(0.01)

    # ------------------------------------------------------------------------------------------
    # Inputs

    def publisher(self, key: str):
        """The advanced publisher of ``key`` (declared at its first use): cache of ``cache`` puts, sample-miss
        detection with a sporadic heartbeat every ``heartbeat_s``, detectable by the service (which then asks
        its cache for what it missed), congestion control ``BLOCK``."""
        with self._publishers_lock:
            p = self._publishers.get(key)
            if p is None:
                p = zenoh.ext.declare_advanced_publisher(
                    self.session,
                    key,
                    encoding=_JSON,
                    congestion_control=zenoh.CongestionControl.BLOCK,
                    cache=zenoh.ext.CacheConfig(max_samples=self.cache),
                    sample_miss_detection=zenoh.ext.MissDetectionConfig(sporadic_heartbeat=self.heartbeat_s),
                    publisher_detection=True,
                )
                self._publishers[key] = p
            return p

    def put_raw(self, vehicle: str, leaf: str, payload: bytes | str) -> None:
        """Puts ``payload`` on ``P/V/<leaf>`` as is (for tools and tests; no validation), through the key's
        advanced publisher (``recovery``); a routed client puts an input on ``P/V/<leaf>/<r>`` and adds it to
        its route's next batch."""
        routed = self.routed and leaf in _INPUTS
        if self.recovery and not routed and leaf in _INPUTS:
            self.publisher(self.key(vehicle, leaf)).put(payload)
            return
        self.session.put(
            self.routed_key(vehicle, leaf) if routed else self.key(vehicle, leaf),
            payload,
            encoding=_JSON,
            congestion_control=zenoh.CongestionControl.BLOCK,
        )
        if routed:
            data = payload.encode() if isinstance(payload, str) else bytes(payload)
            record = _record(vehicle, leaf, data)
            with self._batch_lock:
                self._batches.setdefault(route_of(vehicle), []).append(record)

    def publish_gyro(
        self, vehicle: str, t: float | Sequence[float] | np.ndarray, omega: Sequence[float] | np.ndarray, batch: int = IMU_BATCH
    ) -> int:
        """Gyro samples: time ``t`` (s, the sender's clock), body rate ``omega`` (rad/s). One sample (``t`` a
        number) or many (``t`` of shape (n,), ``omega`` (n, 3)), sent in order, ``batch`` per message.
        Returns the number of samples sent."""
        ts = np.asarray(t, dtype=float)
        if ts.ndim == 0:
            self.put_raw(vehicle, "gyro", _dumps({"t": float(ts), "omega": _vec3(omega, "omega")}))
            return 1
        if ts.ndim != 1 or ts.shape[0] == 0:
            raise ValueError(f"t must be a number or a non-empty 1-D array, got shape {ts.shape}")
        w = _rows(omega, ts.shape[0], "omega")
        tl, wl = ts.tolist(), w.tolist()
        for start in range(0, len(tl), max(1, batch)):
            stop = start + max(1, batch)
            self.put_raw(vehicle, "gyro", _dumps([{"t": a, "omega": b} for a, b in zip(tl[start:stop], wl[start:stop])]))
        return len(tl)

    def publish_gyro_batch(self, vehicle: str, samples: Iterable[tuple[float, Sequence[float]]]) -> None:
        """Gyro samples ``[(t, omega), ...]`` in one message (processed in order)."""
        batch = [{"t": float(t), "omega": _vec3(w, "omega")} for t, w in samples]
        if not batch:
            raise ValueError("empty gyro batch")
        self.put_raw(vehicle, "gyro", _dumps(batch))

    def publish_vectors(self, vehicle: str, t: float, obs: Iterable[Any]) -> None:
        """One vector-observation set at ``t``. ``obs``: dicts ``{"body", "ref", "sigma"[, "sensor"]}`` or
        tuples ``(body, ref, sigma[, sensor])``; ``body`` in the body frame, ``ref`` the same direction
        (or field) in the reference frame, ``sigma`` the per-axis 1σ noise of ``body`` (rad for unit vectors)."""
        self.put_raw(vehicle, "vectors", _dumps({"t": float(t), "obs": [_observation(o) for o in obs]}))

    def publish_vectors_batch(self, vehicle: str, sets: Iterable[tuple[float, Iterable[Any]]]) -> None:
        """Vector-observation sets ``[(t, obs), ...]`` in one message (processed in order)."""
        batch = [{"t": float(t), "obs": [_observation(o) for o in obs]} for t, obs in sets]
        if not batch:
            raise ValueError("empty vectors batch")
        self.put_raw(vehicle, "vectors", _dumps(batch))

    def publish_imu(
        self,
        vehicle: str,
        t: float | Sequence[float] | np.ndarray,
        gyr: Sequence[float] | np.ndarray,
        acc: Sequence[float] | np.ndarray,
        mag: Sequence[float] | np.ndarray | None = None,
        batch: int = IMU_BATCH,
    ) -> int:
        """Raw IMU samples, body frame: rate ``gyr`` (rad/s, covering the interval since the vehicle's
        previous sample), specific force ``acc`` (m/s²) and, optionally, the magnetic field ``mag`` (any
        unit, the same throughout), at times ``t`` (s, increasing).

        One sample (``t`` a number, vectors of 3) or many: ``t`` of shape (n,), the vectors (n, 3) (a row
        of NaN in ``mag`` leaves the field out of that sample). Many samples are sent in order, ``batch``
        per message. Returns the number of samples sent. Non-finite values in ``t``, ``gyr`` or ``acc``
        raise ValueError before anything is sent."""
        ts = np.asarray(t, dtype=float)
        if ts.ndim == 0:
            self.put_raw(vehicle, "imu", _dumps(_imu_sample(float(ts), gyr, acc, mag)))
            return 1
        n = ts.shape[0]
        g = _rows(gyr, n, "gyr")
        a = _rows(acc, n, "acc")
        m = None if mag is None else _rows(mag, n, "mag", nan_rows=True)
        if ts.ndim != 1 or n == 0:
            raise ValueError(f"t must be a number or a non-empty 1-D array, got shape {ts.shape}")
        if not (np.isfinite(ts).all() and np.isfinite(g).all() and np.isfinite(a).all()):
            raise ValueError("t, gyr and acc must be finite")
        if batch < 1:
            raise ValueError("batch must be at least 1")
        tl, gl, al = ts.tolist(), g.tolist(), a.tolist()
        ml = None if m is None else m.tolist()
        for start in range(0, n, batch):
            items = []
            for k in range(start, min(n, start + batch)):
                sample = {"t": tl[k], "gyr": gl[k], "acc": al[k]}
                if ml is not None and all(math.isfinite(c) for c in ml[k]):
                    sample["mag"] = ml[k]
                items.append(sample)
            self.put_raw(vehicle, "imu", _dumps(items))
        return n

    def publish_imu_batch(self, vehicle: str, samples: Iterable[Sequence[Any]]) -> None:
        """Raw IMU samples ``[(t, gyr, acc), ...]`` or ``[(t, gyr, acc, mag), ...]`` (``mag`` may be None)
        in one message (processed in order)."""
        batch = [_imu_sample(*s) for s in samples]
        if not batch:
            raise ValueError("empty IMU batch")
        self.put_raw(vehicle, "imu", _dumps(batch))

    # ------------------------------------------------------------------------------------------
    # Typed results (numpy)

    def estimate(self, vehicle: str, timeout: float | None = None) -> Estimate:
        """``vehicle``'s latest estimate as an :class:`Estimate` (``q``, ``cov``, ``sigma_deg``, ``bias``,
        ``t``, ``diagnostics``)."""
        return Estimate.from_json(self.get_state(vehicle, timeout=timeout))

    def estimates(
        self, vehicles: str = "*", maxsize: int = 1024, timeout: float | None = None
    ) -> EstimateStream:
        """The estimates of ``vehicles`` (an id or a key pattern such as ``*`` or ``sat-*``) as they are
        published, from now on: iterate the returned :class:`EstimateStream` (``for e in ...`` or ``async
        for e in ...``); close it, or use it as a context manager, to stop. Never holds up the service:
        beyond ``maxsize`` unread estimates the oldest are dropped (``stream.dropped`` counts them).
        ``timeout``: end the iteration after that many seconds without an estimate (None: never)."""
        return EstimateStream(self.session, self.key(vehicles, "estimate"), maxsize=maxsize, timeout=timeout)

    def messages(
        self,
        leaves: Sequence[str] = ("estimate",),
        vehicles: str = "*",
        maxsize: int = 1024,
        timeout: float | None = None,
    ) -> MessageStream:
        """The messages published on ``P/<vehicles>/<leaf>`` for each of ``leaves`` (``"estimate"``,
        ``"rejected"``, ``"truth"``), from now on, in one :class:`MessageStream` in arrival order: iterate
        it for ``(key, message)`` pairs, the concrete key (``P/sc1/truth``) and the JSON as parsed. Never
        holds up the service: beyond ``maxsize`` unread messages the oldest are dropped (``.dropped``)."""
        if isinstance(leaves, str):
            leaves = (leaves,)
        for leaf in leaves:
            if not leaf or any(c in leaf for c in "/*$?#"):
                raise ValueError(f"a leaf is one key chunk without wildcards, got {leaf!r}")
        keys = [self.key(vehicles, leaf) for leaf in leaves]
        recovering = [self.key(vehicles, "truth")] if "truth" in leaves else []
        return MessageStream(self.session, keys, maxsize=maxsize, timeout=timeout, recovering=recovering)

    # ------------------------------------------------------------------------------------------
    # Queries

    def query(
        self, selector: str, payload: bytes | str | None = None, timeout: float | None = None
    ) -> list[tuple[str | None, bool, bytes]]:
        """One zenoh get on ``selector`` (a key relative to the prefix, e.g. ``"*/attitude"``), waiting for
        every reply: ``[(key, ok, payload), ...]`` (``key`` is None for error replies, which carry none).
        Zero replies when no queryable matches."""
        timeout = self.timeout if timeout is None else float(timeout)
        out = []
        for reply in self._get(f"{self.prefix}/{selector}", payload, timeout):
            if reply.ok is not None:
                out.append((str(reply.ok.key_expr), True, reply.ok.payload.to_bytes()))
            else:
                out.append((None, False, reply.err.payload.to_bytes()))
        return out

    def _get(self, key: str, payload: bytes | str | None, timeout: float):
        kwargs = {}
        if payload is not None:
            kwargs["payload"] = payload
            kwargs["encoding"] = _JSON
        return self.session.get(
            key,
            consolidation=zenoh.ConsolidationMode.NONE,
            timeout=timeout,
            **kwargs,
        )

    def _call_all(self, key: str, payload: bytes | str | None = None, timeout: float | None = None) -> list:
        """The replies of one get (every instance of a fleet answers the ``P/@/…`` keys), retried while
        nothing answers, until ``timeout``; an error reply raises."""
        timeout = self.timeout if timeout is None else float(timeout)
        deadline = time.monotonic() + timeout
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise TimeoutError(f"nobody answered {key} within {timeout:g} s (is the service running?)")
            out = []
            for reply in self._get(key, payload, max(remaining, 0.05)):
                if reply.ok is None:
                    raise _error_from(reply.err.payload.to_bytes(), key)
                out.append(json.loads(reply.ok.payload.to_bytes()))
            if out:
                return out
            # No queryable matched (yet): declarations may still be on their way.
            time.sleep(min(0.02, max(deadline - time.monotonic(), 0)))

    def _call(self, key: str, payload: bytes | str | None = None, timeout: float | None = None) -> Any:
        """A get that expects one reply: retried (while nothing answers) until ``timeout``."""
        return self._call_all(key, payload, timeout)[0]

    def _vehicle_query(self, vehicle: str, kind: str, timeout: float | None) -> dict:
        if not vehicle or any(c in vehicle for c in "/*$?#"):
            raise ValueError(f"a concrete vehicle id is required, got {vehicle!r} (use get_all for every vehicle)")
        return self._call(self.key(vehicle, kind), timeout=timeout)

    def get_attitude(self, vehicle: str, timeout: float | None = None) -> dict:
        """``{"vehicle", "t", "q", "sigma_deg"}`` of ``vehicle``'s latest estimate."""
        return self._vehicle_query(vehicle, "attitude", timeout)

    def get_covariance(self, vehicle: str, timeout: float | None = None) -> dict:
        """``{"vehicle", "t", "cov", "sigma_deg"}``: ``cov`` 6×6 rows over ``[δα (rad); δβ (rad/s)]``."""
        return self._vehicle_query(vehicle, "covariance", timeout)

    def get_state(self, vehicle: str, timeout: float | None = None) -> dict:
        """The full latest estimate (as published on ``P/V/estimate``)."""
        return self._vehicle_query(vehicle, "state", timeout)

    def get_all(self, kind: str = "attitude", timeout: float | None = None, errors: bool = False) -> dict:
        """``P/*/<kind>``: ``{vehicle: reply}`` for every vehicle that has an estimate. One get, no retry, once every
        member of a fleet answers (``_reach_instances``): ``{}`` when no vehicle has an estimate (or no service is
        reachable). With ``errors=True``, error
        replies that name a vehicle are included as :class:`ServiceError` values; otherwise they are skipped."""
        if kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
        deadline = time.monotonic() + (self.timeout if timeout is None else float(timeout))
        self._reach_instances(deadline)
        out: dict[str, Any] = {}
        for key, ok, payload in self.query(f"*/{kind}", timeout=max(deadline - time.monotonic(), 0.05)):
            if ok:
                vehicle = key[len(self.prefix) + 1 :].split("/", 1)[0]
                out[vehicle] = json.loads(payload)
                continue
            err = _error_from(payload, None)
            if isinstance(err, TimeoutError):
                raise err
            vehicle = None
            if isinstance(err, ServiceError) and err.key and err.key.startswith(self.prefix + "/"):
                vehicle = err.key[len(self.prefix) + 1 :].split("/", 1)[0]
            if vehicle is None or "*" in vehicle:
                raise err
            if errors:
                out[vehicle] = err
        return out

    def reset(self, vehicle: str, timeout: float | None = 15.0, **fields: Any) -> dict:
        """(Re)initialises or reconfigures ``vehicle``'s filter; returns the reset reply
        ``{"vehicle", "state", "filter", "fiducial", "particles", "level", "estimate"}``.

        ``fields`` (all optional): ``filter`` (``"mekf"``, ``"usque"``, ``"qpf"``, ``"sghqf"``), ``fiducial``
        (``"average"``, ``"propagated"``), ``particles`` (qpf), ``level`` (sghqf, 2 to 4), ``q`` (dict ``{w,x,y,z}`` or ``(w, x, y, z)``),
        ``sigma_deg`` (one number or three), ``bias`` (rad/s), ``bias_sigma`` (rad/s, one or three), ``t``
        (s). Without ``q`` the vehicle initialises again from its next usable vector-observation set."""
        req: dict[str, Any] = {}
        for name, value in fields.items():
            if value is None:
                continue
            if name == "q":
                value = _quaternion(value)
            elif name in ("bias",):
                value = _vec3(value, name)
            elif name in ("sigma_deg", "bias_sigma"):
                value = float(value) if isinstance(value, (int, float)) else [float(x) for x in value]
            elif name == "t":
                value = float(value)
            req[name] = value
        return self._call(self.key(vehicle, "reset"), payload=_dumps(req), timeout=timeout)

    def vehicles(self, timeout: float | None = None) -> list[dict]:
        """``P/@/vehicles``: one row per known vehicle (``vehicle``, ``state``, ``filter``, ``fiducial``, ``t``,
        ``received``, ``processed``, ``rejected``, ``estimates``). In a fleet every instance answers with the
        vehicles it owns: the rows of all of them, sorted by vehicle."""
        deadline = time.monotonic() + (self.timeout if timeout is None else float(timeout))
        instances = self._reach_instances(deadline)
        while True:
            replies = self._call_all(f"{self.prefix}/@/vehicles", timeout=max(deadline - time.monotonic(), 0.05))
            if len(replies) >= len(instances) or time.monotonic() >= deadline:
                break
            time.sleep(0.02)
        rows = [row for reply in replies for row in reply]
        return sorted(rows, key=lambda r: r["vehicle"])

    def instances(self, timeout: float | None = None) -> dict[str, dict]:
        """``P/@/instance/*/health``: ``{instance name: its health}``, one entry per running instance (its
        ``fleet`` object says which vehicles pattern it serves, its members and how many vehicles it owns)."""
        deadline = time.monotonic() + (self.timeout if timeout is None else float(timeout))
        instances = self._reach_instances(deadline)
        if instances:
            return instances
        key = f"{self.prefix}/@/instance/*/health"
        return {h["fleet"]["instance"]: h for h in self._call_all(key, timeout=max(deadline - time.monotonic(), 0.05))}

    def _reach_instances(self, deadline: float, patience: float = 0.25) -> dict[str, dict]:
        """``{instance: health}`` once every instance that any instance names as a fleet member answers
        ``P/@/instance/*/health``, or what answered by ``deadline`` (with a warning naming the missing).

        Between peers (a fleet of peer-mode instances, no router), this session reaches the members other than the
        one it connects to through gossip, some time after it opened (tens of ms here, more on a loaded machine):
        until then they answer no query, and a query of the whole fleet would return part of it, silently (measured:
        a fresh session's ``vehicles()`` in a fleet of three held one member's vehicles in a quarter of the tries).
        Once a member has answered, its queryables are known to this session. Nobody answering within ``patience``
        (no service yet, or an access-control policy that keeps this session from the health keys) is no reason to
        wait: the caller's query goes on as before."""
        key = f"{self.prefix}/@/instance/*/health"
        started = time.monotonic()
        while True:
            healths: dict[str, dict] = {}
            for reply in self._get(key, None, max(deadline - time.monotonic(), 0.05)):
                if reply.ok is not None:
                    h = json.loads(reply.ok.payload.to_bytes())
                    name = (h.get("fleet") or {}).get("instance")
                    if name:
                        healths[name] = h
            named = {m for h in healths.values() for m in (h["fleet"].get("members") or [])}
            if healths and named <= healths.keys():
                return healths
            now = time.monotonic()
            if now >= deadline or (not healths and now - started >= patience):
                if healths:
                    log.warning("instances %s of the fleet did not answer in time", sorted(named - healths.keys()))
                return healths
            time.sleep(0.02)

    def health(self, timeout: float | None = None) -> dict:
        """``P/@/health``: service counters (``received``, ``processed``, ``estimates_published``,
        ``rejected`` by code, ``vehicles``, ``queries``, ``uptime_s``, ``version``, ``status``) and ``listened``
        (a subscriber of the estimates is known: ``wait_listened``)."""
        return self._call(f"{self.prefix}/@/health", timeout=timeout)

    # ------------------------------------------------------------------------------------------
    # Outputs

    def _subscribe(self, key: str, callback: Callable[[Any], None], recovering: bool = False):
        def on_sample(sample: zenoh.Sample) -> None:
            try:
                message = json.loads(sample.payload.to_bytes())
            except ValueError:
                log.warning("not JSON on %s", sample.key_expr)
                return
            try:
                callback(message)
            except Exception:  # a callback must not take zenoh's thread down
                log.exception("callback for %s failed", sample.key_expr)

        if recovering:
            return recovering_subscriber(self.session, key, on_sample)
        return self.session.declare_subscriber(key, on_sample)

    def subscribe_estimates(self, callback: Callable[[dict], None], vehicle: str = "*"):
        """Calls ``callback(estimate)`` for every estimate published on ``P/<vehicle>/estimate``
        (``vehicle`` may be ``*``). Returns the subscriber: keep it; ``undeclare()`` it to stop. The service puts
        estimates only once it knows of a subscriber: ``wait_listened()`` before counting on the next one."""
        return self._subscribe(self.key(vehicle, "estimate"), callback)

    def subscribe_rejections(self, callback: Callable[[dict], None], vehicle: str = "*", events: bool = False):
        """Calls ``callback({"code", "message", "key"})`` for every input the service refused for
        ``vehicle`` (``P/<vehicle>/rejected``). The service tells events on the same key that are no refusal
        (``gap``: a sample after a gap in its stream, used); ``events=True`` passes them too. Returns the
        subscriber: keep it."""
        if events:
            return self._subscribe(self.key(vehicle, "rejected"), callback)

        def refusals(msg: dict) -> None:
            if msg.get("code") not in EVENT_CODES:
                callback(msg)

        return self._subscribe(self.key(vehicle, "rejected"), refusals)

    def subscribe_truth(self, callback: Callable[[dict], None], vehicle: str = "*"):
        """Calls ``callback(truth)`` for every truth message of the simulator (``P/<vehicle>/truth``), those put
        before this session reached the simulator's too (an advanced subscriber: ``stream.recovering_subscriber``)."""
        return self._subscribe(self.key(vehicle, "truth"), callback, recovering=True)


def _close_at_exit(ref: "weakref.ref[AttitudeClient]") -> None:
    client = ref()
    if client is not None:
        try:
            client.close()
        except Exception:
            pass


def attitude_error_deg(q_true: Any, q_est: Any) -> float:
    """Angle (deg) of the rotation between two quaternions: ``2·acos(|w|)`` of ``q_est⁻¹ · q_true``. Each is a
    wire quaternion (``{w, x, y, z}``) or a sequence / array ``[w, x, y, z]``."""

    def wxyz(q: Any) -> list[float]:
        if isinstance(q, Mapping):
            return [float(q[k]) for k in ("w", "x", "y", "z")]
        return [float(c) for c in q]

    dot = sum(a * b for a, b in zip(wxyz(q_true), wxyz(q_est)))
    return math.degrees(2.0 * math.acos(min(1.0, abs(dot))))
