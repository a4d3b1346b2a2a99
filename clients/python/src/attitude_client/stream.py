"""Estimates (or any of the service's JSON messages) as an iterator and an async iterator, bridged from
zenoh's callbacks.

zenoh calls the subscriber's callback on its own thread. The callback here only appends the key and the
payload to a bounded buffer and never waits: when the consumer falls behind, the oldest messages are
dropped (and counted in :attr:`MessageStream.dropped`), so a slow script never slows zenoh, the network or
the service. The JSON is parsed by the consumer, not on zenoh's thread.

:class:`MessageStream` follows one or more key expressions in one buffer, in arrival order, and yields
``(key, message)`` with the message as parsed JSON (``P/V/truth``, ``P/V/rejected``, ``P/V/estimate`` side
by side: what ``attitude-view`` reads); :class:`EstimateStream` follows ``P/V/estimate`` and yields
:class:`~attitude_client.Estimate` values.
"""

from __future__ import annotations

import asyncio
import collections
import json
import logging
import threading
import time
from typing import TYPE_CHECKING, Any, AsyncIterator, Generic, Iterator, Sequence, TypeVar

from .estimate import Estimate

if TYPE_CHECKING:
    import zenoh

__all__ = ["EstimateStream", "MessageStream"]

log = logging.getLogger("attitude_client")


T = TypeVar("T")


def recovering_subscriber(session: "zenoh.Session", key: str, callback: Any) -> Any:
    """A subscriber that also gets what an advanced publisher (``simulate``'s truth) put before this session reached
    it: the publisher's cache, asked when the publisher is discovered, late ones too, and the heartbeat's misses.
    Between peers, a publisher's first puts can precede the gossip connection that brings this subscriber to it
    (clients/python/README.md); each sample still arrives once."""
    import zenoh

    return zenoh.ext.declare_advanced_subscriber(
        session,
        key,
        callback,
        history=zenoh.ext.HistoryConfig(detect_late_publishers=True),
        recovery=zenoh.ext.RecoveryConfig(heartbeat=True),
    )


class _Stream(Generic[T]):
    """The buffer and the two iterator protocols; :meth:`_parse` turns ``(key, payload)`` into an item
    (``None``: not one, counted in :attr:`malformed` and skipped). The keys listed in ``recovering`` are followed by
    :func:`recovering_subscriber`, the others by plain subscribers."""

    def __init__(
        self,
        session: "zenoh.Session",
        keys: Sequence[str],
        maxsize: int = 1024,
        timeout: float | None = None,
        recovering: Sequence[str] = (),
    ):
        if maxsize < 1:
            raise ValueError("maxsize must be at least 1")
        if not keys:
            raise ValueError("at least one key expression is required")
        self.keys = tuple(keys)
        self.maxsize = int(maxsize)
        self.timeout = timeout
        #: Messages dropped because the buffer was full (the consumer was slower than the service).
        self.dropped = 0
        #: Payloads that were not what the stream yields (not JSON, or an estimate without its fields).
        self.malformed = 0
        self._buffer: collections.deque[tuple[str, bytes]] = collections.deque()
        self._cond = threading.Condition()
        self._closed = False
        # asyncio consumers: (loop, event) to wake with call_soon_threadsafe.
        self._waiters: list[tuple[asyncio.AbstractEventLoop, asyncio.Event]] = []
        self._subscribers = []
        try:
            for key in self.keys:
                if key in recovering:
                    self._subscribers.append(recovering_subscriber(session, key, self._on_sample))
                else:
                    self._subscribers.append(session.declare_subscriber(key, self._on_sample))
        except Exception:
            self.close()
            raise

    # -- zenoh's thread: append and wake, nothing else ------------------------------------------------
    def _on_sample(self, sample: Any) -> None:
        item = (str(sample.key_expr), sample.payload.to_bytes())
        with self._cond:
            if self._closed:
                return
            if len(self._buffer) >= self.maxsize:
                self._buffer.popleft()
                self.dropped += 1
            self._buffer.append(item)
            self._cond.notify()
            waiters = list(self._waiters)
        for loop, event in waiters:
            try:
                loop.call_soon_threadsafe(event.set)
            except RuntimeError:  # the loop was closed
                pass

    def _parse(self, key: str, payload: bytes) -> T | None:  # pragma: no cover - overridden
        raise NotImplementedError

    # -- the consumer -----------------------------------------------------------------------------
    def get(self, timeout: float | None = None) -> T | None:
        """The next item, waiting at most ``timeout`` s (``None``: for ever); ``None`` on timeout or once
        the stream is closed and empty."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            with self._cond:
                while not self._buffer:
                    if self._closed:
                        return None
                    remaining = None if deadline is None else deadline - time.monotonic()
                    if remaining is not None and remaining <= 0:
                        return None
                    self._cond.wait(remaining)
                key, payload = self._buffer.popleft()
            e = self._parse(key, payload)
            if e is not None:
                return e

    def get_nowait(self) -> T | None:
        """The next item if one is buffered, else ``None``."""
        while True:
            with self._cond:
                if not self._buffer:
                    return None
                key, payload = self._buffer.popleft()
            e = self._parse(key, payload)
            if e is not None:
                return e

    def __len__(self) -> int:
        """Messages buffered, not yet taken."""
        with self._cond:
            return len(self._buffer)

    def __iter__(self) -> "_Stream[T]":
        return self

    def __next__(self) -> T:
        e = self.get(self.timeout)
        if e is None:
            raise StopIteration
        return e

    def __aiter__(self) -> "_Stream[T]":
        return self

    async def __anext__(self) -> T:
        loop = asyncio.get_running_loop()
        event = asyncio.Event()
        entry = (loop, event)
        with self._cond:
            self._waiters.append(entry)
        try:
            deadline = None if self.timeout is None else loop.time() + self.timeout
            while True:
                event.clear()
                e = self.get_nowait()
                if e is not None:
                    return e
                with self._cond:
                    if self._closed and not self._buffer:
                        raise StopAsyncIteration
                    if self._buffer:
                        continue
                remaining = None if deadline is None else deadline - loop.time()
                if remaining is not None and remaining <= 0:
                    raise StopAsyncIteration
                try:
                    await asyncio.wait_for(event.wait(), remaining)
                except asyncio.TimeoutError:
                    raise StopAsyncIteration from None
        finally:
            with self._cond:
                self._waiters.remove(entry)

    # -- life cycle ------------------------------------------------------------------------------
    def close(self) -> None:
        """Undeclares the subscribers; what is buffered can still be taken."""
        with self._cond:
            if self._closed:
                return
            self._closed = True
            self._cond.notify_all()
            waiters = list(self._waiters)
        for loop, event in waiters:
            try:
                loop.call_soon_threadsafe(event.set)
            except RuntimeError:
                pass
        for subscriber in self._subscribers:
            try:
                subscriber.undeclare()
            except Exception:  # the session may already be closed
                pass

    def __enter__(self):
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class EstimateStream(_Stream[Estimate], Iterator[Estimate], AsyncIterator[Estimate]):
    """Estimates published on ``key`` (``P/<vehicles>/estimate``), in arrival order.

    Iterate it (``for e in stream``) or, inside asyncio, ``async for e in stream``; both block until the
    next estimate. ``timeout`` (s) ends the iteration (``StopIteration`` / ``StopAsyncIteration``) when
    nothing comes for that long; ``None`` waits for ever. ``maxsize`` bounds the buffer; what overflows
    it is dropped, oldest first. Close it (or use it as a context manager) to undeclare the subscriber.
    """

    def __init__(self, session: "zenoh.Session", key: str, maxsize: int = 1024, timeout: float | None = None):
        self.key = key
        super().__init__(session, [key], maxsize=maxsize, timeout=timeout)

    def _parse(self, key: str, payload: bytes) -> Estimate | None:
        try:
            return Estimate.from_json(json.loads(payload))
        except (ValueError, KeyError, TypeError):
            self.malformed += 1
            log.warning("not an estimate on %s", key)
            return None


class MessageStream(_Stream["tuple[str, Any]"], Iterator["tuple[str, Any]"], AsyncIterator["tuple[str, Any]"]):
    """The messages published on one or more key expressions (e.g. ``P/*/estimate``, ``P/*/truth``,
    ``P/*/rejected``), in one buffer, in arrival order, as ``(key, message)``: the concrete key the
    message was put on and its JSON, parsed (by the consumer). Iteration, ``timeout``, ``maxsize`` and
    dropping as for :class:`EstimateStream`; a payload that is not JSON is counted in :attr:`malformed`
    and skipped."""

    def _parse(self, key: str, payload: bytes) -> "tuple[str, Any] | None":
        try:
            return key, json.loads(payload)
        except ValueError:
            self.malformed += 1
            log.warning("not JSON on %s", key)
            return None
