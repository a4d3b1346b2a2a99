"""The same input, the same output, through the real binary over zenoh: one recording replayed on `P/V/imu` three
times gives identical estimates (every quaternion and covariance bit for bit), with nothing refused or lost:

* run A: a fresh service, the vehicles never seen before, no reset, batches of 50 samples as fast as the flow control
  allows;
* run B: another fresh service, the same vehicle ids, no reset, batches of 7 samples with a pause between puts (other
  arrival timing, other reorder-window releases);
* run C: the same vehicles of service B again, after a reset with a time before the recording (the way to replay into
  a vehicle that has seen later samples), in batches of 400.

For the MEKF (the preset's filter) and for qpf:average (200 particles, given by a per-vehicle override of the preset,
so that runs A and B need no reset): a particle filter draws its particles from a seed of its vehicle id, and a reset
starts the vehicle over, seed included.

The suite replays the excerpt up to 10 s into the motion; `ATTITUDE_DETERMINISM_TRIAL=FILE.hdf5` (and
`ATTITUDE_DETERMINISM_SECONDS=S`, 0 for the whole recording) run the same test on another recording, e.g. a full trial.

Data: an excerpt of BROAD trial 16 committed in tests/data/broad (Laidig, Caruso, Cereatti, Seel, Data 6(7), 2021,
doi:10.3390/data6070072), CC-BY-4.0.
"""

from __future__ import annotations

from pathlib import Path

import argparse
import os
import subprocess
import sys
import time

import numpy as np

from conftest import BIN, ROOT, free_port

from attitude_client import AttitudeClient  # noqa: E402
from attitude_client.replay import load_trial, replay  # noqa: E402

TRIAL = Path(
    os.environ.get("ATTITUDE_DETERMINISM_TRIAL")
    or ROOT / "tests" / "data" / "broad" / "16_undisturbed_fast_translation_B_excerpt.hdf5"
)
#: Seconds of motion replayed (after the opening rest); 0: the whole recording.
SECONDS = float(os.environ.get("ATTITUDE_DETERMINISM_SECONDS", "10"))
SPECS = ["mekf", "qpf:average"]


def start(tmp_path, name: str):
    preset = (ROOT / "config" / "imu.json5").read_text()
    assert "    vehicles: {}," in preset
    # The particle filter's vehicle by configuration (attitude-replay names it broad-qpf-average-TAG).
    config = preset.replace(
        "    vehicles: {},", '    vehicles: { "broad-qpf-average-det": { kind: "qpf", particles: 200 } },'
    )
    path = tmp_path / f"{name}.json5"
    path.write_text(config)
    port = free_port()
    log = open(tmp_path / f"{name}.log", "wb")
    proc = subprocess.Popen(
        [str(BIN), "serve", "--config", str(path), "--listen", f"tcp/127.0.0.1:{port}"],
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    return proc, f"tcp/127.0.0.1:{port}"


def run(client: AttitudeClient, trial: dict, batch: int, pause: float, reset_t: float | None) -> dict:
    args = argparse.Namespace(
        tag="det", vehicle_prefix="broad", particles=200, batch=batch, window=2000, timeout=60.0, copies=1,
        pause=pause, reset_t=reset_t, no_reset=reset_t is None,
    )
    out = {}
    for spec in SPECS:
        out.update(replay(client, trial, [spec], args))
    return out


def test_the_same_recording_gives_the_same_estimates(tmp_path):
    assert TRIAL.exists(), f"{TRIAL} is missing: the test data of the repository (tests/data/broad/README.md)"
    trial = load_trial(TRIAL, SECONDS or None)
    n = len(trial["gyr"])
    runs = {}
    proc_a, endpoint_a = start(tmp_path, "a")
    try:
        with AttitudeClient(endpoint_a, timeout=10.0) as c:
            c.wait_for_service(timeout=20.0)
            runs["A"] = run(c, trial, 50, 0.0, None)
    finally:
        proc_a.terminate()
        proc_a.wait(timeout=10)
    proc_b, endpoint_b = start(tmp_path, "b")
    try:
        with AttitudeClient(endpoint_b, timeout=10.0) as c:
            c.wait_for_service(timeout=20.0)
            runs["B"] = run(c, trial, 7, 0.002, None)
            time.sleep(0.5)
            runs["C"] = run(c, trial, 400, 0.0, float(trial["t"][0]) - 1.0)
    finally:
        proc_b.terminate()
        proc_b.wait(timeout=10)
    for spec in SPECS:
        for name, r in runs.items():
            got = r[spec]
            assert not got["rejected"], (name, spec, got["rejected"])
            assert got["missing"] == 0, (name, spec, got["missing"])
            # Every sample after the 0.1 s alignment has its estimate.
            assert got["estimates"] == n - got["aligning"] and got["aligning"] < 40, (name, spec, got["estimates"])
        a = runs["A"][spec]
        for name in ("B", "C"):
            b = runs[name][spec]
            assert np.array_equal(a["quat"], b["quat"], equal_nan=True), (spec, name)
            assert np.array_equal(a["cov_att"], b["cov_att"], equal_nan=True), (spec, name)
