"""Estimates as an iterator and an async iterator, bridged from zenoh's callbacks.

zenoh calls the subscriber's callback on its own thread. The callback here only appends the payload to a
bounded buffer and never waits: when the consumer falls behind, the oldest estimates are dropped (and
counted in :attr:`EstimateStream.dropped`), so a slow script never slows zenoh, the network or the
service. The JSON is parsed by the consumer, not on zenoh's thread.
"""

from __future__ import annotations

import asyncio
import collections
import json
import logging
import threading
import time
from typing import TYPE_CHECKING, Any, AsyncIterator, Iterator

from .estimate import Estimate

if TYPE_CHECKING:
    import zenoh

__all__ = ["EstimateStream"]

log = logging.getLogger("attitude_client")


class EstimateStream(Iterator[Estimate], AsyncIterator[Estimate]):
    """Estimates published on ``key`` (``P/<vehicles>/estimate``), in arrival order.

    Iterate it (``for e in stream``) or, inside asyncio, ``async for e in stream``; both block until the
    next estimate. ``timeout`` (s) ends the iteration (``StopIteration`` / ``StopAsyncIteration``) when
    nothing comes for that long; ``None`` waits for ever. ``maxsize`` bounds the buffer; what overflows
    it is dropped, oldest first. Close it (or use it as a context manager) to undeclare the subscriber.
    """

    def __init__(self, session: "zenoh.Session", key: str, maxsize: int = 1024, timeout: float | None = None):
        if maxsize < 1:
            raise ValueError("maxsize must be at least 1")
        self.key = key
        self.maxsize = int(maxsize)
        self.timeout = timeout
        #: Estimates dropped because the buffer was full (the consumer was slower than the service).
        self.dropped = 0
        #: Payloads that were not an estimate (not JSON, or without its fields).
        self.malformed = 0
        self._buffer: collections.deque[bytes] = collections.deque()
        self._cond = threading.Condition()
        self._closed = False
        # asyncio consumers: (loop, event) to wake with call_soon_threadsafe.
        self._waiters: list[tuple[asyncio.AbstractEventLoop, asyncio.Event]] = []
        self._subscriber = session.declare_subscriber(key, self._on_sample)

    # -- zenoh's thread: append and wake, nothing else ------------------------------------------------
    def _on_sample(self, sample: Any) -> None:
        payload = sample.payload.to_bytes()
        with self._cond:
            if self._closed:
                return
            if len(self._buffer) >= self.maxsize:
                self._buffer.popleft()
                self.dropped += 1
            self._buffer.append(payload)
            self._cond.notify()
            waiters = list(self._waiters)
        for loop, event in waiters:
            try:
                loop.call_soon_threadsafe(event.set)
            except RuntimeError:  # the loop was closed
                pass

    # -- the consumer -----------------------------------------------------------------------------
    def _parse(self, payload: bytes) -> Estimate | None:
        try:
            return Estimate.from_json(json.loads(payload))
        except (ValueError, KeyError, TypeError):
            self.malformed += 1
            log.warning("not an estimate on %s", self.key)
            return None

    def get(self, timeout: float | None = None) -> Estimate | None:
        """The next estimate, waiting at most ``timeout`` s (``None``: for ever); ``None`` on timeout or
        once the stream is closed and empty."""
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
                payload = self._buffer.popleft()
            e = self._parse(payload)
            if e is not None:
                return e

    def get_nowait(self) -> Estimate | None:
        """The next estimate if one is buffered, else ``None``."""
        while True:
            with self._cond:
                if not self._buffer:
                    return None
                payload = self._buffer.popleft()
            e = self._parse(payload)
            if e is not None:
                return e

    def __len__(self) -> int:
        """Estimates buffered, not yet taken."""
        with self._cond:
            return len(self._buffer)

    def __iter__(self) -> "EstimateStream":
        return self

    def __next__(self) -> Estimate:
        e = self.get(self.timeout)
        if e is None:
            raise StopIteration
        return e

    def __aiter__(self) -> "EstimateStream":
        return self

    async def __anext__(self) -> Estimate:
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
        """Undeclares the subscriber; what is buffered can still be taken."""
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
        try:
            self._subscriber.undeclare()
        except Exception:  # the session may already be closed
            pass

    def __enter__(self) -> "EstimateStream":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
