"""The arithmetic of ``attitude-view`` (numpy only; the tests hold it against SciPy): quaternions ``[w, x, y, z]``
(body in reference), the attitude error against the truth in the service's convention, 3-2-1 Euler angles, and
vectors and quaternions as the JSON objects of the view's messages. Imports nothing of the view."""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import numpy as np

__all__ = ["error_deg", "euler_zyx_deg"]


def _wxyz(q: Any) -> np.ndarray:
    if isinstance(q, Mapping):
        return np.array([q["w"], q["x"], q["y"], q["z"]], dtype=float)
    return np.asarray(q, dtype=float)


def _hamilton(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a · b`` of ``[w, x, y, z]`` quaternions."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ]
    )


def error_deg(q_est: Any, q_true: Any) -> tuple[np.ndarray, float]:
    """The attitude error of an estimate against the truth, the service's convention (``proto/README.md``):
    ``δq = q_true ⊗ q̂⁻¹`` (Shuster), i.e. the Hamilton ``q̂⁻¹ · q_true`` with ``w ≥ 0``, and ``δα = 2·vec(δq)``
    about the body axes. Returns ``(δα in deg (3,), the error angle in deg)``."""
    qe = _wxyz(q_est)
    qt = _wxyz(q_true)
    dq = _hamilton(qe * np.array([1.0, -1.0, -1.0, -1.0]), qt)
    dq /= np.linalg.norm(dq)
    if dq[0] < 0:
        dq = -dq
    angle = 2.0 * math.atan2(float(np.linalg.norm(dq[1:])), float(dq[0]))
    return np.degrees(2.0 * dq[1:]), math.degrees(angle)


def euler_zyx_deg(q: Any) -> tuple[float, float, float]:
    """Roll, pitch and yaw (deg) of the body in the reference frame, the 3-2-1 sequence: ``R(q) = Rz(yaw) Ry(pitch)
    Rx(roll)`` (SciPy's ``Rotation.as_euler("ZYX")`` reversed)."""
    w, x, y, z = _wxyz(q) / np.linalg.norm(_wxyz(q))
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return math.degrees(roll), math.degrees(pitch), math.degrees(yaw)


def _xyz(v: Sequence[float]) -> dict[str, float]:
    return {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}


def _quat(q: np.ndarray) -> dict[str, float]:
    return {"w": float(q[0]), "x": float(q[1]), "y": float(q[2]), "z": float(q[3])}
