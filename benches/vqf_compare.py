#!/usr/bin/env python3
"""Side-by-side run of a peer on the same data: the `vqf` package against our MEKF on one BROAD trial.

    .venv/bin/python benches/vqf_compare.py /work/shared/data/broad/07_undisturbed_fast_rotation_B.hdf5 \
        [--json] [--bin target/release/attitude-lab] [--repeat 3] [--no-python-loop] \
        [--bench [--particles N] [--seconds S]]

The binary never runs this script: it is the script that runs the lab binary (`imu-bench`, and `bench` with
`--bench`) and VQF (the `vqf` package of the project's .venv, created by scripts/python-tests.sh).

What it does:

1. Reads the trial (`imu_gyr` rad/s, `imu_acc` m/s², `imu_mag` µT, `opt_quat` [w,x,y,z] body→ENU, `movement`,
   attribute `sampling_rate`) and writes the trial file of `attitude-lab imu-bench` (the format of
   `scripts/broad-export.py`: little-endian f64, `[n, rate_hz, 15]`, then per sample
   `[t, gyr(3), acc(3), mag(3), opt_quat(4), movement]`).
2. Runs VQF (Laidig & Seel 2023, PyPI `vqf`) three ways and times each (wall clock, best of `--repeat`;
   the `updateBatch` runs alternate with the MEKF runs so that both see the same machine load):
   * `VQF(Ts).updateBatch(gyr, acc, mag)`: the C++ filter looping over the samples in compiled code. **This is
     the figure the ratio uses**: it is the like-for-like counterpart of our compiled per-sample Rust loop.
   * `VQF(Ts).update(gyr[i], acc[i], mag[i])` + `getQuat9D()` in a Python loop: for information only; it mostly
     measures the Python/Cython call overhead per sample.
   * `offlineVQF(gyr, acc, mag, Ts)`: the acausal offline variant, for information (it may use future samples,
     so its accuracy is not comparable to a causal filter's).
3. Runs `attitude-lab imu-bench --trial FILE --config config/imu.json5 [--estimates-out FILE]` (`--repeat`
   times, best of) and reads its JSON line (`samples_per_s`: the trial through one vehicle of the service's
   pipeline with the MEKF, in one process, no network, file I/O excluded; process start-up is not counted for
   either side). ratio = MEKF samples/s ÷ VQF `updateBatch` samples/s.
4. With `--bench`, first runs `attitude-lab bench [--json] --particles N --seconds S` (each filter's step
   cost against the MEKF) and prints its table before the comparison's; with `--json`, prints one object:
   `bench --json`'s with the comparison's object under `"vqf"`.
5. Scores both with the BROAD metric (`example_code/broad_utils.py`): `e = q_est ⊗ q_opt⁻¹` (Hamilton, earth-frame
   error), total `2·acos(|e_w|)`, heading `2·atan(|e_z/e_w|)`, inclination `2·acos(√(e_w² + e_z²))`, RMSE in
   degrees over `movement` (NaN reference rows ignored, as `nanmean` does there).
   Heading alignment: VQF's 9D quaternion is in its own earth frame (heading from the magnetometer), ours in ENU
   aligned with the magnetic north seen at rest; neither frame is exactly the optical one. For both estimators
   the mean heading offset (circular mean of the z-twist of `e`) over the second half of the opening rest
   period (before the first `movement` sample, never over scored samples) is removed before scoring. The
   unaligned (official) figures are reported too.

Data: BROAD, D. Laidig, M. Caruso, A. Cereatti, T. Seel, "BROAD — A Benchmark for Robust Inertial Orientation
Estimation", Data 6(7), 2021, doi:10.3390/data6070072, licensed CC-BY-4.0. Keep this attribution wherever the
results are shown.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from importlib import metadata
from pathlib import Path

import numpy as np
from vqf import VQF, offlineVQF

from attitude_client.replay import broad_rmse as broad_metric, invquat, quatmult  # noqa: E402
from attitude_client.replay import load_trial as read_trial  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
ATTRIBUTION = (
    "Data: BROAD (Laidig, Caruso, Cereatti, Seel, 'BROAD - A Benchmark for Robust Inertial Orientation "
    "Estimation', Data 6(7), 2021, doi:10.3390/data6070072), CC-BY-4.0."
)


# ----------------------------------------------------------------------------------------------------------
# Quaternions, Hamilton [w, x, y, z]


def normalize(q: np.ndarray) -> np.ndarray:
    return q / np.linalg.norm(q, axis=1)[:, None]


def error_quat_earth(q_est: np.ndarray, q_opt: np.ndarray) -> np.ndarray:
    """e = q_est ⊗ q_opt⁻¹: the estimation error expressed in the earth frame (BROAD's calculateErrorQuatEarth)."""
    return normalize(quatmult(normalize(q_est), invquat(normalize(q_opt))))


def heading_offset_rad(q_est: np.ndarray, q_opt: np.ndarray, rows: np.ndarray) -> float:
    """Circular mean of the heading (z-twist) of the earth-frame error over `rows` (NaN rows skipped)."""
    e = error_quat_earth(q_est[rows], q_opt[rows])
    psi = 2.0 * np.arctan2(e[:, 3], e[:, 0])
    ok = np.isfinite(psi)
    if not ok.any():
        return 0.0
    return float(np.arctan2(np.mean(np.sin(psi[ok])), np.mean(np.cos(psi[ok]))))


def rotate_heading(q_est: np.ndarray, angle_rad: float) -> np.ndarray:
    """R_z(angle) ⊗ q_est: rotates the estimate's earth frame about the vertical."""
    rz = np.array([np.cos(angle_rad / 2), 0.0, 0.0, np.sin(angle_rad / 2)])
    return quatmult(rz, q_est)


def broad_rmse(q_est: np.ndarray, q_opt: np.ndarray, movement: np.ndarray) -> dict:
    """Total/heading/inclination RMSE in degrees over `movement` (the BROAD metric, one implementation:
    attitude_client.replay, clients/python)."""
    m = broad_metric(q_est, q_opt, movement)
    return {"total": m["total_rmse_deg"], "heading": m["heading_rmse_deg"], "inclination": m["inclination_rmse_deg"]}


def score(q_est: np.ndarray, trial: dict) -> dict:
    """BROAD errors, unaligned and after removing the rest-period heading offset."""
    offset = heading_offset_rad(q_est, trial["opt_quat"], trial["align_rows"])
    return {
        "heading_offset_deg": float(np.rad2deg(offset)),
        "aligned": broad_rmse(rotate_heading(q_est, -offset), trial["opt_quat"], trial["movement"]),
        "unaligned": broad_rmse(q_est, trial["opt_quat"], trial["movement"]),
    }


# ----------------------------------------------------------------------------------------------------------
# Data


def load_trial(path: Path) -> dict:
    """The trial as attitude-replay reads it (one reader), which must have its truth and movement phases."""
    trial = read_trial(path, None)
    if trial["opt_quat"] is None or trial["movement"] is None:
        raise SystemExit(f"{path}: opt_quat and movement are needed to score")
    n = len(trial["gyr"])
    for key in ("acc", "mag", "opt_quat", "movement"):
        if len(trial[key]) != n:
            raise SystemExit(f"{path}: {key} has {len(trial[key])} rows, imu_gyr {n}")
    if not trial["movement"].any():
        raise SystemExit(f"{path}: no movement samples to score")
    first_move = int(np.argmax(trial["movement"]))
    rows = np.zeros(n, dtype=bool)
    rows[first_move // 2 : first_move] = True
    rows &= np.isfinite(trial["opt_quat"]).all(axis=1)
    if not rows.any():
        raise SystemExit(f"{path}: no valid reference samples in the opening rest period")
    trial["align_rows"] = rows
    return trial


def write_samples(path: Path, trial: dict) -> None:
    """The trial file of `imu-bench` (the format of scripts/broad-export.py)."""
    n = len(trial["gyr"])
    t = np.asarray(trial["t"], dtype=np.float64)
    body = np.column_stack(
        [t, trial["gyr"], trial["acc"], trial["mag"], trial["opt_quat"], trial["movement"].astype(np.float64)]
    ).astype("<f8")
    header = np.array([n, trial["rate_hz"], 15], dtype="<f8")
    with open(path, "wb") as f:
        f.write(header.tobytes())
        f.write(np.ascontiguousarray(body).tobytes())


def read_estimates(path: Path, n: int) -> np.ndarray:
    values = np.fromfile(path, dtype="<f8")
    if len(values) < 1 or int(values[0]) != n or len(values) != 1 + 4 * n:
        raise SystemExit(f"{path}: expected {n} estimates, got header {values[:1]} and {len(values)} values")
    return values[1:].reshape(n, 4)


# ----------------------------------------------------------------------------------------------------------
# The two estimators


def best_of(repeat: int, fn):
    """Runs fn() `repeat` times; returns (best wall-clock seconds, result of the first run)."""
    best, first = float("inf"), None
    for i in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        dt = time.perf_counter() - t0
        best = min(best, dt)
        if i == 0:
            first = out
    return best, first


def vqf_batch_once(trial: dict) -> tuple[float, np.ndarray]:
    """One timed run of VQF's C++ per-sample loop (`updateBatch`): (seconds, quat9D)."""
    ts = 1.0 / trial["rate_hz"]
    t0 = time.perf_counter()
    out = VQF(ts).updateBatch(trial["gyr"], trial["acc"], trial["mag"])
    return time.perf_counter() - t0, out["quat9D"]


def run_vqf_others(trial: dict, repeat: int, online_loop: bool, batch_quat: np.ndarray) -> dict:
    """The variants reported for information: offlineVQF and the per-sample Python loop."""
    gyr, acc, mag = trial["gyr"], trial["acc"], trial["mag"]
    n, ts = len(gyr), 1.0 / trial["rate_hz"]
    out = {}

    offline_s, offline = best_of(repeat, lambda: offlineVQF(gyr, acc, mag, ts))
    out["offline"] = {"seconds": offline_s, "samples_per_s": n / offline_s, "quat": offline["quat9D"]}

    if online_loop:

        def loop():
            v = VQF(ts)
            q = np.empty((n, 4))
            for i in range(n):
                v.update(gyr[i], acc[i], mag[i])
                q[i] = v.getQuat9D()
            return q

        loop_s, q = best_of(1, loop)
        out["python_loop"] = {"seconds": loop_s, "samples_per_s": n / loop_s, "quat": q}
        # The per-sample loop and the batch call are the same causal filter: same estimates.
        out["python_loop"]["max_diff_vs_batch"] = float(
            np.max(np.abs(np.abs(np.sum(q * batch_quat, axis=1)) - 1.0))
        )
    return out


def mekf_once(bin_path: Path, samples: Path, estimates: Path | None, n: int) -> dict:
    """One run of `attitude-lab imu-bench`; its JSON line (the timing is the binary's own)."""
    cmd = [str(bin_path), "imu-bench", "--trial", str(samples), "--config", str(ROOT / "config" / "imu.json5")]
    if estimates is not None:
        cmd += ["--estimates-out", str(estimates)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr}{proc.stdout}")
    lines = [line for line in proc.stdout.splitlines() if line.lstrip().startswith("{")]
    if not lines:
        raise SystemExit(f"{' '.join(cmd)} printed no JSON line:\n{proc.stdout}")
    run = json.loads(lines[-1])
    if run["samples"] != n:
        raise SystemExit(f"imu-bench ran {run['samples']} samples, the trial has {n}")
    return run


def run_bench(bin_path: Path, particles: int, seconds: float, as_json: bool) -> str | dict:
    """`attitude-lab bench`: its table (text), or its JSON object with `as_json`."""
    cmd = [str(bin_path), "bench", "--particles", str(particles), "--seconds", str(seconds)]
    if as_json:
        cmd.append("--json")
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr}{proc.stdout}")
    if not as_json:
        return proc.stdout
    lines = [line for line in proc.stdout.splitlines() if line.lstrip().startswith("{")]
    if not lines:
        raise SystemExit(f"{' '.join(cmd)} printed no JSON line:\n{proc.stdout}")
    return json.loads(lines[-1])


def timed_pair(trial: dict, bin_path: Path, samples: Path, estimates: Path, repeat: int) -> tuple[dict, dict]:
    """VQF updateBatch and the MEKF, alternated `repeat` times so that both see the same machine load;
    the best run of each counts. Returns (vqf_batch, mekf)."""
    n = len(trial["gyr"])
    vqf_s, mekf_runs, vqf_quat = [], [], None
    for i in range(repeat):
        seconds, quat = vqf_batch_once(trial)
        vqf_s.append(seconds)
        vqf_quat = quat if vqf_quat is None else vqf_quat
        mekf_runs.append(mekf_once(bin_path, samples, estimates if i == 0 else None, n))
    best_vqf = min(vqf_s)
    best_mekf = max(mekf_runs, key=lambda r: r["samples_per_s"])
    vqf = {"seconds": best_vqf, "samples_per_s": n / best_vqf, "quat": vqf_quat,
           "all_samples_per_s": [n / s for s in vqf_s]}
    mekf = {
        "seconds": best_mekf["seconds"],
        "samples_per_s": best_mekf["samples_per_s"],
        "rejected": best_mekf.get("rejected"),
        "quat": read_estimates(estimates, n),
        "all_samples_per_s": [r["samples_per_s"] for r in mekf_runs],
    }
    return vqf, mekf


# ----------------------------------------------------------------------------------------------------------


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("trial", type=Path, help="a BROAD trial (.hdf5)")
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    ap.add_argument(
        "--bin",
        type=Path,
        default=Path(os.environ.get("ATTITUDE_LAB_BIN", ROOT / "target/release/attitude-lab")),
        help="the attitude-lab binary (default: $ATTITUDE_LAB_BIN or target/release/attitude-lab)",
    )
    ap.add_argument("--repeat", type=int, default=3, help="timed runs of each estimator; the best counts")
    ap.add_argument("--no-python-loop", action="store_true", help="skip VQF's slow per-sample Python loop")
    ap.add_argument("--workdir", type=Path, help="keep the samples and estimates files here")
    ap.add_argument(
        "--bench",
        action="store_true",
        help="also run `attitude-lab bench` (each filter's step cost against the MEKF) and print it first; "
        'with --json, one object: bench\'s, with this comparison under "vqf"',
    )
    ap.add_argument("--particles", type=int, default=1000, help="with --bench: particles of the particle filter")
    ap.add_argument("--seconds", type=float, default=1.0, help="with --bench: measuring time per filter, s")
    args = ap.parse_args()
    if args.repeat < 1:
        ap.error("--repeat must be at least 1")
    if args.bench and (args.particles < 2 or not args.seconds > 0):
        ap.error("--particles must be at least 2 and --seconds positive")

    bench = run_bench(args.bin, args.particles, args.seconds, args.json) if args.bench else None

    trial = load_trial(args.trial)
    n = len(trial["gyr"])

    with tempfile.TemporaryDirectory(prefix="vqf_compare_") as tmp:
        work = args.workdir or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        samples = work / f"{trial['name']}.trial"
        estimates = work / f"{trial['name']}.mekf.bin"
        write_samples(samples, trial)
        batch, mekf = timed_pair(trial, args.bin, samples, estimates, args.repeat)
        vqf = run_vqf_others(trial, args.repeat, not args.no_python_loop, batch["quat"])
        vqf["batch"] = batch

    scores = {"mekf": score(mekf["quat"], trial), "vqf": score(vqf["batch"]["quat"], trial)}
    scores["vqf_offline"] = score(vqf["offline"]["quat"], trial)
    ratio = mekf["samples_per_s"] / vqf["batch"]["samples_per_s"]

    result = {
        "trial": trial["name"],
        "samples": n,
        "rate_hz": trial["rate_hz"],
        "vqf_samples_per_s": vqf["batch"]["samples_per_s"],
        "mekf_samples_per_s": mekf["samples_per_s"],
        "ratio": ratio,
        "ratio_basis": "mekf imu-bench (Rust loop, one process) / vqf VQF.updateBatch (C++ loop)",
        "vqf_total_rmse_deg": scores["vqf"]["aligned"]["total"],
        "mekf_total_rmse_deg": scores["mekf"]["aligned"]["total"],
        "vqf_python_loop_samples_per_s": vqf.get("python_loop", {}).get("samples_per_s"),
        "vqf_offline_samples_per_s": vqf["offline"]["samples_per_s"],
        "mekf_rejected_measurements": mekf["rejected"],
        "runs_samples_per_s": {"vqf_batch": batch["all_samples_per_s"], "mekf": mekf["all_samples_per_s"]},
        "errors_deg": scores,
        "heading_alignment": "mean heading offset over the second half of the opening rest period removed",
        "repeat": args.repeat,
        "versions": {
            "vqf": metadata.version("vqf"),
            "h5py": metadata.version("h5py"),
            "numpy": metadata.version("numpy"),
            "python": sys.version.split()[0],
        },
        "attribution": ATTRIBUTION,
    }
    if "python_loop" in vqf:
        result["vqf_python_loop_max_diff_vs_batch"] = vqf["python_loop"]["max_diff_vs_batch"]

    if args.json:
        if bench is not None:
            bench["vqf"] = result
            result = bench
        print(json.dumps(result))
        return 0

    if bench is not None:
        print(bench, end="")
        print(f"\nMEKF vs VQF on {args.trial}:")
    print(f"{trial['name']}: {n} samples at {trial['rate_hz']:.3f} Hz, best of {args.repeat} runs\n")
    print(f"{'estimator':<34} {'samples/s':>12} {'total°':>8} {'heading°':>9} {'incl.°':>8} {'hdg off°':>9}")
    rows = [
        ("MEKF (attitude-lab imu-bench)", mekf["samples_per_s"], scores["mekf"]),
        ("VQF updateBatch (C++ loop)", vqf["batch"]["samples_per_s"], scores["vqf"]),
    ]
    if "python_loop" in vqf:
        rows.append(("VQF update() in a Python loop", vqf["python_loop"]["samples_per_s"], None))
    rows.append(("offlineVQF (acausal)", vqf["offline"]["samples_per_s"], scores["vqf_offline"]))
    for label, sps, sc in rows:
        if sc is None:
            print(f"{label:<34} {sps:>12.0f} {'(= batch)':>8}")
            continue
        a = sc["aligned"]
        print(
            f"{label:<34} {sps:>12.0f} {a['total']:>8.2f} {a['heading']:>9.2f} "
            f"{a['inclination']:>8.2f} {sc['heading_offset_deg']:>9.2f}"
        )
    print(f"\nratio MEKF / VQF updateBatch = {ratio:.2f} (target ≥ 2)")
    print(
        "errors: BROAD RMSE over `movement`, after removing each estimator's mean heading offset over the "
        "opening rest period;\nunaligned (official) totals: "
        + ", ".join(f"{k} {v['unaligned']['total']:.2f}°" for k, v in scores.items())
    )
    if mekf["rejected"]:
        print(f"MEKF refused {mekf['rejected']} measurements")
    print(ATTRIBUTION)
    return 0


if __name__ == "__main__":
    sys.exit(main())
