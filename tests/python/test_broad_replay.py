"""The BROAD replay end to end: the real binary with config/imu.json5, attitude-replay (the client package's `attitude_client.replay`) over zenoh.

Replays both committed excerpts (tests/data/broad/: trial 16, fast translations; trial 34, a magnet attached 3 cm
from the sensor) through one service on `P/V/imu`, with the MEKF and the QPF (500 particles; its seed derives from
the vehicle id, fixed here by `--tag`, on a fresh service), and checks the structure of the `--json` output and of
`--details`, that nothing was refused or lost (every sample after the pipeline's 0.1 s alignment has its estimate),
and bounds on accuracy and honesty that the model before `P/V/imu` (a 3 s low-pass of the accelerometer fed at every
sample, no rest detection, no hard-iron fit) fails. Measured (total RMSE °; tilt in 99%, median tilt NEES, heading in
99%):

| excerpt | MEKF | qpf:average (200) | VQF | Madgwick | before `P/V/imu`: MEKF, QPF |
|---|---|---|---|---|---|
| 16 | 0.84; 0.999, 1.20, 1.000 | 1.32; 0.997, 1.29, 1.000 | 0.89 | 4.81 | 1.01; 0.975, 2.34 · 1.06; 0.931, 4.16 |
| 34 | 0.88; 0.997, 1.33, 1.000 | 1.69; 0.996, 1.38, 0.982 | 3.95 | 8.27 | 2.11; 0.997, 1.25 · 2.70; 0.777, 3.90 |

With the preset of issue 26 (tuned on BROAD and two other sensors): MEKF 16 0.81; 0.995, 1.27, 1.000 and 34 1.04;
0.992, 2.00, 1.000; the QPF at this test's tags 34 2.14 (0.54× VQF, the seed's spread below).

Now (the particle filter's Gaussian tilt step and the bias term in the tilt reading, issue 26; the QPF at 500
particles, for 200 before): MEKF 16 0.81; 0.996, 1.18, 1.000 and 34 1.05; 0.993, 1.86, 1.000; the QPF 16 1.26; 0.996,
1.08, 1.000 and 34 1.38; 0.992, 1.89, 1.000. At 200 particles this test's tags gave the QPF 1.83° on 16 (2.06× VQF),
one draw of a spread that `attitude-lab imu-study` shows over five other vehicle ids: 1.04–2.14° on 16 and
1.11–2.58° on 34 (before the two changes 1.10–2.84° and 1.59–3.27°); at 500 particles 0.84–1.50° and 1.05–2.39°.

(The same seed and samples give the same figures run after run; the MEKF's equal `attitude-lab imu-study`'s.)
The QPF's figure is one seed of a wide spread: with 200 particles its heading wanders by the seed. Over other tags,
before issue 26,
(seeds) the total RMSE on 16 had median 1.04° and 90th percentile 1.42° (24 seeds; the scalar particle filter before
issue 15: 1.06°, 1.46°), on 34 median 1.26°, 90th percentile 1.72°, worst 1.97° (48 seeds; before: 1.29°, 1.76°,
2.38°); the tags here gave 0.79° and 1.03° before issue 15 and 1.32° and 1.69° after it.

Bounds: ours at most VQF's total RMSE (16: MEKF 1.0×; the QPF, for its spread, 1.8×) or far below it where VQF's
magnetometer is fooled by the attached magnet (34: 0.35× and 0.5×), inclination within 1.1× VQF's; the tilt inside its 99% ellipse on ≥ 97%
(MEKF) / 95% (QPF) of the samples with a median tilt NEES in [0.7, 2.1] (honest: 1.39; a covariance 1.5× too small
in σ puts it near 3, one 1.4× too large near 0.7), the heading inside 99% on ≥ 95% / 90%; VQF within ±50% of its
measured figure (the data and the metric are read right); Madgwick worse than both of ours; the heading offset
within ±10°.

Data: BROAD (Laidig, Caruso, Cereatti, Seel, Data 6(7), 2021, doi:10.3390/data6070072), CC-BY-4.0.
"""

from __future__ import annotations

import json
import subprocess
import sys

import h5py
import pytest

from attitude_client.replay import ACCURACY_KEYS, HONESTY_KEYS
from conftest import BIN, ROOT, free_port

DATA = ROOT / "tests" / "data" / "broad"
OURS = ("mekf", "qpf:average")
#: Most total RMSE as a multiple of VQF's on the same samples, per excerpt and filter.
MAX_TOTAL_VS_VQF = {
    "16_undisturbed_fast_translation_B_excerpt": {"mekf": 1.0, "qpf:average": 1.8},
    # (The QPF on 34: 1.38° at this seed with 500 particles, 0.35× VQF; 2.14° with 200 before issue 26's last changes.)
    "34_disturbed_attached_magnet_3cm_excerpt": {"mekf": 0.35, "qpf:average": 0.6},
}
#: Least fraction inside the 99% ellipse (tilt, heading), per filter.
MIN_IN99 = {"mekf": (0.97, 0.95), "qpf:average": (0.95, 0.90)}
#: Measured total RMSE, deg: ours (MEKF, QPF with 500 particles) and VQF's.
MEASURED = {
    "16_undisturbed_fast_translation_B_excerpt": {"mekf": 0.81, "qpf:average": 1.26, "vqf": 0.89},
    "34_disturbed_attached_magnet_3cm_excerpt": {"mekf": 1.05, "qpf:average": 1.38, "vqf": 3.95},
}


@pytest.fixture(scope="module")
def imu_service(tmp_path_factory):
    """The preset file itself is the service's config (as a user runs it), on a free port."""
    logdir = tmp_path_factory.mktemp("broad")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    log = open(logdir / "service.log", "wb")
    proc = subprocess.Popen(
        [str(BIN), "serve", "--config", str(ROOT / "config" / "imu.json5"), "--listen", endpoint],
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    try:
        yield endpoint, logdir / "service.log"
    finally:
        proc.terminate()
        proc.wait(timeout=10)
        log.close()


@pytest.mark.parametrize("name", sorted(MEASURED))
def test_broad_excerpt_through_the_service(imu_service, tmp_path, name):
    endpoint, service_log = imu_service
    trial = DATA / f"{name}.hdf5"
    assert trial.exists(), f"{trial} is missing: the committed excerpts (tests/data/broad/README.md) are required"
    with h5py.File(trial, "r") as f:
        n, rate = len(f["imu_gyr"]), float(f.attrs["sampling_rate"])
    out = subprocess.run(
        [sys.executable, "-m", "attitude_client.replay", str(trial), "--connect", endpoint, "--json", "--particles", "500",
         "--tag", f"pytest{name[:2]}", "--details", str(tmp_path / "details.json")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 0, out.stderr + service_log.read_text(errors="replace")[-3000:]
    result = json.loads(out.stdout.strip().splitlines()[-1])
    assert set(result) == {*OURS, "vqf", "madgwick"}
    for est, r in result.items():
        keys = set(ACCURACY_KEYS) | (set(HONESTY_KEYS) if est in OURS else set())
        assert set(r) == keys, est
        assert all(isinstance(v, float) for v in r.values()), (est, r)
    details = json.loads((tmp_path / "details.json").read_text())
    assert details["samples"] == n and details["first_sample"] > 0
    # Every scored sample counts for every estimator: none of ours lacks an estimate.
    assert len(set(details["scored"].values())) == 1 and details["scored"]["mekf"] > 15_000, details["scored"]
    for spec in OURS:
        run = details["service"][spec]
        # Nothing refused or lost: an estimate for each sample after the alignment (0.1 s of samples).
        assert not run["rejected"] and run["missing"] == 0, run
        assert run["aligning"] <= round(0.1 * rate) + 1 and run["estimates"] == n - run["aligning"], run

    measured = MEASURED[name]
    vqf = result["vqf"]["total_rmse_deg"]
    assert 0.5 * measured["vqf"] < vqf < 1.5 * measured["vqf"], result
    for spec in OURS:
        r = result[spec]
        assert r["total_rmse_deg"] <= MAX_TOTAL_VS_VQF[name][spec] * vqf, (spec, r, vqf)
        assert r["inclination_rmse_deg"] <= 1.1 * result["vqf"]["inclination_rmse_deg"], (spec, r, result["vqf"])
        assert r["total_rmse_deg"] < result["madgwick"]["total_rmse_deg"], result
        tilt_min, heading_min = MIN_IN99[spec]
        assert tilt_min <= r["tilt_in99"] <= 1.0 and heading_min <= r["heading_in99"] <= 1.0, (spec, r)
        assert 0.7 <= r["tilt_nees_median"] <= 2.1, (spec, r)
        assert abs(r["heading_offset_deg"]) < 10, (spec, r)
