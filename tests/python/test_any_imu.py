"""Any IMU, any rate (issue 26): the committed BROAD excerpts altered as another sensor or driver would have given
them, through the service's vehicle pipeline (`attitude-lab imu-study`, the code a `serve` vehicle runs, with
config/imu.json5), scored beside VQF on the very same altered samples (`attitude_client.alter`, docs/recordings.md).

Each alteration keeps the truth; what changes is what the estimator sees: another rate (25, 40, 50, 100 Hz and
1 kHz, the gyro's integral kept), irregular intervals (±50% at 100 Hz), held samples (30% of the samples repeat the previous
reading), a gyro clipped at 4 and at 6 rad/s (inferred from the clipped output: no range is configured), a start in motion
(no opening rest: alignment, bias and field learned on the move), a magnetometer in nT instead of µT, a
magnetometer 10 and 30 times slower than the gyro whose driver repeats its last reading in between, and five
holes of 0.15 s in the motion filled in on the line between the real samples on both sides (what a converter that
resamples onto a uniform grid does; at 285.7 Hz and at 50 Hz), and all at once (40 Hz, ±20% intervals, 5% held, the
magnetometer every second sample and in other units, clipped at 6 rad/s, started in motion). The bounds
are per alteration: accuracy within a factor of VQF's on the same samples, and honesty (the tilt inside its 99%
ellipse, the 3-axis error inside its 99% ellipsoid, the median tilt NEES). The figures measured are in `BOUNDS`'
comment.

One altered recording also goes through the real service over zenoh (`attitude-replay` of the CSV): the same
figures as in process.

Data: BROAD (Laidig, Caruso, Cereatti, Seel, Data 6(7), 2021, doi:10.3390/data6070072), CC-BY-4.0.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from attitude_client.alter import alter, write_csv
from attitude_client.replay import broad_scores, load_trial, run_vqf
from conftest import BIN, LAB, ROOT, free_port

DATA = ROOT / "tests" / "data" / "broad"
EXCERPTS = ("16_undisturbed_fast_translation_B_excerpt", "34_disturbed_attached_magnet_3cm_excerpt")

#: Five holes of 0.15 s in the excerpts' motion (seconds from the first sample, and the span).
HOLES = tuple((t0, 0.15) for t0 in (25.0, 35.0, 45.0, 55.0, 65.0))

#: The alterations: name → attitude_client.alter's arguments.
ALTERATIONS = {
    "r25": dict(rate=25.0),
    "r40": dict(rate=40.0),
    "r50": dict(rate=50.0),
    "r100": dict(rate=100.0),
    "r1000": dict(rate=1000.0),
    "jitter": dict(rate=100.0, jitter=0.5),
    "hold": dict(hold=0.3),
    "clip4": dict(clip=4.0),
    "clip6": dict(clip=6.0),
    "motion": dict(start_in_motion=True),
    "nT": dict(mag_scale=1000.0),
    "mag10": dict(mag_every=10),
    "mag30": dict(mag_every=30),
    "filled": dict(drop_bursts=HOLES, fill=True),
    "filled50": dict(rate=50.0, drop_bursts=HOLES, fill=True),
    # Everything at once, as a user's own device might give it.
    "all": dict(rate=40.0, jitter=0.2, hold=0.05, mag_every=2, clip=6.0, mag_scale=0.01, start_in_motion=True),
}

#: Per alteration: the most total RMSE as a multiple of VQF's on the same samples, the least tilt and 3-axis
#: fractions inside 99%, and the range of the median tilt NEES (honest: 1.39). Both runs are deterministic, so
#: the bounds sit just outside what was measured (excerpts 16 / 34, the preset of issue 26):
#:
#: | alteration | total / VQF | tilt in 99% | 3-axis in 99% | tilt NEES median |
#: |---|---|---|---|---|
#: | r25    | 1.34 / 0.35 | 0.978 / 0.999 | 0.986 / 0.999 | 0.46 / 0.58 |
#: | r40    | 1.18 / 0.32 | 1.000 / 0.998 | 1.000 / 1.000 | 0.45 / 0.71 |
#: | r50    | 1.09 / 0.33 | 1.000 / 0.999 | 1.000 / 1.000 | 0.44 / 0.74 |
#: | r100   | 0.97 / 0.33 | 0.999 / 0.998 | 1.000 / 0.999 | 0.69 / 1.00 |
#: | r1000  | 0.86 / 0.29 | 0.995 / 0.998 | 0.998 / 0.998 | 1.65 / 1.45 |
#: | jitter | 0.16 / 0.12 | 0.964 / 0.998 | 0.986 / 0.999 | 1.64 / 0.95 |
#: | hold   | 0.30 / 0.28 | 1.000 / 1.000 | 1.000 / 1.000 | 0.17 / 0.70 |
#: | clip4  | 1.08 / 0.75 | 0.998 / 1.000 | 1.000 / 1.000 | 0.19 / 0.07 |
#: | clip6  | 1.32 / 0.28 | 0.998 / 0.998 | 1.000 / 1.000 | 0.04 / 1.26 |
#: | motion | 0.53 / 0.32 | 1.000 / 1.000 | 1.000 / 1.000 | 0.25 / 0.26 |
#: | nT     | 0.83 / 0.28 | 0.998 / 0.998 | 1.000 / 1.000 | 1.31 / 1.26 |
#: | mag10  | 0.77 / 0.22 | 0.998 / 0.998 | 1.000 / 1.000 | 1.31 / 1.26 |
#: | mag30  | 0.60 / 0.22 | 0.998 / 0.998 | 1.000 / 1.000 | 1.31 / 1.26 |
#: | filled | 0.90 / 0.44 | 0.998 / 1.000 | 0.989 / 1.000 | 0.54 / 0.10 |
#: | filled50 | 0.95 / 0.49 | 1.000 / 1.000 | 1.000 / 1.000 | 0.35 / 0.07 |
#: | all    | 0.70 / 0.26 | 1.000 / 1.000 | 1.000 / 1.000 | 0.15 / 0.32 |
#:
#: r1000 is a faster sensor of the same kind (`alter`'s rate above the source's: the rates on a smooth curve through
#: the source's, white noise added to keep each channel's noise density; see `test_a_faster_rate_is_a_faster_sensor`).
#: Resampled as before, with every reading held over its source interval, the 1 kHz stream repeated each reading
#: three or four times to within rounding, a run the pipeline rightly takes for made-up samples (a filled hole), and
#: the covariance was six times too wide (median tilt NEES 0.09 / 0.12): no real 1 kHz sensor's readings do that.
#:
#: The preset before 2026-11-30's retuning (`gyro.change_factor` 0.5 instead of 0.12, `motion_gain` 0.75, the
#: magnetometer's σ 0.03 rad; docs/broad.md, "A second basin") was as accurate or less at the low rates and far more
#: cautious: r25 1.40 / 0.44, r40 1.27 / 0.30, r50 1.19 / 0.26, r100 1.02 / 0.22, with median tilt NEES 0.16–0.49.
#: The retuning moved four bounds outward, each because its measured figure moved past it: r25's NEES ceiling
#: 0.5 → 0.7 (0.58: less cautious), jitter's tilt 0.97 → 0.955 (0.984 → 0.964), filled's 3-axis 0.99 → 0.98
#: (0.996 → 0.989), filled50's NEES ceiling 0.3 → 0.45 (0.35). Every other bound stayed or tightened.
#:
#: The low rates changed with two models of what a sample's interval holds (`ahrs/mod.rs`, `sensors/gyro/channel.rs`):
#: readings that are their interval's mean describe the body half an interval before the gyro's integral (gravity and
#: the field are turned forward by it), and one rotation step per interval leaves out the coning term of the interval
#: before. Before them, total / VQF was 1.23 / 0.71 at 25 Hz, 1.20 / 0.52 at 40, 1.14 / 0.43 at 50 and 1.05 / 0.26 at
#: 100 Hz. Excerpt 34 gained; excerpt 16 (a fast translation) lost a little, by a heading offset of a few tenths of a
#: degree that the coning term moves (docs/broad.md, "What a sample's interval holds").
#:
#: A slower magnetometer was a miss until a repeated reading was turned by the gyro frame's rotation since it was new
#: (`ahrs/mod.rs`, `MagHold`): the stale readings pulled the heading back to where the body pointed when they were
#: taken, 1.14× VQF's total on excerpt 16 with every 10th reading new (0.88× with every 30th, 0.52× / 0.48× on 34).
#: Filled holes were a miss until a run of samples on one line was taken for what it is, a gap someone filled in
#: (`ahrs/mod.rs`, `Interpolation`; the variance a gap of the run's length hides): the made-up rates turned the
#: filter as if real, and the tilt was inside its 99% ellipse 68% / 81% of the time (3-axis 63% / 84%) at 285.7 Hz,
#: 80% / 94% at 50 Hz.
#:
#: Held samples were a miss until the held run's catch-up (`ahrs/mod.rs`, `held_catch_up`): the held readings turned
#: the gyro frame by the stale rate, the tilt was inside its 99% ellipse 82% of the time on excerpt 16 (median NEES
#: 2.84) and the total RMSE 0.99× VQF's; now the run is turned by the line between the rates on both sides and the
#: frame's error is told to the low-pass. A start in motion was a miss until the bias's variance entered the tilt
#: reading (`GravityChannel::observation`): on excerpt 34 (an attached magnet, no rest to learn the bias or the field
#: from) the tilt was inside its 99% ellipse 88% of the time (median NEES 1.91), because the unlearnt bias turns the
#: gyro frame the accelerometer's low-pass lives in; now 100% (median NEES 0.30: cautious while the bias is learned).
#: Before the saturation term was widened (saturation_factor 0.25 → 1) the clipped excerpt 16 had 71% inside.
#: The saturation term was spread over every axis until 2026-12-02; it is now about the saturated axes alone
#: (`GyroChannel::saturation_variance`): clip4 was 1.38 / 0.83 (its bound 1.4, now 1.15) and clip6 1.37 / 0.28, with
#: the same honesty.
BOUNDS = {
    "r25": (1.45, 0.97, 0.98, (0.4, 0.7)),
    "r40": (1.3, 0.99, 0.99, (0.35, 0.75)),
    "r50": (1.2, 0.99, 0.99, (0.35, 0.9)),
    "r100": (1.05, 0.99, 0.99, (0.55, 1.2)),
    "r1000": (0.95, 0.99, 0.99, (1.2, 2.0)),
    "jitter": (0.25, 0.955, 0.985, (0.8, 1.8)),
    "hold": (0.4, 0.99, 0.99, (0.12, 0.9)),
    "clip4": (1.15, 0.99, 0.99, (0.03, 0.2)),
    "clip6": (1.4, 0.99, 0.99, (0.02, 1.5)),
    "motion": (0.65, 0.99, 0.99, (0.2, 0.35)),
    "nT": (0.95, 0.99, 0.99, (1.0, 1.6)),
    "mag10": (0.9, 0.99, 0.99, (1.0, 1.6)),
    "mag30": (0.7, 0.99, 0.99, (1.0, 1.6)),
    "filled": (1.0, 0.99, 0.98, (0.06, 0.7)),
    "filled50": (1.05, 0.99, 0.99, (0.05, 0.45)),
    "all": (0.8, 0.99, 0.99, (0.1, 0.4)),
}


@pytest.fixture(scope="module")
def altered(tmp_path_factory):
    """Every excerpt under every alteration as a CSV trial, with VQF's scores on the same samples."""
    out = tmp_path_factory.mktemp("any_imu")
    vqf = {}
    for excerpt in EXCERPTS:
        path = DATA / f"{excerpt}.hdf5"
        assert path.exists(), f"{path} is missing: the committed excerpts (tests/data/broad/README.md) are required"
        trial = load_trial(path, None)
        for name, kwargs in ALTERATIONS.items():
            a = alter(trial, **kwargs)
            stem = f"{excerpt[:2]}_{name}"
            write_csv(a, out / f"{stem}.csv")
            vqf[stem] = broad_scores(run_vqf(a), None, a["opt_quat"], a["movement"], a["truth"])
    return out, vqf


@pytest.fixture(scope="module")
def ours(altered):
    """imu-study over every altered trial: {name: the study's result}."""
    folder, _ = altered
    run = subprocess.run(
        [str(LAB), "imu-study", str(folder), "--config", str(ROOT / "config" / "imu.json5"), "--json"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr
    return {r["trial"]: r for r in json.loads(run.stdout)}


def test_a_faster_rate_is_a_faster_sensor():
    """`alter` above the source's rate: the rotation of every source interval kept exactly, readings that change
    continuously (none repeated, none on a line through the two before, as a real sensor's never are) and each
    channel's noise density the source's."""
    from attitude_client.alter import quietest_noise, resample

    trial = load_trial(DATA / f"{EXCERPTS[0]}.hdf5", None)
    t = trial["t"]
    # Each source interval split in two: the two halves' mean is the source's reading, to rounding.
    times = np.sort(np.concatenate([t, 0.5 * (t[:-1] + t[1:])]))
    smooth = resample(trial, times, smooth=True)
    halves = 0.5 * (smooth["gyr"][1:-1:2] + smooth["gyr"][2::2])
    assert np.abs(halves - trial["gyr"][1:]).max() <= 1e-12 * max(1.0, np.abs(trial["gyr"]).max())
    # ... and they differ from each other where the rate changes (a held reading would repeat it).
    changing = np.abs(np.diff(trial["gyr"], axis=0)).max(axis=1) > 1e-3
    assert np.all(np.abs(smooth["gyr"][2::2] - smooth["gyr"][1:-1:2]).max(axis=1)[changing] > 0)

    fast = alter(trial, rate=1000.0)
    assert fast["rate_hz"] == pytest.approx(1000.0, rel=1e-3)
    for key in ("gyr", "acc", "mag"):
        x = fast[key]
        assert not np.any(np.all(x[1:] == x[:-1], axis=1)), key
        second = np.abs(np.diff(x, 2, axis=0)).max(axis=1)
        assert np.mean(second <= 1e-9 * np.abs(x[2:]).max(axis=1)) < 1e-3, key
    source, faster = quietest_noise(trial), quietest_noise(fast)
    for key in ("gyr", "acc", "mag"):
        ratio = faster[key] / source[key] / np.sqrt(1000.0 / trial["rate_hz"])
        assert np.all((ratio > 0.8) & (ratio < 1.25)), (key, ratio)


@pytest.mark.parametrize("alteration", sorted(ALTERATIONS))
def test_altered_excerpts_beside_vqf(altered, ours, alteration):
    _, vqf = altered
    factor, tilt_min, att_min, (nees_lo, nees_hi) = BOUNDS[alteration]
    for excerpt in EXCERPTS:
        name = f"{excerpt[:2]}_{alteration}"
        r, v = ours[name], vqf[name]
        assert not r["rejected"], (name, r["rejected"])
        assert r["total_rmse_deg"] <= factor * v["total_rmse_deg"], (name, r["total_rmse_deg"], v)
        assert r["tilt_in99"] >= tilt_min, (name, r)
        assert r["att_in99"] >= att_min, (name, r)
        assert nees_lo <= r["tilt_nees_median"] <= nees_hi, (name, r)


#: Excerpt 34 (an attached magnet, turned by hand) at the low rates, where the interval's models matter most: the
#: reading's lag and the coning term (`ahrs/mod.rs`, `sensors/gyro/channel.rs`). Measured, total / VQF: 0.35, 0.32,
#: 0.33 at 25, 40, 50 Hz; without them 0.54, 0.53, 0.48, and the tilt inside its 99% ellipse only 0.90, 0.93, 0.96 of
#: the time (median NEES 2.9, 2.7, 2.6). (The preset before 2026-11-30's retuning: 0.43, 0.31, 0.26; without them
#: 0.71, 0.53, 0.43.)
INTERVAL_MODEL_BOUNDS = {"r25": 0.45, "r40": 0.4, "r50": 0.35}


@pytest.mark.parametrize("alteration", sorted(INTERVAL_MODEL_BOUNDS))
def test_the_intervals_models_at_low_rates(altered, ours, alteration):
    _, vqf = altered
    name = f"34_{alteration}"
    assert ours[name]["total_rmse_deg"] <= INTERVAL_MODEL_BOUNDS[alteration] * vqf[name]["total_rmse_deg"], (
        name, ours[name], vqf[name])


#: The particle filter (`qpf:average`, the preset's 2000 particles, seeded by the study's vehicle id) at the low
#: rates, where weighing a tilt reading far sharper than the cloud used to widen the heading (BROAD 07 at 25 Hz:
#: 51° where the MEKF has 8°). Measured, excerpts 16 / 34, total / VQF: before the Gaussian tilt step (`filters/qpf`,
#: `gaussian_tilt`) r25 1.43 / 0.79, r40 1.36 / 0.60, r50 1.45 / 0.40; with it 1.21 / 0.71, 1.19 / 0.51,
#: 1.17 / 0.44; with the interval's models above (the lag and the coning term) 1.43 / 0.40, 1.32 / 0.32,
#: 1.26 / 0.32 (tilt inside 99% ≥ 0.978 both ways): excerpt 16 moves as the MEKF's does; with the preset of
#: 2026-11-30's retuning 1.42 / 0.35, 1.15 / 0.33, 1.32 / 0.34 (tilt inside 99% ≥ 0.977).
QPF_RATE_BOUND = 1.5


@pytest.fixture(scope="module")
def ours_qpf(altered):
    folder, _ = altered
    run = subprocess.run(
        [str(LAB), "imu-study", str(folder), "--config", str(ROOT / "config" / "imu.json5"), "--json",
         "--filter", "qpf:average"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr
    return {r["trial"]: r for r in json.loads(run.stdout)}


#: The particle filter with a clipped gyro (`qpf:average`, as above). What a saturated sample hides was spread over
#: every axis: the cloud's heading spread over the circle in excerpt 16's saturated swings and its average went
#: anywhere, 50.5° and 45.4° of total error (1.94× and 8.45× VQF's) at 4 and 6 rad/s where the MEKF had 36.0° and
#: 7.4°. About the saturated axes alone (`GyroChannel::saturation_variance`) it is 27.1° and 7.0° (1.04× and 1.30×);
#: excerpt 34 0.71× and 0.24×.
QPF_CLIP_BOUND = 1.45


#: The particle filter's bounds by alteration: total / VQF, and the tilt inside its 99% ellipse.
QPF_BOUNDS = {
    "r25": (QPF_RATE_BOUND, 0.96),
    "r40": (QPF_RATE_BOUND, 0.96),
    "r50": (QPF_RATE_BOUND, 0.96),
    "clip4": (QPF_CLIP_BOUND, 0.99),
    "clip6": (QPF_CLIP_BOUND, 0.99),
    # (Measured 0.61 / 0.26; with the saturation spread over every axis excerpt 16 was 2.72×.)
    "all": (0.75, 0.99),
}


@pytest.mark.parametrize("alteration", sorted(QPF_BOUNDS))
def test_the_particle_filter_beside_vqf(altered, ours_qpf, alteration):
    _, vqf = altered
    factor, tilt_min = QPF_BOUNDS[alteration]
    for excerpt in EXCERPTS:
        name = f"{excerpt[:2]}_{alteration}"
        r, v = ours_qpf[name], vqf[name]
        assert not r["rejected"], (name, r["rejected"])
        if alteration in ("clip4", "clip6", "all") and excerpt.startswith("16"):  # (its rate reaches 10 rad/s; 34's 5.2)
            assert r["imu"]["gyro_saturated"] > 0, (name, r["imu"])
        assert r["total_rmse_deg"] <= factor * v["total_rmse_deg"], (name, r["total_rmse_deg"], v)
        assert r["tilt_in99"] >= tilt_min, (name, r)


def test_an_altered_recording_through_the_service(altered, ours, tmp_path):
    """The 40 Hz alteration of excerpt 16 through the real service (attitude-replay of the CSV trial): every
    sample after the alignment estimated, nothing refused, and the MEKF's figures those of imu-study."""
    folder, _ = altered
    csv = folder / "16_r40.csv"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    log = open(tmp_path / "service.log", "wb")
    proc = subprocess.Popen(
        [str(BIN), "serve", "--config", str(ROOT / "config" / "imu.json5"), "--listen", endpoint],
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    try:
        out = subprocess.run(
            [sys.executable, "-m", "attitude_client.replay", str(csv), "--connect", endpoint, "--json",
             "--filters", "mekf", "--no-peers", "--tag", "anyimu", "--details", str(tmp_path / "details.json")],
            capture_output=True,
            text=True,
            timeout=300,
        )
    finally:
        proc.terminate()
        proc.wait(timeout=10)
        log.close()
    assert out.returncode == 0, out.stderr + (tmp_path / "service.log").read_text(errors="replace")[-3000:]
    result = json.loads(out.stdout.strip().splitlines()[-1])["mekf"]
    details = json.loads((tmp_path / "details.json").read_text())
    run = details["service"]["mekf"]
    assert not run["rejected"] and run["missing"] == 0, run
    study = ours["16_r40"]
    for key in ("total_rmse_deg", "inclination_rmse_deg", "tilt_in99", "att_in99"):
        assert result[key] == pytest.approx(study[key], rel=1e-9, abs=1e-12), (key, result, study)


def test_a_hard_iron_offset_from_the_first_sample_is_allowed_for(tmp_path):
    """A magnet fixed to the body from the start (excerpt 34; offsets of (30, −20, 15) and (10, −5, 8) µT against a
    field of about 48 µT): north is taken from the offset field, and the heading is wrong until rotation reveals the
    offset (103° and 31° on this excerpt, for 5 s of its motion), but the covariance says so: while the reference is
    unconfirmed the published heading allows for an offset of half the field's norm (docs/broad.md, 'A hard-iron
    offset present from the first sample'). Without that allowance: 3-axis inside 99% 0.015 and 0.093, heading
    0.010 and 0.072; measured with it: 0.995 and 1.000, heading 0.911 and 1.000."""
    trial = load_trial(DATA / f"{EXCERPTS[1]}.hdf5", None)
    for name, offset in (("large", (30.0, -20.0, 15.0)), ("small", (10.0, -5.0, 8.0))):
        write_csv(alter(trial, mag_offset=offset), tmp_path / f"34_hardiron_{name}.csv")
    run = subprocess.run(
        [str(LAB), "imu-study", str(tmp_path), "--config", str(ROOT / "config" / "imu.json5"), "--json"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    rows = json.loads(run.stdout)
    assert len(rows) == 2, rows
    for r in rows:
        assert not r["rejected"], r
        assert r["tilt_in99"] >= 0.99, r
        assert r["att_in99"] >= 0.95, r
        assert r["heading_in99"] >= 0.85, r
