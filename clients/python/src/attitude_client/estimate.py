"""An estimate of the attitude service as numpy arrays (``P/V/estimate``, ``P/V/state``).

Conventions, the service's own (``proto/README.md``):

* ``q`` is ``[w, x, y, z]`` (scalar first, Hamilton): the orientation of the body in the reference frame.
  It rotates body coordinates into reference coordinates, ``r = R(q) b``; the attitude matrix of the
  spacecraft literature is its transpose, ``b = A(q) r`` with ``A = Rᵀ``. The service normalises ``w ≥ 0``.
* ``cov`` is 6×6 over ``[δα (rad, body axes); δβ (rad/s)]``, with the attitude error
  ``δq = q_true ⊗ q̂⁻¹`` expressed in the body frame, ``δα ≈ 2 vec(δq)``, and ``δβ = β_true − β̂``.
* ``rotation()`` is SciPy's ``Rotation`` of ``R(q)`` (body → reference): ``e.rotation().apply(b)`` gives
  reference coordinates; ``e.rotation().inv().apply(r)`` body coordinates. SciPy stores quaternions scalar
  last, ``[x, y, z, w]``; :attr:`Estimate.q_xyzw` gives that order.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

if TYPE_CHECKING:  # SciPy is an optional extra: ``pip install attitude-client[scipy]``
    from scipy.spatial.transform import Rotation

__all__ = ["Estimate", "attitude_matrix"]


def attitude_matrix(q: np.ndarray) -> np.ndarray:
    """``A(q)`` for ``q = [w, x, y, z]``: reference → body coordinates, ``b = A r`` (the transpose of ``R(q)``)."""
    w, x, y, z = (float(c) for c in q)
    return np.array(
        [
            [w * w + x * x - y * y - z * z, 2 * (x * y + w * z), 2 * (x * z - w * y)],
            [2 * (x * y - w * z), w * w - x * x + y * y - z * z, 2 * (y * z + w * x)],
            [2 * (x * z + w * y), 2 * (y * z - w * x), w * w - x * x - y * y + z * z],
        ]
    )


def _array(value: Any, shape: tuple[int, ...], what: str) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.shape != shape:
        raise ValueError(f"{what} must have shape {shape}, got {a.shape}")
    return a


@dataclass(frozen=True)
class Estimate:
    """One estimate of one vehicle, as numpy arrays (see the module's conventions).

    ``cov`` and ``bias`` are ``None`` in the reply of an ``attitude`` query, which carries neither.
    ``diagnostics`` is the estimate's ``diagnostics`` object as parsed JSON (what the filter knows about
    itself: effective sample size, gate and rejection counts, the IMU pipeline's state, …)."""

    vehicle: str
    t: float
    q: np.ndarray
    sigma_deg: np.ndarray
    cov: np.ndarray | None = None
    bias: np.ndarray | None = None
    filter: str | None = None
    fiducial: str | None = None
    seq: int | None = None
    diagnostics: Mapping[str, Any] = field(default_factory=dict)

    @classmethod
    def from_json(cls, msg: Mapping[str, Any]) -> "Estimate":
        """From the service's JSON (an estimate, a ``state`` reply, an ``attitude`` or ``covariance`` reply)."""
        q = msg["q"]
        cov = msg.get("cov")
        bias = msg.get("bias")
        return cls(
            vehicle=str(msg["vehicle"]),
            t=float(msg["t"]),
            q=np.array([q["w"], q["x"], q["y"], q["z"]], dtype=float),
            sigma_deg=_array(msg["sigma_deg"], (3,), "sigma_deg"),
            cov=None if cov is None else _array(cov, (6, 6), "cov"),
            bias=None if bias is None else _array(bias, (3,), "bias"),
            filter=msg.get("filter"),
            fiducial=msg.get("fiducial"),
            seq=msg.get("seq"),
            diagnostics=msg.get("diagnostics") or {},
        )

    @property
    def q_xyzw(self) -> np.ndarray:
        """``q`` scalar last, ``[x, y, z, w]`` (SciPy's and ROS's order)."""
        return np.roll(self.q, -1)

    @property
    def ess(self) -> float | None:
        """The effective sample size of a particle filter (``None`` for the Kalman filters)."""
        value = self.diagnostics.get("ess")
        return None if value is None else float(value)

    def attitude_matrix(self) -> np.ndarray:
        """``A(q)``: reference → body coordinates (``b = A r``)."""
        return attitude_matrix(self.q)

    def rotation(self) -> "Rotation":
        """The orientation as ``scipy.spatial.transform.Rotation`` (body → reference; needs SciPy)."""
        try:
            from scipy.spatial.transform import Rotation
        except ImportError as e:  # pragma: no cover - depends on the installation
            raise ImportError("Estimate.rotation() needs SciPy: pip install 'attitude-client[scipy]'") from e
        return Rotation.from_quat(self.q_xyzw)
