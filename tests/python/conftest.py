"""Fixtures of the black-box tests: the real `attitude-service serve` binary on a free port, and clients.

The binary is `target/release/attitude-service` (or `$ATTITUDE_SERVICE_BIN`), and the laboratory's, for the
studies and benches (imu-study, quadrature), `target/release/attitude-lab` (or `$ATTITUDE_LAB_BIN`);
`scripts/python-tests.sh` builds them when one is missing. Every wait has a deadline.
"""

from __future__ import annotations

import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import weakref
from typing import Callable

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from attitude_client import AttitudeClient  # noqa: E402
from attitude_client.faults import free_port  # noqa: E402,F401  (one implementation: see its docstring)
import attitude_client  # noqa: E402

# The tests import the client package as a user does (scripts/python-tests.sh installs it editable); a copy
# installed from another checkout would test the wrong code.
if not pathlib.Path(attitude_client.__file__).resolve().is_relative_to(ROOT / "clients" / "python" / "src"):
    raise ImportError(
        f"attitude_client is imported from {attitude_client.__file__}, not from {ROOT / 'clients/python/src'}: "
        "run the tests with scripts/python-tests.sh (it installs clients/python editable into .venv)"
    )

BIN = pathlib.Path(os.environ.get("ATTITUDE_SERVICE_BIN", ROOT / "target" / "release" / "attitude-service"))
LAB = pathlib.Path(os.environ.get("ATTITUDE_LAB_BIN", ROOT / "target" / "release" / "attitude-lab"))
SCHEMAS = ROOT / "proto" / "schemas"

#: The prefix of the shared service: two chunks, to exercise a multi-chunk prefix.
PREFIX = "pytest/attitude"

#: test_accuracy: ACCURACY_RUNS vehicles `v-<kind>-<i>` per filter kind.
ACCURACY_KINDS = {"mekf": {"kind": "mekf"}, "usque": {"kind": "usque"}, "qpf": {"kind": "qpf", "particles": 500}}
ACCURACY_RUNS = 40

#: Per-vehicle filter overrides of the shared service (the rest get the default filter: qpf, 1000 particles).
VEHICLES = {
    # test_accuracy
    **{f"v-{kind}-{i}": cfg for kind, cfg in ACCURACY_KINDS.items() for i in range(ACCURACY_RUNS)},
    # test_estimates
    "e-usque-prop": {"kind": "usque", "fiducial": "propagated"},
    # test_queries (P/@/vehicles)
    "l-mekf": {"kind": "mekf"},
    "l-qpf": {"kind": "qpf", "fiducial": "propagated", "particles": 200},
    # test_inputs, test_reset: cheap filters
    "h-1": {"kind": "mekf"},
    "bad-1": {"kind": "mekf"},
    "r-usque": {"kind": "usque"},
    "lat-1": {"kind": "mekf"},
}


def wait_until(predicate: Callable[[], bool], timeout: float, what: str, interval: float = 0.01):
    """Polls ``predicate`` until it is true; fails the test after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out after {timeout} s waiting for {what}")
        time.sleep(interval)


class ServiceProcess:
    """`attitude-service serve --config <tmp> --listen tcp/127.0.0.1:<port> [args]`: a free port unless ``port``
    (a restart on the same endpoint)."""

    def __init__(
        self,
        service_config: dict | None = None,
        prefix: str = PREFIX,
        workdir: str | None = None,
        args: list[str] | None = None,
        port: int | None = None,
    ):
        if not BIN.exists():
            pytest.fail(f"{BIN} does not exist: build it (cargo build --release) or run scripts/python-tests.sh")
        self.prefix = prefix
        self.port = port or free_port()
        self.endpoint = f"tcp/127.0.0.1:{self.port}"
        self.dir = pathlib.Path(workdir or tempfile.mkdtemp(prefix="attitude-pytest-"))
        if workdir is None:
            # Its own folder (the configuration and the log) goes with it: a test reads the log while it holds the
            # process, and a failing test's message carries the log's tail.
            weakref.finalize(self, shutil.rmtree, str(self.dir), ignore_errors=True)
        config = {
            "zenoh": {
                "mode": "peer",
                "listen": {"endpoints": [self.endpoint]},
                "scouting": {"multicast": {"enabled": False}},
            },
            "service": {"key_prefix": prefix, **(service_config or {})},
        }
        self.config_path = self.dir / "service.json5"
        self.config_path.write_text(json.dumps(config, indent=2))
        self.log_path = self.dir / "service.log"
        self._log = open(self.log_path, "wb")
        env = dict(os.environ)
        env.setdefault("RUST_LOG", "warn")
        self.proc = subprocess.Popen(
            [str(BIN), "serve", "--config", str(self.config_path), "--listen", self.endpoint, *(args or [])],
            stdout=self._log,
            stderr=subprocess.STDOUT,
            env=env,
        )

    def log(self) -> str:
        try:
            return self.log_path.read_text(errors="replace")
        except OSError:
            return ""

    def client(self, **kwargs) -> AttitudeClient:
        return AttitudeClient(self.endpoint, prefix=self.prefix, **kwargs)

    def wait_ready(self, client: AttitudeClient, timeout: float = 20.0) -> dict:
        """Polls ``P/@/health`` until the service answers (and fails early if the process died)."""
        deadline = time.monotonic() + timeout
        while True:
            if self.proc.poll() is not None:
                pytest.fail(f"the service exited with {self.proc.returncode} during start-up:\n{self.log()}")
            try:
                return client.health(timeout=0.5)
            except TimeoutError:
                if time.monotonic() > deadline:
                    pytest.fail(f"the service did not answer P/@/health within {timeout} s:\n{self.log()}")

    def stop(self, sig: int = signal.SIGTERM, timeout: float = 10.0) -> tuple[int | None, float]:
        """Sends ``sig`` and waits up to ``timeout`` s; returns (exit code or None, seconds taken). Kills the
        process when it does not exit in time."""
        t0 = time.monotonic()
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        try:
            code = self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(timeout=10)
            code = None
        self._log.close()
        return code, time.monotonic() - t0


@pytest.fixture(scope="session")
def service():
    """The shared service (one process for the whole session); stopped with SIGTERM at the end, which
    must exit 0 within 10 s."""
    svc = ServiceProcess({"vehicles": VEHICLES})
    probe = svc.client()
    try:
        svc.wait_ready(probe)
    finally:
        probe.close()
    yield svc
    code, took = svc.stop(signal.SIGTERM, timeout=10.0)
    log = svc.log()
    assert code == 0, f"SIGTERM: the service exited with {code} after {took:.1f} s:\n{log[-4000:]}"
    assert took < 10.0
    assert "panicked" not in log, log[-4000:]


@pytest.fixture(scope="session")
def client(service):
    c = service.client()
    service.wait_ready(c)
    yield c
    c.close()


@pytest.fixture
def new_client(service):
    """Factory of extra sessions (closed at the end of the test)."""
    made = []

    def make() -> AttitudeClient:
        c = service.client()
        service.wait_ready(c)
        made.append(c)
        return c

    yield make
    for c in made:
        c.close()


def schema(name: str):
    """The JSON Schema validator of ``proto/schemas/<name>.schema.json``, or None when the file (or the
    jsonschema package) is missing."""
    path = SCHEMAS / f"{name}.schema.json"
    if not path.exists():
        return None
    try:
        import jsonschema
    except ImportError:
        return None
    return jsonschema.Draft202012Validator(json.loads(path.read_text()))


def validate(name: str, message) -> bool:
    """Validates ``message`` against schema ``name`` when it exists; True when validated."""
    v = schema(name)
    if v is None:
        return False
    errors = sorted(v.iter_errors(message), key=lambda e: list(e.path))
    assert not errors, f"{name}.schema.json: " + "; ".join(
        f"{list(e.path)}: {e.message}" for e in errors[:5]
    ) + f"\nmessage: {json.dumps(message)[:2000]}"
    return True


class Collector:
    """Thread-safe list of messages received by a subscription callback."""

    def __init__(self):
        self.items: list = []
        self.lock = threading.Lock()

    def __call__(self, message):
        with self.lock:
            self.items.append(message)

    def snapshot(self) -> list:
        with self.lock:
            return list(self.items)

    def where(self, **fields) -> list:
        return [m for m in self.snapshot() if all(m.get(k) == v for k, v in fields.items())]

    def wait_for(self, predicate: Callable[[list], bool], timeout: float, what: str) -> list:
        wait_until(lambda: predicate(self.snapshot()), timeout, what)
        return self.snapshot()


def subscribe_synced(client: AttitudeClient, subscribe: Callable, *args, **kwargs):
    """Declares a subscription, then makes a round trip to the service on the same session: the service
    received the declaration (messages on one link are in order) before it answers. Estimates are put only
    while a subscriber matches, and the service's zenoh tells it of a new one on its own time (behind a
    router, later still): for them it waits for the health's ``listened``. Nothing the service publishes
    afterwards is missed."""
    sub = subscribe(*args, **kwargs)
    client.health()
    if getattr(subscribe, "__name__", "") == "subscribe_estimates":
        client.wait_listened()
    return sub
