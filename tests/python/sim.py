"""Simulated star-tracker-like measurements and quaternion helpers for the black-box tests.

Convention (contract v1): a wire quaternion ``{"w","x","y","z"}`` is the orientation of the body in the
reference frame (Hamilton); a body measurement of a reference vector ``r`` is ``b = R(q).T @ r`` with
``R`` the Hamilton rotation matrix. scipy's ``Rotation`` composes like Hamilton products
(``(a * b).as_quat()`` is ``q_a ⊗ q_b``) and stores quaternions scalar last.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

# Gyro noise of the service's default configuration (config/default.json5).
GYRO_ARW = 3.1622776601683794e-7  # rad/s^(1/2)
DEG_PER_HR = np.pi / 180.0 / 3600.0


def to_rotation(q: dict) -> Rotation:
    return Rotation.from_quat([q["x"], q["y"], q["z"], q["w"]])


def to_wire(r: Rotation) -> dict:
    x, y, z, w = r.as_quat()
    if w < 0:
        w, x, y, z = -w, -x, -y, -z
    return {"w": float(w), "x": float(x), "y": float(y), "z": float(z)}


def axis_errors_rad(q_true: Rotation, q_est: dict) -> np.ndarray:
    """Per-body-axis attitude error ``2·vec(δq)``, ``δq = q_true ⊗_Shuster q̂⁻¹`` = Hamilton ``q̂⁻¹ · q_true``."""
    dq = (to_rotation(q_est).inv() * q_true).as_quat()  # x, y, z, w
    if dq[3] < 0:
        dq = -dq
    return 2.0 * dq[:3]


def attitude_nees(q_true: Rotation, estimate: dict) -> float:
    """``δαᵀ P_att⁻¹ δα`` of a wire estimate against the truth: δα its body-frame error (``axis_errors_rad``),
    P_att the attitude block of its ``cov``. χ²(3) for a consistent filter."""
    err = axis_errors_rad(q_true, estimate["q"])
    return float(err @ np.linalg.solve(np.array(estimate["cov"])[:3, :3], err))


def angle_error_deg(q_true: Rotation, q_est: dict) -> float:
    dq = (to_rotation(q_est).inv() * q_true).as_quat()
    return float(np.degrees(2.0 * np.arccos(min(1.0, abs(dq[3])))))


def quat_distance(a: dict, b: dict) -> float:
    """``min(|a - b|, |a + b|)`` over the four components (0 for the same rotation)."""
    va = np.array([a["w"], a["x"], a["y"], a["z"]])
    vb = np.array([b["w"], b["x"], b["y"], b["z"]])
    return float(min(np.linalg.norm(va - vb), np.linalg.norm(va + vb)))


@dataclass
class Chunk:
    """What one publisher sends in one go, in time order: gyro samples, then one vector set."""

    gyro: list  # [(t, omega)]
    t: float  # time of the vector set
    obs: list  # [(body, ref, sigma, sensor)]


@dataclass
class Scenario:
    """Constant-rate truth ``q(t) = q0 ⊗ exp(ω t / 2)``, a constant gyro bias, gyro at ``gyro_hz``, a set of
    ``len(refs)`` unit-vector observations with per-axis noise ``sigma`` every ``1/vec_hz`` s."""

    seed: int
    duration_s: float = 60.0
    gyro_hz: float = 10.0
    vec_hz: float = 1.0
    sigma: float = 1e-4
    rate_rad_s: np.ndarray = field(default_factory=lambda: np.array([0.01, -0.02, 0.015]))
    bias_max_deg_hr: float = 1.0
    sensor: str = "st1"

    def __post_init__(self):
        self.rng = np.random.default_rng(self.seed)
        self.q0 = Rotation.random(random_state=self.rng)
        self.bias = self.rng.uniform(-1, 1, 3) * self.bias_max_deg_hr * DEG_PER_HR
        self.refs = self._star_directions(3)

    def _star_directions(self, n: int) -> np.ndarray:
        """``n`` random unit vectors at least 30° apart (good geometry: every axis observable)."""
        while True:
            v = self.rng.normal(size=(n, 3))
            v /= np.linalg.norm(v, axis=1, keepdims=True)
            cos = np.abs(v @ v.T)[np.triu_indices(n, 1)]
            if np.all(cos < np.cos(np.radians(30))):
                return v

    def truth(self, t: float) -> Rotation:
        return self.q0 * Rotation.from_rotvec(self.rate_rad_s * t)

    def gyro(self, t: float) -> np.ndarray:
        dt = 1.0 / self.gyro_hz
        return self.rate_rad_s + self.bias + self.rng.normal(0.0, GYRO_ARW / np.sqrt(dt), 3)

    def vectors(self, t: float) -> list:
        r_true = self.truth(t)
        obs = []
        for ref in self.refs:
            b = r_true.inv().apply(ref) + self.rng.normal(0.0, self.sigma, 3)
            obs.append((b / np.linalg.norm(b), ref, self.sigma, self.sensor))
        return obs

    def chunks(self) -> list[Chunk]:
        """A vector set at t = 0, 1/vec_hz, ..., duration; before each, the gyro samples since the last set
        (times ≤ the set's time). Everything is in time order."""
        n_gyro = int(round(self.duration_s * self.gyro_hz))
        gyro_times = [i / self.gyro_hz for i in range(n_gyro + 1)]
        n_sets = int(round(self.duration_s * self.vec_hz))
        out = []
        g = 0
        for k in range(n_sets + 1):
            t = k / self.vec_hz
            batch = []
            while g < len(gyro_times) and gyro_times[g] <= t + 1e-12:
                batch.append((gyro_times[g], self.gyro(gyro_times[g])))
                g += 1
            out.append(Chunk(gyro=batch, t=t, obs=self.vectors(t)))
        return out
