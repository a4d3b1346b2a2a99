"""Security: the shipped examples of `config/security/` run as they are, with
certificates made by `openssl` at test time (in a temporary directory, removed after a clean run) and
the placeholder paths and ports substituted.

Three deployments, every test runs on each:

* ``tls-usrpwd``: the service itself listens (service-tls-usrpwd.json5: TLS, user/password, ACL);
  clients use client-tls-usrpwd.json5.
* ``mtls``: the service itself listens (service-mtls.json5: mutual TLS, ACL on certificate common
  names); clients use client-mtls.json5.
* ``router``: zenohd 1.10.2 is the trust boundary (router-tls-usrpwd.json5: TLS, user/password, ACL);
  the service connects to it as a client (service-behind-router.json5); clients use
  client-tls-usrpwd.json5 against the router.

Each refusal has a positive control (the same thing done by the identity allowed to do it works), so
every test can fail. What a refusal looks like: a session without valid credentials does not open
(``zenoh.open`` raises); a denied put is dropped (the service never counts it, never creates the
vehicle, publishes nothing); a denied query gets no reply at all (zero replies or zenoh's timeout, never
an answer of the service).
"""

from __future__ import annotations

import json
import os
import pathlib
import re
import shutil
import signal
import subprocess
import tempfile
import time

import pytest
import zenoh

from attitude_client import AttitudeClient, ServiceError
from certs import make_ca, make_cert, make_pki
from conftest import BIN, ROOT, Collector, free_port, wait_until
from attitude_client.tcp_proxy import TcpProxy

SECURITY = ROOT / "config" / "security"
PREFIX = "attitude"  # the examples' key prefix
PLACEHOLDER_DIR = "/etc/attitude-service/"
PLACEHOLDER_LISTEN = "tls/0.0.0.0:7447"
PLACEHOLDER_CONNECT = "tls/localhost:7447"

#: zenoh's access-control interceptor (its decisions are logged at trace level).
ACL_LOG = "zenoh::net::routing::interceptor::access_control"

#: Passwords of the users' dictionary written at test time (`guest` authenticates but is in no subject).
USERS = {
    "sensor-sc1": "pw-sc1",
    "sensor-sc2": "pw-sc2",
    "operator": "pw-operator",
    "service": "pw-service",
    "guest": "pw-guest",
}
#: Client certificates made at test time (`guest` is signed by the CA but is in no subject).
CERT_NAMES = ["sensor-sc1", "sensor-sc2", "operator", "service", "guest"]

TWO_VECTORS = [([1.0, 0.0, 0.0], [1.0, 0.0, 0.0], 1e-3), ([0.0, 1.0, 0.0], [0.0, 1.0, 0.0], 1e-3)]


def zenohd_path() -> pathlib.Path:
    """zenohd 1.10.2 from scripts/ensure-zenohd.sh (which installs it once, in about 6 min)."""
    r = subprocess.run(["bash", str(ROOT / "scripts" / "ensure-zenohd.sh")], capture_output=True, text=True)
    if r.returncode != 0 or not r.stdout.strip():
        pytest.fail(f"scripts/ensure-zenohd.sh failed:\n{r.stderr[-3000:]}")
    return pathlib.Path(r.stdout.strip().splitlines()[-1])


def render(name: str, directory: pathlib.Path, port: int) -> str:
    """The shipped example ``config/security/<name>`` with its placeholders replaced."""
    text = (SECURITY / name).read_text()
    assert PLACEHOLDER_DIR in text, f"{name} lost its placeholder {PLACEHOLDER_DIR}"
    assert PLACEHOLDER_LISTEN in text or PLACEHOLDER_CONNECT in text, f"{name} lost its endpoint placeholder"
    return (
        text.replace(PLACEHOLDER_DIR, f"{directory}/")
        .replace(PLACEHOLDER_LISTEN, f"tls/127.0.0.1:{port}")
        .replace(PLACEHOLDER_CONNECT, f"tls/127.0.0.1:{port}")
    )


class Process:
    """A child process with its log in ``directory/<name>.log``; stopped with SIGTERM."""

    def __init__(self, name: str, args: list[str], directory: pathlib.Path):
        self.name = name
        self.log_path = directory / f"{name}.log"
        self._log = open(self.log_path, "wb")
        env = dict(os.environ)
        # zenoh logs every access-control decision at trace level: the tests read the refusals there.
        env["RUST_LOG"] = os.environ.get("RUST_LOG", "warn") + f",{ACL_LOG}=trace"
        self.proc = subprocess.Popen(args, stdout=self._log, stderr=subprocess.STDOUT, env=env)

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")

    def alive(self):
        if self.proc.poll() is not None:
            pytest.fail(f"{self.name} exited with {self.proc.returncode}:\n{self.log()[-3000:]}")

    def stop(self) -> int | None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        try:
            code = self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(timeout=10)
            code = None
        self._log.close()
        return code


def open_when_up(d: "Deployment", proc: "Process", identity: str, timeout: float = 10.0) -> AttitudeClient:
    """A client session of ``identity``, retried until the listening process accepts it (a client-mode
    session does not open while nothing listens)."""
    deadline = time.monotonic() + timeout
    while True:
        proc.alive()
        try:
            return d.open(identity)
        except zenoh.ZError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.05)


class Deployment:
    """One running deployment: ``open(identity)`` gives a client session logged in as ``identity``."""

    def __init__(self, kind: str, directory: pathlib.Path, zenohd: pathlib.Path | None):
        self.kind = kind
        self.dir = directory
        self.pki = make_pki(directory / "tls", CERT_NAMES)
        # Another CA, not trusted by anyone, with certificates that look right.
        rogue = make_ca(directory / "rogue", "rogue-ca", "rogue-ca")
        make_cert(directory / "rogue", "operator", "operator", rogue, server=False)
        make_cert(directory / "rogue", "server", "localhost", rogue, server=True)
        (directory / "users.txt").write_text("".join(f"{u}:{p}\n" for u, p in USERS.items()))
        self.port = free_port()
        self.processes: list[Process] = []
        self.clients: list[AttitudeClient] = []
        self.t = 0.0  # sample time of the next measurements (each vehicle's times must increase)
        try:
            self._start(zenohd)
        except BaseException:
            self.close(check=False)
            raise

    def _start(self, zenohd: pathlib.Path | None):
        kind, directory = self.kind, self.dir
        if kind == "router":
            self.client_template = "client-tls-usrpwd.json5"
            router_cfg = directory / "router.json5"
            router_cfg.write_text(render("router-tls-usrpwd.json5", directory, self.port))
            router = Process("zenohd", [str(zenohd), "-c", str(router_cfg)], directory)
            self.processes.append(router)
            self.operator = open_when_up(self, router, "operator")
            service_cfg = directory / "service.json5"
            text = render("service-behind-router.json5", directory, self.port)
            text = text.replace('"CHANGE-ME-service"', json.dumps(USERS["service"]))
            service_cfg.write_text(text)
        else:
            name = "service-tls-usrpwd.json5" if kind == "tls-usrpwd" else "service-mtls.json5"
            service_cfg = directory / "service.json5"
            service_cfg.write_text(render(name, directory, self.port))
            self.client_template = "client-tls-usrpwd.json5" if kind == "tls-usrpwd" else "client-mtls.json5"
        self.service = Process("service", [str(BIN), "serve", "--config", str(service_cfg)], directory)
        self.processes.append(self.service)
        if kind != "router":
            self.operator = open_when_up(self, self.service, "operator")
        deadline = time.monotonic() + 20
        while True:
            self.service.alive()
            try:
                self.operator.health(timeout=0.5)
                break
            except TimeoutError:
                if time.monotonic() > deadline:
                    pytest.fail(f"{kind}: the service did not answer the operator:\n{self.service.log()[-3000:]}")

    # --------------------------------------------------------------------------------------------

    def config(self, identity: str | None, **changes) -> zenoh.Config:
        """The shipped client example for this deployment, logged in as ``identity`` (None: no
        credentials at all). ``changes``: zenoh config keys to override (JSON values)."""
        text = render(self.client_template, self.dir, self.port)
        c = zenoh.Config.from_json5(text)
        if self.kind == "mtls":
            if identity is None:  # TLS (the server is verified) without a client certificate
                c.insert_json5("transport/link/tls/enable_mtls", "false")
                c.insert_json5("transport/link/tls/connect_certificate", "null")
                c.insert_json5("transport/link/tls/connect_private_key", "null")
            else:
                cert, key = self.pki / f"{identity}.pem", self.pki / f"{identity}.key"
                c.insert_json5("transport/link/tls/connect_certificate", json.dumps(str(cert)))
                c.insert_json5("transport/link/tls/connect_private_key", json.dumps(str(key)))
        else:
            if identity is None:
                c.insert_json5("transport/auth/usrpwd", "{}")
            else:
                c.insert_json5("transport/auth/usrpwd/user", json.dumps(identity))
                c.insert_json5("transport/auth/usrpwd/password", json.dumps(USERS[identity]))
        for key, value in changes.items():
            c.insert_json5(key, json.dumps(value))
        return c

    def open(self, identity: str | None, **changes) -> AttitudeClient:
        client = AttitudeClient(prefix=PREFIX, timeout=5.0, config=self.config(identity, **changes))
        self.clients.append(client)
        return client

    def refused_configs(self) -> list[tuple[str, zenoh.Config]]:
        """Sessions that must not open, each a one-change variant of the operator's working config."""
        plain = {"connect/endpoints": [f"tcp/127.0.0.1:{self.port}"]}
        rogue_ca = {"transport/link/tls/root_ca_certificate": str(self.dir / "rogue" / "rogue-ca.pem")}
        out = [
            ("no credentials", self.config(None)),
            ("plain TCP to the TLS port", self.config("operator", **plain)),
            ("a client that does not trust the server's CA", self.config("operator", **rogue_ca)),
        ]
        if self.kind == "mtls":
            rogue = self.dir / "rogue"
            out.append(
                (
                    "a certificate with CN=operator signed by another CA",
                    self.config(
                        "operator",
                        **{
                            "transport/link/tls/connect_certificate": str(rogue / "operator.pem"),
                            "transport/link/tls/connect_private_key": str(rogue / "operator.key"),
                        },
                    ),
                )
            )
        else:
            wrong = {"transport/auth/usrpwd/password": "wrong"}
            unknown = {"transport/auth/usrpwd/user": "mallory"}
            out.append(("the operator with a wrong password", self.config("operator", **wrong)))
            out.append(("an unknown user", self.config("operator", **unknown)))
        return out

    def assert_denied(self, who: str, message: str, key: str):
        """The node that carries the policy logged that ``who`` (a user name or certificate CN) is refused
        ``message`` (``Put``, ``Query``, ``Subscriber``, ``Liveliness Token``) on ``key`` in ingress, e.g.
        "... Username(sensor-sc1)+... is unauthorized to Query (ingress) on attitude/sc1/reset". (For a
        declaration, zenoh logs the decision once per key as "Declare/Undeclare Subscriber".)"""
        node = self.processes[0]  # the router, or the service itself
        pattern = re.compile(
            rf"\({re.escape(who)}\).* is unauthorized to (Declare |Declare/Undeclare )?{re.escape(message)} "
            rf"\(ingress\) on {re.escape(key)}$"
        )

        def logged():
            return any(pattern.search(line) for line in node.log().splitlines())

        wait_until(logged, 5, f"{node.name} to log that {who} may not {message} on {key}", interval=0.05)

    def next_t(self) -> float:
        self.t += 1.0
        return self.t

    def feed(self, sensor: AttitudeClient, vehicle: str, estimates: Collector) -> float:
        """Puts a gyro sample and a vector set for ``vehicle`` from ``sensor`` and waits for the
        estimate of that set on the operator's subscription; returns its time."""
        t = self.next_t()
        sensor.publish_gyro(vehicle, t - 0.5, [0.0, 0.0, 0.0])
        sensor.publish_vectors(vehicle, t, TWO_VECTORS)
        deadline = time.monotonic() + 15
        while not any(m["vehicle"] == vehicle and m["t"] == t for m in estimates.snapshot()):
            if time.monotonic() > deadline:
                row = [r for r in self.operator.vehicles() if r["vehicle"] == vehicle]
                pytest.fail(
                    f"{self.kind}: no estimate of {vehicle} at t={t} within 15 s; seen "
                    f"{[(m['vehicle'], m['t']) for m in estimates.snapshot()]}; row {row}; "
                    f"health {self.operator.health()}; files in {self.dir}\n{self.service.log()[-2000:]}"
                )
            time.sleep(0.01)
        return t

    def close(self, check: bool = True):
        try:
            for c in self.clients:
                try:
                    c.close()
                except zenoh.ZError:  # "close operation timed out" on a loaded machine: not what is tested
                    pass
        finally:
            codes = {p.name: p.stop() for p in reversed(self.processes)}
        if not check:
            return
        log = self.service.log()
        assert "panicked" not in log, log[-3000:]
        assert codes["service"] == 0, f"{self.kind}: the service exited with {codes['service']}:\n{log[-3000:]}"


DEPLOYMENTS = ["tls-usrpwd", "mtls", "router"]


@pytest.fixture(scope="module", params=DEPLOYMENTS)
def deployment(request):
    zenohd = None
    if request.param == "router":
        zenohd = zenohd_path()
    # Our own temporary directory, as conftest's services do: pytest's numbered tmp_path directories
    # are rotated by any other pytest session that starts meanwhile on this machine. It holds the
    # private keys and the logs: removed after a clean run, kept (and named in the failure) otherwise.
    directory = pathlib.Path(tempfile.mkdtemp(prefix=f"attitude-security-{request.param}-"))
    d = Deployment(request.param, directory, zenohd)
    try:
        yield d
    finally:
        d.close()
    shutil.rmtree(directory, ignore_errors=True)


def operator_estimates(d: Deployment) -> tuple[Collector, object]:
    """The operator's subscription to every estimate, synchronised with the service (which puts estimates
    only while it knows of a subscriber: behind a router a health query could come back before that)."""
    estimates = Collector()
    sub = d.operator.subscribe_estimates(estimates)
    d.operator.wait_listened()
    return estimates, sub


def answered(replies: list) -> list:
    """The replies that carry an answer of the service (not zenoh's own timeout error)."""
    out = []
    for key, ok, payload in replies:
        if ok or b"timeout" not in payload.lower():
            out.append((key, ok, payload))
    return out


# ------------------------------------------------------------------------------------------------


def test_client_without_credentials_is_refused(deployment):
    d = deployment
    for what, config in d.refused_configs():
        t0 = time.monotonic()
        try:
            session = zenoh.open(config)
        except zenoh.ZError as e:
            assert "Unable to connect" in str(e), (what, str(e))
            assert time.monotonic() - t0 < 15, what
            continue
        session.close()
        pytest.fail(f"{d.kind}: a session opened with {what}")
    # Positive control: the same configuration with the right credentials opens and is answered.
    operator = d.open("operator")
    assert operator.health(timeout=5)["status"]
    sensor = d.open("sensor-sc1")
    assert sensor.session.info.routers_zid() or sensor.session.info.peers_zid()


def test_sensor_put_to_another_vehicle_is_dropped(deployment):
    d = deployment
    estimates, sub = operator_estimates(d)
    rejections = Collector()
    rsub = d.operator.subscribe_rejections(rejections)
    received0 = d.operator.health()["received"]
    sensor = d.open("sensor-sc1")
    # First the other vehicle's keys (sc2 belongs to sensor-sc2), then its own: messages of one session
    # arrive in order, so once sc1's estimate is out, sc2's puts would have been received before it.
    t = d.next_t()
    sensor.publish_gyro("sc2", t - 0.5, [0.0, 0.0, 0.0])
    sensor.publish_vectors("sc2", t, TWO_VECTORS)
    t1 = d.feed(sensor, "sc1", estimates)  # positive control: its own vehicle is processed
    assert d.operator.get_state("sc1")["t"] == t1
    time.sleep(0.3)
    assert "sc2" not in {m["vehicle"] for m in estimates.snapshot()}
    assert not rejections.snapshot(), rejections.snapshot()
    assert "sc2" not in {r["vehicle"] for r in d.operator.vehicles()}
    with pytest.raises(ServiceError) as e:
        d.operator.get_state("sc2")
    assert e.value.code == "unknown_vehicle"
    # Exactly sc1's two messages were received: the two for sc2 never reached the service.
    assert d.operator.health()["received"] - received0 == 2
    d.assert_denied("sensor-sc1", "Put", "attitude/sc2/gyro")
    d.assert_denied("sensor-sc1", "Put", "attitude/sc2/vectors")
    # Positive control: the same keys are accepted from sc2's own sensors.
    d.feed(d.open("sensor-sc2"), "sc2", estimates)
    sub.undeclare()
    rsub.undeclare()


def test_a_sensors_puts_during_a_cut_link_come_back_through_the_policy(deployment):
    """The client's advanced publishers through the policy (the rules `sc1-caches` and `sensors-told`): the
    sensor's link is cut (a TCP proxy in front of the TLS endpoint) while it puts three sets; when it is back
    the service fetches them from the sensor's cache, so every sample is received and the last set has its
    estimate. (Without those rules a sensor's declared publishers stop sending once they learn of no
    subscriber, and nothing could be fetched again.)"""
    d = deployment
    estimates, sub = operator_estimates(d)
    proxy = TcpProxy(("127.0.0.1", d.port))
    try:
        sensor = d.open("sensor-sc1", **{"connect/endpoints": [f"tls/127.0.0.1:{proxy.port}"]})
        d.feed(sensor, "sc1", estimates)
        received0 = d.operator.health()["received"]
        proxy.cut(2.0)
        time.sleep(0.2)
        for _ in range(3):
            t = d.next_t()
            sensor.publish_gyro("sc1", t - 0.5, [0.0, 0.0, 0.0])
            sensor.publish_vectors("sc1", t, TWO_VECTORS)
        wait_until(lambda: any(m["vehicle"] == "sc1" and m["t"] == t for m in estimates.snapshot()), 20,
                   "the estimate of the last set put during the cut")
        assert proxy.connections >= 2, proxy.connections
        assert d.operator.health()["received"] - received0 == 6
        assert d.operator.health()["missed"] == 0
    finally:
        proxy.close()
        sub.undeclare()


def test_reset_by_a_sensor_is_refused(deployment):
    d = deployment
    estimates, sub = operator_estimates(d)
    sensor = d.open("sensor-sc1")
    d.feed(sensor, "sc1", estimates)
    before = d.operator.get_state("sc1")
    filter_before = next(r for r in d.operator.vehicles() if r["vehicle"] == "sc1")["filter"]
    other = "usque" if filter_before != "usque" else "mekf"
    request = json.dumps({"filter": other, "q": {"w": 0.0, "x": 1.0, "y": 0.0, "z": 0.0}, "sigma_deg": 5.0})
    # The sensor's reset of its own vehicle: no reply at all (the query never reaches the service).
    replies = sensor.query("sc1/reset", payload=request, timeout=1.0)
    assert answered(replies) == [], replies
    d.assert_denied("sensor-sc1", "Query", "attitude/sc1/reset")
    time.sleep(0.2)
    after = d.operator.get_state("sc1")
    assert after == before  # same seq, t, q, filter: the filter is unchanged
    assert next(r for r in d.operator.vehicles() if r["vehicle"] == "sc1")["filter"] == filter_before
    # Positive control: the operator's identical reset works.
    reply = d.operator.reset("sc1", **json.loads(request))
    assert reply["filter"] == other
    assert d.operator.get_state("sc1")["filter"] == other
    sub.undeclare()


def test_everything_else_a_sensor_tries_is_refused(deployment):
    d = deployment
    estimates, sub = operator_estimates(d)
    sensor = d.open("sensor-sc1")
    d.feed(sensor, "sc1", estimates)  # so that sc1 has an estimate to ask for
    # Sensors cannot query anything, not even their own vehicle's state or the health.
    for selector in ("@/health", "@/vehicles", "sc1/state", "*/attitude"):
        assert answered(sensor.query(selector, timeout=1.0)) == [], selector
        assert answered(d.operator.query(selector, timeout=5.0)), f"operator: {selector}"  # positive control
    # Sensors cannot subscribe to estimates, not even their own vehicle's.
    seen_all, seen_own = Collector(), Collector()
    sensor.subscribe_estimates(seen_all)
    sensor.subscribe_estimates(seen_own, vehicle="sc1")
    time.sleep(0.3)  # let the (refused) declarations travel
    t = d.feed(sensor, "sc1", estimates)  # the operator sees this estimate
    time.sleep(0.3)
    assert seen_all.snapshot() == [] and seen_own.snapshot() == [], t
    d.assert_denied("sensor-sc1", "Subscriber", "attitude/*/estimate")
    d.assert_denied("sensor-sc1", "Subscriber", "attitude/sc1/estimate")
    # An operator cannot put measurements (it may only query and subscribe), and an identity that
    # authenticates but is in no subject can do nothing.
    received0 = d.operator.health()["received"]
    guest = d.open("guest")
    assert answered(guest.query("@/health", timeout=1.0)) == []
    for client in (d.operator, guest):
        for vehicle in ("sc1", "sc2"):
            t = d.next_t()
            client.publish_gyro(vehicle, t - 0.5, [0.0, 0.0, 0.0])
            client.publish_vectors(vehicle, t, TWO_VECTORS)
    time.sleep(0.5)
    assert d.operator.health()["received"] == received0
    d.assert_denied("operator", "Put", "attitude/sc1/vectors")
    # (guest's refusals leave no such line: it matches no subject, so the default permission applies.)
    # Positive control of the last check: sensor-sc1's puts in the same way are received.
    d.feed(sensor, "sc1", estimates)
    assert d.operator.health()["received"] == received0 + 2
    sub.undeclare()


def test_fleet_liveliness_is_left_to_services(deployment):
    """The fleet work needs liveliness tokens under P/@/fleet/** between service instances: a session
    logged in as `service` may declare one and another `service` session sees it; a sensor's token is
    not seen."""
    d = deployment
    a, b = d.open("service"), d.open("service")
    sensor = d.open("sensor-sc1")
    token = a.session.liveliness().declare_token(f"{PREFIX}/@/fleet/instance-a")
    evil = sensor.session.liveliness().declare_token(f"{PREFIX}/@/fleet/instance-evil")
    seen: set[str] = set()

    def look():
        seen.clear()
        for reply in b.session.liveliness().get(f"{PREFIX}/@/fleet/**", timeout=2.0):
            if reply.ok is not None:
                seen.add(str(reply.ok.key_expr))
        return f"{PREFIX}/@/fleet/instance-a" in seen

    wait_until(look, 10, "the service token")
    time.sleep(0.3)  # the sensor's token was declared before: give it time to travel too
    wait_until(look, 10, "the service token")
    assert seen == {f"{PREFIX}/@/fleet/instance-a"}, seen
    d.assert_denied("sensor-sc1", "Liveliness Token", f"{PREFIX}/@/fleet/instance-evil")
    token.undeclare()
    # The receiving node logs "Unknown token" here: the ACL dropped this token's declaration.
    evil.undeclare()


def test_examples_share_one_policy():
    """The three server-side examples carry the same rules and policies (only the subjects differ:
    user names or certificate common names, plus the other site's router on the router)."""

    def block(name: str, start: str) -> list[str]:
        """The stripped lines from ``start`` to the first line that closes a list (``],``)."""
        lines = [line.strip() for line in (SECURITY / name).read_text().splitlines()]
        i = lines.index(start)
        return lines[i : lines.index("],", i) + 1]

    names = ["service-tls-usrpwd.json5", "service-mtls.json5", "router-tls-usrpwd.json5"]
    rules = [block(n, "rules: [") for n in names]
    policies = [block(n, "policies: [") for n in names]
    assert len(rules[0]) > 50 and len(policies[0]) > 4
    assert rules[0] == rules[1] == rules[2]
    assert policies[0] == policies[1] == policies[2]
