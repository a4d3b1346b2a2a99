"""A TCP proxy that cuts a link (``attitude-faults``, the tests of recovery): a zenoh session connects to the proxy,
which forwards to the real endpoint; ``cut(seconds)`` closes every forwarded connection and refuses new ones
(accepted, then closed at once) for that long, as a network that goes away and comes back does. Threads only, no
dependency."""

from __future__ import annotations

import socket
import threading
import time


class TcpProxy:
    """Listens on 127.0.0.1:<free port> (``endpoint``: ``tcp/127.0.0.1:<port>``) and forwards to ``target``
    (``(host, port)``)."""

    def __init__(self, target: tuple[str, int]):
        self.target = target
        self.server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.server.bind(("127.0.0.1", 0))
        self.server.listen(16)
        self.port = self.server.getsockname()[1]
        self.endpoint = f"tcp/127.0.0.1:{self.port}"
        self._lock = threading.Lock()
        self._open: list[socket.socket] = []
        self._down_until = 0.0
        self._closed = False
        #: Connections accepted and forwarded, and refused while cut.
        self.connections = 0
        self.refused = 0
        threading.Thread(target=self._accept, name="tcp-proxy", daemon=True).start()

    def _accept(self) -> None:
        while not self._closed:
            try:
                client, _ = self.server.accept()
            except OSError:
                return
            if time.monotonic() < self._down_until:
                self.refused += 1
                client.close()
                continue
            try:
                upstream = socket.create_connection(self.target, timeout=5)
                upstream.settimeout(None)
            except OSError:
                client.close()
                continue
            for s in (client, upstream):
                s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            with self._lock:
                self._open += [client, upstream]
                self.connections += 1
            for a, b in ((client, upstream), (upstream, client)):
                threading.Thread(target=self._pump, args=(a, b), daemon=True).start()

    def _pump(self, src: socket.socket, dst: socket.socket) -> None:
        try:
            while True:
                data = src.recv(65536)
                if not data:
                    break
                dst.sendall(data)
        except OSError:
            pass
        for s in (src, dst):
            try:
                s.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            s.close()

    def cut(self, seconds: float) -> None:
        """Closes every forwarded connection and refuses new ones for ``seconds``."""
        self._down_until = time.monotonic() + seconds
        with self._lock:
            sockets, self._open = self._open, []
        for s in sockets:
            try:
                s.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            s.close()

    def restore(self) -> None:
        """Accepts connections again (after ``cut``)."""
        self._down_until = 0.0

    def close(self) -> None:
        self._closed = True
        self.cut(0)
        self.server.close()
