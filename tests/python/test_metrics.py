"""HTTP through zenoh's REST plugin, against the real binary: `serve --rest-http-port` (the plugin linked into
the service) and a zenohd router that loads the plugin as a library. urllib is the HTTP client, and
prometheus_client's OpenMetrics parser (an implementation independent of the Rust encoder) reads the metrics.

* `test_rest_http_port_serves_attitudes_and_metrics`: an attitude as JSON (the plugin's list of samples,
  and the raw reply with Content-Type application/json), an error reply, and `@/metrics?_raw=true` requested
  as Prometheus does (DEPLOYMENT.md's scrape configuration, Prometheus's Accept header): Content-Type
  `application/openmetrics-text; version=1.0.0; charset=utf-8`, parsed, counters moving with the inputs and a
  rejection under its code; the same text as a zenoh get of `@/metrics`.
* `test_the_same_urls_through_a_router_running_the_plugin`: zenohd 1.10.2 with the REST plugin
  (`scripts/ensure-zenohd.sh` builds both once into a cache), the service attached to it as a peer without
  HTTP of its own: the same URLs on the router's HTTP port give the same answers.
"""

from __future__ import annotations

import json
import os
import pathlib
import re
import signal
import subprocess
import time
import urllib.error
import urllib.parse
import urllib.request

import pytest
from prometheus_client.openmetrics.parser import text_string_to_metric_families

from conftest import BIN, ROOT, ServiceProcess, free_port, schema, wait_until

PREFIX = "attitude"
METRICS_TYPE = "application/openmetrics-text; version=1.0.0; charset=utf-8"
#: What Prometheus 3 sends (scrape_protocols' default order).
PROMETHEUS_ACCEPT = (
    "application/openmetrics-text;version=1.0.0;escaping=allow-utf-8;q=0.5,"
    "application/openmetrics-text;version=0.0.1;q=0.4,text/plain;version=1.0.0;escaping=allow-utf-8;q=0.3,"
    "text/plain;version=0.0.4;q=0.2,*/*;q=0.1"
)

STARS = [([1.0, 0.0, 0.0], 1e-4), ([0.0, 0.6, 0.8], 1e-4), ([0.0, -0.8, 0.6], 1e-4)]


def http_get(url: str, accept: str | None = None) -> tuple[int, str, bytes]:
    req = urllib.request.Request(url, headers={"Accept": accept} if accept else {})
    try:
        with urllib.request.urlopen(req, timeout=10) as r:
            return r.status, r.headers.get("Content-Type", ""), r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.headers.get("Content-Type", ""), e.read()


def scrape_config() -> tuple[str, dict[str, list[str]]]:
    """`metrics_path` and `params` of the Prometheus scrape configuration in DEPLOYMENT.md."""
    text = (ROOT / "DEPLOYMENT.md").read_text()
    block = re.search(r"```yaml\n(scrape_configs:.*?)```", text, re.S)
    assert block, "DEPLOYMENT.md has a ```yaml scrape_configs block"
    path = re.search(r"metrics_path:\s*(\S+)", block.group(1)).group(1)
    raw = re.search(r"_raw:\s*(\[.*?\])", block.group(1)).group(1)
    return path, {"_raw": json.loads(raw)}


def scrape(base: str) -> dict:
    """GET the metrics as Prometheus does with DEPLOYMENT.md's configuration; {family name: family}."""
    path, params = scrape_config()
    url = f"{base}{path}?{urllib.parse.urlencode(params, doseq=True)}"
    status, content_type, body = http_get(url, accept=PROMETHEUS_ACCEPT)
    assert status == 200, (url, status, body[:200])
    assert content_type == METRICS_TYPE, content_type
    return {f.name: f for f in text_string_to_metric_families(body.decode())}


def sample(families: dict, family: str, suffix: str = "", **labels) -> float | None:
    for s in families[family].samples:
        if s.name == family + suffix and s.labels == labels:
            return s.value
    return None


def attitude_over_http(base: str, vehicle: str) -> dict:
    """`GET P/V/attitude`: the plugin's JSON list of samples, and the raw reply; both JSON and saying so."""
    status, content_type, body = http_get(f"{base}/{PREFIX}/{vehicle}/attitude")
    assert (status, content_type) == (200, "application/json"), (status, content_type, body)
    samples = json.loads(body)
    assert [(s["key"], s["encoding"]) for s in samples] == [(f"{PREFIX}/{vehicle}/attitude", "application/json")]
    status, content_type, body = http_get(f"{base}/{PREFIX}/{vehicle}/attitude?_raw=true")
    assert (status, content_type) == (200, "application/json"), (status, content_type, body)
    raw = json.loads(body)
    assert raw == samples[0]["value"]
    validator = schema("attitude")
    if validator is not None:
        validator.validate(raw)
    return raw


def feed(client, vehicle: str, n: int) -> None:
    for k in range(n):
        client.publish_gyro(vehicle, float(k), [0.0, 0.0, 0.0])
        client.publish_vectors(vehicle, k + 0.5, [(b, b, s) for b, s in STARS])


def test_rest_http_port_serves_attitudes_and_metrics():
    http = free_port()
    svc = ServiceProcess({"filter": {"kind": "mekf"}}, prefix=PREFIX, args=["--rest-http-port", f"127.0.0.1:{http}"])
    client = svc.client()
    base = f"http://127.0.0.1:{http}"
    try:
        svc.wait_ready(client)
        before = scrape(base)
        assert sample(before, "attitude_estimates_published", "_total") == 0
        assert sample(before, "attitude_rejected", "_total", code="invalid_json") == 0
        feed(client, "sc1", 5)
        client.put_raw("sc1", "gyro", b"{not json")
        wait_until(
            lambda: sample(scrape(base), "attitude_processed", "_total") == 10, 15, "10 samples processed"
        )
        a = attitude_over_http(base, "sc1")
        assert a["vehicle"] == "sc1" and a["t"] == 4.5

        m = scrape(base)
        types = {name: f.type for name, f in m.items()}
        assert types["attitude_received"] == "counter"
        assert types["attitude_step_seconds"] == "histogram"
        assert types["attitude_inbox_depth"] == "gauge"
        assert types["attitude_service"] == "info"
        assert sample(m, "attitude_received", "_total") == 11
        assert sample(m, "attitude_estimates_published", "_total") == 5
        assert sample(m, "attitude_rejected", "_total", code="invalid_json") == 1
        assert sample(m, "attitude_vehicle_rejected", "_total", vehicle="sc1", code="invalid_json") == 1
        assert sample(m, "attitude_vehicle_processed", "_total", vehicle="sc1") == 10
        assert sample(m, "attitude_step_seconds", "_count", filter="mekf") == 10
        assert sample(m, "attitude_step_seconds", "_bucket", filter="mekf", le="+Inf") == 10
        assert sample(m, "attitude_vehicles", filter="mekf", state="tracking") == 1

        # An unknown vehicle: the error reply, as JSON.
        status, content_type, body = http_get(f"{base}/{PREFIX}/nobody/attitude?_raw=true")
        assert (status, content_type) == (200, "application/json")
        assert json.loads(body)["code"] == "unknown_vehicle"

        # The HTTP text is the zenoh reply: the same families as a get of P/@/metrics.
        [(key, ok, payload)] = client.query("@/metrics")
        assert ok and key == f"{PREFIX}/@/metrics"
        assert {f.name for f in text_string_to_metric_families(payload.decode())} == set(m)
    finally:
        client.close()
        code, _ = svc.stop()
        log = svc.log()
    assert code == 0, log[-3000:]
    assert "panicked" not in log, log[-3000:]


def ensured() -> tuple[str, pathlib.Path]:
    """zenohd and the folder of its REST plugin library (built once by scripts/ensure-zenohd.sh)."""
    out = subprocess.run(
        ["bash", str(ROOT / "scripts" / "ensure-zenohd.sh")], check=True, capture_output=True, text=True
    )
    zenohd = out.stdout.strip().splitlines()[-1]
    return zenohd, pathlib.Path(zenohd).parent.parent / "lib"


def test_the_same_urls_through_a_router_running_the_plugin(tmp_path):
    zenohd, plugins = ensured()
    work = tmp_path
    zport, http = free_port(), free_port()
    router_log = open(work / "zenohd.log", "wb")
    router = subprocess.Popen(
        [
            zenohd, "--no-multicast-scouting", "-l", f"tcp/127.0.0.1:{zport}",
            "--plugin-search-dir", str(plugins), "--rest-http-port", f"127.0.0.1:{http}",
        ],
        stdout=router_log, stderr=subprocess.STDOUT, env={**os.environ, "RUST_LOG": "info"},
    )  # fmt: skip
    svc = ServiceProcess({"filter": {"kind": "mekf"}}, prefix=PREFIX, args=["--connect", f"tcp/127.0.0.1:{zport}"])
    client = svc.client()
    base = f"http://127.0.0.1:{http}"

    def through_router() -> bool:
        try:
            return http_get(f"{base}/{PREFIX}/@/health?_raw=true")[0:2] == (200, "application/json")
        except OSError:
            return False

    try:
        svc.wait_ready(client)
        wait_until(through_router, 20, "the service's health through the router's HTTP port", interval=0.1)
        feed(client, "sc1", 3)
        wait_until(lambda: sample(scrape(base), "attitude_processed", "_total") == 6, 15, "6 samples processed")
        a = attitude_over_http(base, "sc1")
        assert a == client.get_attitude("sc1")
        m = scrape(base)
        assert sample(m, "attitude_estimates_published", "_total") == 3
        assert sample(m, "attitude_vehicle_estimates_published", "_total", vehicle="sc1") == 3
        # The router's own page: its REST plugin (zenohd's admin space, not the service).
        status, _, body = http_get(f"{base}/@/local/router?_raw=true")
        assert status == 200 and b"rest" in body, body[:300]
    finally:
        client.close()
        code, _ = svc.stop()
        router.send_signal(signal.SIGTERM)
        try:
            router.wait(timeout=10)
        except subprocess.TimeoutExpired:
            router.kill()
            router.wait(timeout=10)
        router_log.close()
    assert code == 0, svc.log()[-3000:]
