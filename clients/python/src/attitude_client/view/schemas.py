"""What ``attitude-view`` publishes: the topics (fixed, and ``/V/<leaf>`` per vehicle), the contract's rejection
codes, and the JSON Schemas of the JSON topics (:func:`schemas`; each ``title`` is the schema name Foxglove shows,
and the Rerun sink flattens the same messages). Imports nothing of the view."""

from __future__ import annotations

from typing import Any, Iterable

__all__ = [
    "REJECTION_CODES", "SCENE_TOPIC", "SUMMARY_TOPIC", "TF_TOPIC", "VEHICLE_LEAVES", "WORLD", "schemas",
    "vehicle_topics",
]

#: The rejection codes of the contract (``proto/README.md``, ``proto/schemas/error.schema.json``; a test keeps the
#: two equal). ``/V/rejections`` counts each of them (zero included) so that a plot has every series from the start.
REJECTION_CODES = (
    "invalid_utf8",
    "invalid_json",
    "bad_request",
    "non_finite",
    "zero_vector",
    "bad_sigma",
    "payload_too_large",
    "batch_too_large",
    "invalid_vehicle_id",
    "unknown_vehicle",
    "not_initialized",
    "too_many_vehicles",
    "out_of_order",
    "duplicate",
    "time_jump",
    "out_of_range",
    "queue_full",
    "mixed_inputs",
    "filter_error",
    "wrong_route",
    "samples_missed",
    "gap",
    "internal",
)

#: Fixed topics (every vehicle's frames and scene, the table).
TF_TOPIC = "/tf"
SCENE_TOPIC = "/scene"
SUMMARY_TOPIC = "/summary"
WORLD = "world"

#: Per-vehicle topics: ``/V/<leaf>``.
VEHICLE_LEAVES = ("attitude", "error", "diagnostics", "rejections")
def vehicle_topics(vehicle: str) -> dict[str, str]:
    """``{leaf: "/V/leaf"}`` for the per-vehicle topics."""
    return {leaf: f"/{vehicle}/{leaf}" for leaf in VEHICLE_LEAVES}

# ----------------------------------------------------------------------------------------------------------------
# The JSON Schemas of the custom topics (their ``title`` is the schema name Foxglove shows)


def _obj(title: str | None, properties: dict[str, Any], required: Iterable[str], description: str = "") -> dict:
    schema: dict[str, Any] = {"type": "object"}
    if title:
        schema["title"] = title
    if description:
        schema["description"] = description
    schema["properties"] = properties
    schema["required"] = list(required)
    return schema


_NUM = {"type": "number"}
_INT = {"type": "integer"}
_STR = {"type": "string"}
_BOOL = {"type": "boolean"}


def _vec(description: str) -> dict:
    return _obj(None, {"x": _NUM, "y": _NUM, "z": _NUM}, ("x", "y", "z"), description)


_QUAT = _obj(None, {"w": _NUM, "x": _NUM, "y": _NUM, "z": _NUM}, ("w", "x", "y", "z"), "[w, x, y, z]: body in reference")
_COMMON = {
    "vehicle": {**_STR, "description": "the vehicle id"},
    "t": {**_NUM, "description": "the estimate's time, s, on the vehicle's clock"},
    "seq": {**_INT, "description": "the estimate's seq (estimates published for the vehicle so far)"},
}


def schemas() -> dict[str, dict]:
    """``{leaf or fixed topic: JSON Schema}`` of the JSON topics: ``attitude``, ``error``, ``diagnostics``,
    ``rejections`` (per vehicle) and ``/summary``."""
    codes = {code: _INT for code in REJECTION_CODES}
    return {
        "attitude": _obj(
            "attitude_view.Attitude",
            {
                **_COMMON,
                "filter": {**_STR, "description": "mekf, usque or qpf, with the fiducial: qpf:average"},
                "q": _QUAT,
                "euler_deg": _obj(
                    None, {"roll": _NUM, "pitch": _NUM, "yaw": _NUM}, ("roll", "pitch", "yaw"),
                    "3-2-1 Euler angles of the body in the reference frame, deg",
                ),
                "sigma_deg": _vec("attitude 1σ per body axis, deg"),
                "three_sigma_deg": _vec("3σ per body axis, deg"),
                "bias_deg_h": _vec("estimated gyro bias, deg/h, body axes"),
                "rate_hz": {**_NUM, "description": "estimates per second of wall time (the last 10 s)"},
                "received": {**_INT, "description": "estimates of this vehicle the view received"},
            },
            ("vehicle", "t", "seq", "filter", "q", "euler_deg", "sigma_deg", "three_sigma_deg", "bias_deg_h",
             "rate_hz", "received"),
            "a vehicle's estimate (P/V/estimate)",
        ),
        "error": _obj(
            "attitude_view.Error",
            {
                **_COMMON,
                "error_deg": _vec("δα = 2·vec(q̂⁻¹ ⊗ q_true) per body axis, deg"),
                "plus_3sigma_deg": _vec("+3σ per body axis, deg"),
                "minus_3sigma_deg": _vec("−3σ per body axis, deg"),
                "angle_deg": {**_NUM, "description": "the error angle, deg"},
                "within_3sigma": {**_BOOL, "description": "every axis's error inside its ±3σ"},
                "nees": {**_NUM, "description": "δαᵀ P⁻¹ δα with P the attitude block of cov (χ²₃ when consistent)"},
                "truth_q": _QUAT,
            },
            ("vehicle", "t", "seq", "error_deg", "plus_3sigma_deg", "minus_3sigma_deg", "angle_deg",
             "within_3sigma", "truth_q"),
            "the estimate against the simulator's truth (P/V/truth) at the same t",
        ),
        "diagnostics": _obj(
            "attitude_view.Diagnostics",
            {
                **_COMMON,
                "filter": _STR,
                "ess": {**_NUM, "description": "effective sample size 1/Σwᵢ² of the last update (particle filters)"},
                "particles": {**_INT, "description": "particle count (particle filters)"},
                "ess_fraction": {**_NUM, "description": "ess / particles"},
                "nis": {**_NUM, "description": "normalised innovation squared of the last update (Kalman filters)"},
                "nis_dof": _INT,
                "propagations": _INT,
                "updates": _INT,
                "resamples": _INT,
                "reinits": {**_INT, "description": "re-initialisations, every cause"},
                "gated": {**_INT, "description": "observations refused by the innovation gate, every sensor"},
                "rollbacks": _INT,
                "held": {**_INT, "description": "samples waiting in the reorder window"},
                "rejected": {**_INT, "description": "the vehicle's inputs the service refused since it exists"},
            },
            ("vehicle", "t", "seq", "filter", "propagations", "updates", "reinits", "gated", "rollbacks", "held",
             "rejected"),
            "what the filter knows about itself (the estimate's diagnostics)",
        ),
        "rejections": _obj(
            "attitude_view.Rejections",
            {
                "vehicle": _STR,
                "total": {**_INT, "description": "rejections (P/V/rejected) since the view started"},
                "by_code": _obj(None, codes, REJECTION_CODES, "the same by code"),
                "last": _obj(None, {"code": _STR, "message": _STR, "key": _STR}, ("code", "message", "key"),
                             "the last rejection"),
            },
            ("vehicle", "total", "by_code", "last"),
            "the vehicle's refused inputs, counted by the view",
        ),
        SUMMARY_TOPIC: _obj(
            "attitude_view.Summary",
            {
                "vehicles": {
                    "type": "array",
                    "items": _obj(
                        None,
                        {
                            "vehicle": _STR,
                            "filter": _STR,
                            "t": _NUM,
                            "seq": _INT,
                            "error_deg": {"type": ["number", "null"], "description": "error angle; null: no truth"},
                            "three_sigma_deg": {**_NUM, "description": "the largest 3σ of the three axes"},
                            "within_3sigma": {"type": ["boolean", "null"]},
                            "ess": {"type": ["number", "null"]},
                            "rejected": {**_INT, "description": "rejections since the view started"},
                            "rate_hz": _NUM,
                        },
                        ("vehicle", "filter", "t", "seq", "error_deg", "three_sigma_deg", "within_3sigma", "ess",
                         "rejected", "rate_hz"),
                    ),
                },
                "dropped": {**_INT, "description": "messages the view dropped because it fell behind"},
            },
            ("vehicles", "dropped"),
            "a row per vehicle",
        ),
    }
