//! Why an input or a request was refused: a stable machine-readable code (the contract's table,
//! `proto/README.md`, "Errors") and a readable message. Every layer refuses with it; the wire turns it
//! into an error reply.

/// Why an input or a request was refused: a stable machine-readable code and a readable message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rejection {
    pub code: RejectCode,
    pub message: String,
}

/// Stable rejection codes (the `code` field of error replies and `P/V/rejected`; the table in
/// `proto/README.md`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum RejectCode {
    /// The payload is not UTF-8.
    InvalidUtf8,
    /// The payload is not JSON.
    InvalidJson,
    /// JSON of the wrong shape: missing or unknown fields, wrong types, wrong array lengths.
    BadRequest,
    /// NaN or infinity where a number is required.
    NonFinite,
    /// A zero or near-zero vector where a direction or field is required.
    ZeroVector,
    /// A sigma that is not positive.
    BadSigma,
    /// The payload exceeds the configured size.
    PayloadTooLarge,
    /// A batch or observation set exceeds the configured count.
    BatchTooLarge,
    /// The vehicle id is outside the contract (1–64 of `[A-Za-z0-9_-]`).
    InvalidVehicleId,
    /// The query names a vehicle the service does not know.
    UnknownVehicle,
    /// The vehicle exists but has no estimate yet (waiting for a usable vector-observation set), or
    /// an input cannot start it (a set without two non-parallel vectors).
    NotInitialized,
    /// A new vehicle beyond the configured maximum.
    TooManyVehicles,
    /// The sample is older than what the vehicle's filter already processed.
    OutOfOrder,
    /// The same sample again: a gyro sample at the time of one already accepted, or a vector set
    /// identical to one already accepted at the same time.
    Duplicate,
    /// The sample is further ahead of the vehicle's newest time than `time.max_jump_s` (a reset with
    /// `t` re-anchors the vehicle's time).
    TimeJump,
    /// A finite number outside its physical range (a rate above `limits.max_rate_rad_s`, a time beyond
    /// ±1e12 s, a vector or sigma above 1e100).
    OutOfRange,
    /// The vehicle's input queue is full.
    QueueFull,
    /// A gyro sample for a vehicle fed raw IMU samples, or an IMU sample for one fed gyro samples (one
    /// gyro per vehicle; a reset lets it switch).
    MixedInputs,
    /// The filter refused the input (numerical failure); the filter is unchanged.
    FilterError,
    /// A routed input (`P/V/<leaf>/<r>`) whose route `r` is not the vehicle's.
    WrongRoute,
    /// Not a refusal of one input: zenoh reports puts of the vehicle's input key lost between an
    /// advanced publisher and the service, and its cache could not give them back.
    SamplesMissed,
    /// Not a refusal: the sample came after a gap in its stream (more than three usual intervals
    /// without one); it was used, the gap bridged and paid for in the covariance.
    Gap,
    /// Something failed inside the service.
    Internal,
}

impl RejectCode {
    pub const ALL: [RejectCode; 23] = [
        RejectCode::InvalidUtf8,
        RejectCode::InvalidJson,
        RejectCode::BadRequest,
        RejectCode::NonFinite,
        RejectCode::ZeroVector,
        RejectCode::BadSigma,
        RejectCode::PayloadTooLarge,
        RejectCode::BatchTooLarge,
        RejectCode::InvalidVehicleId,
        RejectCode::UnknownVehicle,
        RejectCode::NotInitialized,
        RejectCode::TooManyVehicles,
        RejectCode::OutOfOrder,
        RejectCode::Duplicate,
        RejectCode::TimeJump,
        RejectCode::OutOfRange,
        RejectCode::QueueFull,
        RejectCode::MixedInputs,
        RejectCode::FilterError,
        RejectCode::WrongRoute,
        RejectCode::SamplesMissed,
        RejectCode::Gap,
        RejectCode::Internal,
    ];

    pub fn as_str(&self) -> &'static str {
        match self {
            RejectCode::InvalidUtf8 => "invalid_utf8",
            RejectCode::InvalidJson => "invalid_json",
            RejectCode::BadRequest => "bad_request",
            RejectCode::NonFinite => "non_finite",
            RejectCode::ZeroVector => "zero_vector",
            RejectCode::BadSigma => "bad_sigma",
            RejectCode::PayloadTooLarge => "payload_too_large",
            RejectCode::BatchTooLarge => "batch_too_large",
            RejectCode::InvalidVehicleId => "invalid_vehicle_id",
            RejectCode::UnknownVehicle => "unknown_vehicle",
            RejectCode::NotInitialized => "not_initialized",
            RejectCode::TooManyVehicles => "too_many_vehicles",
            RejectCode::OutOfOrder => "out_of_order",
            RejectCode::Duplicate => "duplicate",
            RejectCode::TimeJump => "time_jump",
            RejectCode::OutOfRange => "out_of_range",
            RejectCode::QueueFull => "queue_full",
            RejectCode::MixedInputs => "mixed_inputs",
            RejectCode::FilterError => "filter_error",
            RejectCode::WrongRoute => "wrong_route",
            RejectCode::SamplesMissed => "samples_missed",
            RejectCode::Gap => "gap",
            RejectCode::Internal => "internal",
        }
    }
}

impl Rejection {
    pub fn new(code: RejectCode, message: impl Into<String>) -> Self {
        Rejection {
            code,
            message: message.into(),
        }
    }
}
