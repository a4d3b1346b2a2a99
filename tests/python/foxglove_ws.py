"""A client of the Foxglove WebSocket protocol for the tests of `attitude-view` (websockets, a thread).

The protocol (subprotocol `foxglove.sdk.v1`, the name foxglove-sdk's server gives the Foxglove WebSocket protocol
`foxglove.websocket.v1`; the messages are the same): the server sends `serverInfo`, then `advertise` with its channels
(id, topic, encoding, schemaName, schemaEncoding, schema), again for every channel added later; the client sends
`subscribe` with `{id, channelId}` pairs of its choosing; the server then sends binary frames `0x01 | subscription id
(u32 LE) | log time (u64 LE, ns) | payload`. JSON payloads are parsed; protobuf ones are decoded with the
FileDescriptorSet the channel advertises (google.protobuf), independently of the SDK that encoded them.
"""

from __future__ import annotations

import base64
import json
import struct
import threading
import time

import websockets.sync.client as websockets_sync
from google.protobuf import descriptor_pb2, descriptor_pool, json_format, message_factory
from websockets.exceptions import ConnectionClosed

SUBPROTOCOL = "foxglove.sdk.v1"


class FoxgloveClient:
    """A client of the Foxglove WebSocket protocol: subscribes to every channel as it is advertised and keeps every
    message, decoded, per topic: ``messages[topic] = [(log_time_ns, message), ...]``."""

    def __init__(self, url: str, timeout: float = 15.0):
        deadline = time.monotonic() + timeout
        while True:
            try:
                self._connect = websockets_sync.connect(url, subprotocols=[SUBPROTOCOL], open_timeout=2, max_size=None)
                self.ws = self._connect.__enter__()
                break
            except (OSError, TimeoutError):
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.1)
        assert self.ws.subprotocol == SUBPROTOCOL
        self.lock = threading.Lock()
        self.server_info: dict | None = None
        self.channels: dict[int, dict] = {}
        self.subscriptions: dict[int, int] = {}  # subscription id -> channel id
        self.messages: dict[str, list] = {}
        self.errors: list[str] = []
        self._decoders: dict[int, object] = {}
        self._next_sub = 1
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()

    def _decoder(self, channel: dict):
        if channel["encoding"] == "json":
            return lambda data: json.loads(data)
        assert channel["encoding"] == "protobuf" and channel["schemaEncoding"] == "protobuf", channel
        fds = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
        pool = descriptor_pool.DescriptorPool()
        for fd in fds.file:
            pool.Add(fd)
        cls = message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))
        return lambda data: json_format.MessageToDict(cls.FromString(data), preserving_proto_field_name=True)

    def _read(self) -> None:
        try:
            while True:
                frame = self.ws.recv()
                if isinstance(frame, str):
                    msg = json.loads(frame)
                    if msg["op"] == "serverInfo":
                        self.server_info = msg
                    elif msg["op"] == "advertise":
                        subs = []
                        with self.lock:
                            for ch in msg["channels"]:
                                self.channels[ch["id"]] = ch
                                self._decoders[ch["id"]] = self._decoder(ch)
                                self.messages.setdefault(ch["topic"], [])
                                subs.append({"id": self._next_sub, "channelId": ch["id"]})
                                self.subscriptions[self._next_sub] = ch["id"]
                                self._next_sub += 1
                        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
                    elif msg["op"] == "status" and msg.get("level", 0) >= 2:
                        self.errors.append(msg.get("message", ""))
                    continue
                assert frame[0] == 0x01, f"opcode {frame[0]}"
                sub_id, log_time = struct.unpack_from("<IQ", frame, 1)
                with self.lock:
                    cid = self.subscriptions[sub_id]
                    topic = self.channels[cid]["topic"]
                    self.messages[topic].append((log_time, self._decoders[cid](frame[13:])))
        except ConnectionClosed:  # the test closed it, or the view ended: the waits report what is missing
            pass
        except Exception as e:
            self.errors.append(repr(e))

    def topics(self) -> dict[str, dict]:
        with self.lock:
            return {ch["topic"]: ch for ch in self.channels.values()}

    def got(self, topic: str) -> list:
        with self.lock:
            return list(self.messages.get(topic, []))

    def last(self, topic: str):
        got = self.got(topic)
        return got[-1][1] if got else None

    def close(self) -> None:
        self._connect.__exit__(None, None, None)
        self.thread.join(timeout=5)
