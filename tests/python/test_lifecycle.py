"""Process life cycle: start-up on a free port, clean exit on SIGTERM / SIGINT, even with work in flight."""

from __future__ import annotations

import signal
import subprocess

import pytest

from conftest import BIN, ServiceProcess
from sim import Scenario


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_signal_stops_the_service_cleanly(sig):
    svc = ServiceProcess({"filter": {"kind": "qpf", "particles": 2000}}, prefix="lifecycle")
    try:
        with svc.client() as c:
            svc.wait_ready(c)
            # Work in flight: a backlog of particle-filter updates on several vehicles.
            s = Scenario(seed=5, duration_s=20.0)
            chunks = s.chunks()
            for v in ("a", "b", "c"):
                c.publish_vectors_batch(v, [(ch.t, ch.obs) for ch in chunks])
            c.health()
    finally:
        code, took = svc.stop(sig, timeout=10.0)
    log = svc.log()
    assert code == 0, f"exit code {code} after {took:.1f} s:\n{log[-4000:]}"
    assert took < 5.0, f"took {took:.1f} s to stop"
    assert "panicked" not in log, log


def test_help_documents_serve():
    out = subprocess.run([str(BIN), "serve", "--help"], capture_output=True, text=True, timeout=10)
    assert out.returncode == 0
    for option in ("--config", "--listen", "--connect"):
        assert option in out.stdout


def test_invalid_config_fails_fast(tmp_path):
    bad = tmp_path / "bad.json5"
    bad.write_text('{service: {filter: {kind: "ekf"}}}')
    out = subprocess.run([str(BIN), "serve", "--config", str(bad)], capture_output=True, text=True, timeout=20)
    assert out.returncode != 0
    assert "ekf" in out.stderr
