//! The wire contract in `proto/` (prose, JSON Schemas, examples) against the Rust wire types of
//! `src/wire`: these tests fail when the two drift apart.
//!
//! * Every example decodes into its Rust type and re-encodes to the same JSON value, and every example
//!   file is in [`EXAMPLES`].
//! * Every example is valid under its schema, and its numbers are consistent (unit quaternions,
//!   `w ≥ 0` in what the service sends, symmetric positive-definite covariances whose attitude diagonal
//!   matches `sigma_deg`, observations that agree with the truth under `b = A(q) r`, IMU samples that
//!   agree with the IMU estimate).
//! * Every field of every Rust message (a fully populated instance, serialised) is in its schema's
//!   `properties`, and every schema property is a field of the Rust message.
//! * Every rejection code is in the error table of `proto/README.md` and in the schemas' enumerations.
//!
//! The schemas are applied by the `jsonschema` crate (draft 2020-12, what they declare). A test checks
//! that they are valid under the draft's meta-schema and use only its keywords (a misspelt keyword would
//! silently check nothing), and that their one pattern, the vehicle id, accepts exactly the ids the
//! service accepts. (Python validates live replies against the same files with `jsonschema`.)

use crate::common::proto_dir;
use attitude_service::attitude::{q_method, Quaternion};
use attitude_service::wire::{
    decode_batch, validate_vehicle_id, AttitudeMsg, CheckpointHealthMsg, CovarianceMsg,
    DiagnosticsMsg, ErrorMsg, EstimateMsg, FleetHealthMsg, GateCountsMsg, GyroMsg, HealthMsg,
    ImuDiagnosticsMsg, ImuMsg, IngestHealthMsg, InputLimits, MeasuredNoiseMsg, ObservationMsg,
    PerAxis, QuaternionMsg, RejectCode, Rejection, ResetMsg, ResetReplyMsg, SensorSheetMsg,
    TruthMsg, VectorsMsg, VehicleInfoMsg,
};
use nalgebra::{Matrix6, Vector3};
use serde::de::DeserializeOwned;
use serde::Serialize;
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

const DRAFT_2020_12: &str = "https://json-schema.org/draft/2020-12/schema";
/// The only pattern of the schemas, the vehicle id: it accepts what `wire::validate_vehicle_id` accepts.
const VEHICLE_PATTERN: &str = "^[A-Za-z0-9_-]{1,64}$";
/// The error code of a query for a vehicle that exists but has no estimate yet (the contract names it
/// even if `RejectCode` lost it).
const NOT_INITIALIZED: &str = "not_initialized";
/// A key of `P/@/health`'s `rejected` counters that is not an error code: samples dropped on arrival
/// (`query::health`).
const INGEST_OVERFLOW: &str = "ingest_overflow";

type RoundTrip = fn(&Value) -> Result<(), String>;

/// Every example: file in `proto/examples/`, the schema it follows (`proto/schemas/NAME.schema.json`)
/// and the Rust type it decodes into.
const EXAMPLES: &[(&str, &str, RoundTrip)] = &[
    ("gyro.json", "gyro", round_trip::<GyroMsg>),
    ("gyro-batch.json", "gyro", round_trip::<Vec<GyroMsg>>),
    ("vectors.json", "vectors", round_trip::<VectorsMsg>),
    (
        "vectors-batch.json",
        "vectors",
        round_trip::<Vec<VectorsMsg>>,
    ),
    (
        "vectors-magnetometer.json",
        "vectors",
        round_trip::<VectorsMsg>,
    ),
    ("imu.json", "imu", round_trip::<ImuMsg>),
    ("imu-batch.json", "imu", round_trip::<Vec<ImuMsg>>),
    ("estimate-qpf.json", "estimate", round_trip::<EstimateMsg>),
    ("estimate-mekf.json", "estimate", round_trip::<EstimateMsg>),
    ("estimate-imu.json", "estimate", round_trip::<EstimateMsg>),
    ("state.json", "state", round_trip::<EstimateMsg>),
    ("attitude.json", "attitude", round_trip::<AttitudeMsg>),
    ("covariance.json", "covariance", round_trip::<CovarianceMsg>),
    (
        "reset-request.json",
        "reset-request",
        round_trip::<ResetMsg>,
    ),
    (
        "reset-request-initialize.json",
        "reset-request",
        round_trip::<ResetMsg>,
    ),
    (
        "reset-reply.json",
        "reset-reply",
        round_trip::<ResetReplyMsg>,
    ),
    (
        "reset-reply-initializing.json",
        "reset-reply",
        round_trip::<ResetReplyMsg>,
    ),
    ("error.json", "error", round_trip::<ErrorMsg>),
    ("rejected.json", "error", round_trip::<ErrorMsg>),
    (
        "vehicles.json",
        "vehicles",
        round_trip::<Vec<VehicleInfoMsg>>,
    ),
    ("health.json", "health", round_trip::<HealthMsg>),
    ("truth.json", "truth", round_trip::<TruthMsg>),
];

fn round_trip<T: DeserializeOwned + Serialize>(example: &Value) -> Result<(), String> {
    let typed: T = serde_json::from_value(example.clone())
        .map_err(|e| format!("does not decode into its Rust type: {e}"))?;
    let again = serde_json::to_value(&typed).map_err(|e| format!("does not encode: {e}"))?;
    if &again == example {
        Ok(())
    } else {
        Err(format!(
            "re-encodes differently\n    example: {example}\n    Rust:    {again}"
        ))
    }
}

fn read_json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{} is not JSON: {e}", path.display()))
}

fn example(name: &str) -> Value {
    read_json(&proto_dir().join("examples").join(name))
}

fn schema(name: &str) -> Value {
    read_json(
        &proto_dir()
            .join("schemas")
            .join(format!("{name}.schema.json")),
    )
}

/// File names in a folder of `proto/` that end with `suffix`.
fn files_in(folder: &str, suffix: &str) -> BTreeSet<String> {
    let dir = proto_dir().join(folder);
    std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|name| name.ends_with(suffix))
        .collect()
}

fn schema_names() -> BTreeSet<String> {
    files_in("schemas", ".schema.json")
        .into_iter()
        .map(|f| f.trim_end_matches(".schema.json").to_string())
        .collect()
}

/// Every code an error reply or a rejection can carry.
fn all_codes() -> BTreeSet<String> {
    let mut codes: BTreeSet<String> = RejectCode::ALL
        .iter()
        .map(|c| c.as_str().to_string())
        .collect();
    codes.insert(NOT_INITIALIZED.to_string());
    codes
}

fn fail_on(errors: Vec<String>) {
    assert!(
        errors.is_empty(),
        "{} problem(s):\n{}",
        errors.len(),
        errors.join("\n")
    );
}

// ------------------------------------------------------------------------------------------------
// Validation by the `jsonschema` crate (draft 2020-12, what every file declares), and the walks over a
// schema's structure that compare it with the Rust messages.

/// Every keyword of draft 2020-12 (the core, applicator, unevaluated, validation, meta-data, format
/// annotation and content vocabularies). A validator ignores a word it does not know, so a misspelt
/// keyword would check nothing: the schemas may use only these.
#[rustfmt::skip]
const KEYWORDS_2020_12: &[&str] = &[
    // core
    "$schema", "$id", "$ref", "$anchor", "$dynamicRef", "$dynamicAnchor", "$vocabulary", "$comment",
    "$defs",
    // applicator, unevaluated
    "allOf", "anyOf", "oneOf", "not", "if", "then", "else", "dependentSchemas", "prefixItems", "items",
    "contains", "properties", "patternProperties", "additionalProperties", "propertyNames",
    "unevaluatedItems", "unevaluatedProperties",
    // validation
    "type", "enum", "const", "multipleOf", "maximum", "exclusiveMaximum", "minimum",
    "exclusiveMinimum", "maxLength", "minLength", "pattern", "maxItems", "minItems", "uniqueItems",
    "maxContains", "minContains", "maxProperties", "minProperties", "required", "dependentRequired",
    // meta-data, format annotation, content
    "title", "description", "default", "deprecated", "readOnly", "writeOnly", "examples", "format",
    "contentEncoding", "contentMediaType", "contentSchema",
];

/// Every schema object in `schema` (itself included) with its JSON pointer.
fn subschemas<'s>(schema: &'s Value, at: String, out: &mut Vec<(String, &'s Value)>) {
    let Some(map) = schema.as_object() else {
        return; // `true` or `false`
    };
    out.push((at.clone(), schema));
    for (keyword, arg) in map {
        let at = format!("{at}/{keyword}");
        match keyword.as_str() {
            "$defs" | "properties" | "patternProperties" | "dependentSchemas" => {
                for (name, sub) in arg.as_object().into_iter().flatten() {
                    subschemas(sub, format!("{at}/{name}"), out);
                }
            }
            "allOf" | "anyOf" | "oneOf" | "prefixItems" => {
                for (i, sub) in arg.as_array().into_iter().flatten().enumerate() {
                    subschemas(sub, format!("{at}/{i}"), out);
                }
            }
            "not"
            | "if"
            | "then"
            | "else"
            | "items"
            | "contains"
            | "additionalProperties"
            | "propertyNames"
            | "unevaluatedItems"
            | "unevaluatedProperties"
            | "contentSchema" => subschemas(arg, at, out),
            _ => {}
        }
    }
}

/// One schema file: validation, and the walks over its structure.
struct Validator<'a> {
    root: &'a Value,
}

impl Validator<'_> {
    /// Follows a local `$ref` (`#/$defs/NAME`).
    fn resolve<'s>(&'s self, schema: &'s Value) -> &'s Value {
        match schema.get("$ref").and_then(Value::as_str) {
            Some(r) => {
                let pointer = r
                    .strip_prefix('#')
                    .unwrap_or_else(|| panic!("only local $ref are supported, got {r}"));
                let target = self
                    .root
                    .pointer(pointer)
                    .unwrap_or_else(|| panic!("$ref {r} does not resolve"));
                self.resolve(target)
            }
            None => schema,
        }
    }

    /// Why `value` is not valid under `schema` (the file or a part of it, whose `$ref`s resolve in the
    /// file's `$defs`), by the `jsonschema` crate; `at` names the value in the messages.
    fn errors(&self, schema: &Value, value: &Value, at: &str) -> Vec<String> {
        let mut standalone = schema.clone();
        if let (Some(s), Some(defs)) = (standalone.as_object_mut(), self.root.get("$defs")) {
            s.entry("$defs").or_insert_with(|| defs.clone());
        }
        let validator = jsonschema::draft202012::new(&standalone)
            .unwrap_or_else(|e| panic!("{at}: the schema does not compile: {e}"));
        validator
            .iter_errors(value)
            .map(|e| format!("{at}{}: {e}", e.instance_path()))
            .collect()
    }

    /// The branch of a `oneOf`/`anyOf` that `value` is valid under (or the schema itself).
    fn branch<'s>(&'s self, schema: &'s Value, value: &Value) -> &'s Value {
        let schema = self.resolve(schema);
        for keyword in ["oneOf", "anyOf"] {
            if let Some(branches) = schema.get(keyword).and_then(Value::as_array) {
                let chosen = branches
                    .iter()
                    .find(|b| self.errors(b, value, "").is_empty())
                    .unwrap_or_else(|| panic!("no branch of {keyword} matches {value}"));
                return self.branch(chosen, value);
            }
        }
        schema
    }

    /// Compares the field names of `value` with the `properties` of the schema, at every depth.
    fn compare_fields(&self, schema: &Value, value: &Value, at: &str, out: &mut Vec<String>) {
        let schema = self.branch(schema, value);
        match value {
            Value::Object(map) => {
                if let Some(props) = schema.get("properties").and_then(Value::as_object) {
                    for name in map.keys().filter(|k| !props.contains_key(*k)) {
                        out.push(format!("{at}: Rust field {name} is not in the schema"));
                    }
                    for name in props.keys().filter(|k| !map.contains_key(*k)) {
                        out.push(format!(
                            "{at}: schema property {name} is not a field of the Rust message"
                        ));
                    }
                    for (name, v) in map {
                        if let Some(sub) = props.get(name) {
                            self.compare_fields(sub, v, &format!("{at}.{name}"), out);
                        }
                    }
                } else if let Some(sub) =
                    schema.get("additionalProperties").filter(|s| s.is_object())
                {
                    // A map (code -> count): its keys are data, not fields.
                    for (name, v) in map {
                        self.compare_fields(sub, v, &format!("{at}.{name}"), out);
                    }
                } else {
                    out.push(format!(
                        "{at}: the schema does not describe this object's fields"
                    ));
                }
            }
            Value::Array(items) => {
                if let Some(sub) = schema.get("items") {
                    for (i, v) in items.iter().enumerate() {
                        self.compare_fields(sub, v, &format!("{at}[{i}]"), out);
                    }
                }
            }
            _ => {}
        }
    }
}

impl Validator<'_> {
    /// Compares the fields present in a minimal message with the schema's `required`, at every depth.
    fn compare_required(&self, schema: &Value, value: &Value, at: &str, out: &mut Vec<String>) {
        let schema = self.branch(schema, value);
        match value {
            Value::Object(map) => {
                let Some(props) = schema.get("properties").and_then(Value::as_object) else {
                    return; // a map: its keys are data
                };
                let required: BTreeSet<&str> = schema
                    .get("required")
                    .and_then(Value::as_array)
                    .map(|r| r.iter().map(|x| x.as_str().unwrap()).collect())
                    .unwrap_or_default();
                let sent: BTreeSet<&str> = map.keys().map(String::as_str).collect();
                if required != sent {
                    out.push(format!(
                        "{at}: the schema requires {required:?}, Rust always sends {sent:?}"
                    ));
                }
                for (name, v) in map {
                    if let Some(sub) = props.get(name) {
                        self.compare_required(sub, v, &format!("{at}.{name}"), out);
                    }
                }
            }
            Value::Array(items) => {
                if let Some(sub) = schema.get("items") {
                    for (i, v) in items.iter().enumerate() {
                        self.compare_required(sub, v, &format!("{at}[{i}]"), out);
                    }
                }
            }
            _ => {}
        }
    }
}

fn schema_errors(schema_name: &str, value: &Value) -> Vec<String> {
    let root = schema(schema_name);
    let v = Validator { root: &root };
    v.errors(&root, value, schema_name)
}

// ------------------------------------------------------------------------------------------------
// Fully populated Rust messages: every optional field present.

fn full_estimate() -> EstimateMsg {
    let mut cov = [[0.0; 6]; 6];
    for (i, row) in cov.iter_mut().enumerate() {
        row[i] = if i < 3 { 1.0e-8 } else { 1.0e-14 };
    }
    EstimateMsg {
        vehicle: "sc1".into(),
        t: 12.5,
        q: QuaternionMsg {
            w: 0.6,
            x: 0.0,
            y: 0.8,
            z: 0.0,
        },
        bias: [1.0e-6, -2.0e-6, 3.0e-7],
        cov,
        sigma_deg: [1.0e-4f64.to_degrees(); 3],
        filter: "qpf".into(),
        fiducial: Some("average".into()),
        seq: 7,
        diagnostics: DiagnosticsMsg {
            propagations: 70,
            updates: 7,
            nis: Some(2.9),
            nis_dof: Some(6),
            ess: Some(512.5),
            particles: Some(1000),
            level: Some(3),
            concentration: Some(0.999),
            eigen_gap: Some(0.998),
            pc_stages: Some(2),
            resamples: Some(3),
            fiducial_fallbacks: Some(0),
            rejected: BTreeMap::from([("out_of_order".to_string(), 1)]),
            gyro_gap_s: Some(2.5),
            gyro_gaps: 1,
            gate: BTreeMap::from([(
                "st1".to_string(),
                GateCountsMsg {
                    accepted: 20,
                    gated: 1,
                    norm_gated: 2,
                    disturbed: 3,
                },
            )]),
            consecutive_gated: 0,
            rollbacks: 0,
            reinits: BTreeMap::from([("gate".to_string(), 1)]),
            held: 2,
            replayed: true,
            late_fused: 3,
            missed: 2,
            imu: Some(full_imu_diagnostics()),
        },
    }
}

fn full_imu_diagnostics() -> ImuDiagnosticsMsg {
    ImuDiagnosticsMsg {
        samples: 5000,
        at_rest: false,
        rest_samples: 1200,
        bias_updates: 4,
        tilt_updates: 170,
        tilt_gated: 1,
        heading_updates: 160,
        mag_rejected: 10,
        mag_disturbed: true,
        mag_new_fields: 0,
        mag_hard_iron_changes: 1,
        tilt_reacquisitions: 0,
        heading_reacquisitions: 0,
        tilt_sigma_lp_deg: 0.3,
        mag_norm: Some(44.5),
        mag_dip_deg: Some(69.8),
        mag_offset: Some([0.3, -0.2, -5.9]),
        mag_reference: Some("confirmed".to_string()),
        gyro_saturated: 3,
        acc_saturated: 1,
        heading_aided: true,
        heading_unaided_s: 0.5,
        gaps: 2,
        blind_s: 0.35,
        measured: MeasuredNoiseMsg {
            gyro_noise_density_deg_s_sqrt_hz: 0.007,
            acc_noise_density_ug_sqrt_hz: 120.0,
            mag_noise: 0.2,
            rest_s: 40.0,
        },
    }
}

fn full_imu() -> ImuMsg {
    ImuMsg {
        t: 12.5,
        gyr: [0.0, 1.0e-3, -2.0e-3],
        acc: [0.1, -0.2, 9.8],
        mag: Some([0.0, 15.6, -41.7]),
    }
}

fn full_observation() -> ObservationMsg {
    ObservationMsg {
        body: [1.0, 0.0, 0.0],
        reference: [0.0, 1.0, 0.0],
        sigma: 1.0e-4,
        sensor: Some("st1".into()),
    }
}

/// (schema, a fully populated message of the Rust type that schema describes).
fn full_messages() -> Vec<(&'static str, Value)> {
    fn v<T: Serialize>(t: T) -> Value {
        serde_json::to_value(t).unwrap()
    }
    let gyro = GyroMsg {
        t: 12.5,
        omega: [0.0, 1.0e-3, -2.0e-3],
    };
    let vectors = VectorsMsg {
        t: 12.5,
        obs: vec![full_observation(), full_observation()],
    };
    let reset = ResetMsg {
        filter: Some("qpf".into()),
        fiducial: Some("propagated".into()),
        particles: Some(2000),
        level: Some(3),
        q: Some(QuaternionMsg {
            w: 0.0,
            x: -0.6,
            y: 0.0,
            z: 0.8,
        }),
        sigma_deg: Some(PerAxis::Three([1.0, 2.0, 3.0])),
        bias: Some([0.0, 0.0, 1.0e-6]),
        bias_sigma: Some(PerAxis::One(5.0e-6)),
        t: Some(100.0),
        sensor: Some(SensorSheetMsg {
            gyro_noise_density_deg_s_sqrt_hz: Some(0.005),
            gyro_bias_instability_deg_h: Some(10.0),
            gyro_range_deg_s: Some(2000.0),
            acc_noise_density_ug_sqrt_hz: Some(150.0),
            acc_range_g: Some(16.0),
            mag_noise: Some(0.3),
            mag_offset_sigma: Some(0.5),
            output: Some("increments".into()),
        }),
    };
    let reset_other_forms = ResetMsg {
        sigma_deg: Some(PerAxis::One(2.0)),
        bias_sigma: Some(PerAxis::Three([1.0e-6, 2.0e-6, 3.0e-6])),
        ..reset.clone()
    };
    let reset_reply = ResetReplyMsg {
        vehicle: "sc1".into(),
        state: "tracking".into(),
        filter: "qpf".into(),
        fiducial: Some("average".into()),
        particles: Some(1000),
        level: Some(3),
        estimate: Some(full_estimate()),
    };
    let vehicle = VehicleInfoMsg {
        vehicle: "sc1".into(),
        state: "tracking".into(),
        filter: "usque".into(),
        fiducial: Some("propagated".into()),
        t: Some(12.5),
        received: 10,
        processed: 9,
        rejected: 1,
        estimates: 3,
    };
    let health = HealthMsg {
        status: "ok".into(),
        version: "0.1.0".into(),
        uptime_s: 3.5,
        vehicles: 1,
        received: 10,
        processed: 9,
        estimates_published: 3,
        listened: true,
        rejected: BTreeMap::from([
            (NOT_INITIALIZED.to_string(), 1),
            ("queue_full".to_string(), 2),
            (INGEST_OVERFLOW.to_string(), 5),
        ]),
        queries: 4,
        held: 2,
        gated: 1,
        reinits: 1,
        rollbacks: 0,
        late_fused: 4,
        history_bytes: 123456,
        missed: 3,
        gaps: 2,
        blind_s: 0.4,
        ingest: IngestHealthMsg {
            recovery: true,
            depth: 1,
            capacity: 65536,
            waited: 2,
            wait_s: 0.004,
            refused: 5,
            redelivered: 7,
        },
        checkpoints: Some(CheckpointHealthMsg {
            state_dir: "/var/lib/attitude".into(),
            interval_s: 10.0,
            restored: 1,
            skipped: 0,
            written: 12,
            failed: 0,
        }),
        fleet: Some(FleetHealthMsg {
            mode: "dynamic".into(),
            group: "default".into(),
            instance: "ground-1".into(),
            vehicles: "*".into(),
            members: vec!["ground-1".into(), "ground-2".into()],
            owned: 2,
            takeovers: 1,
            released: 0,
            routes_owned: vec![0, 3, 4, 9, 10, 13, 14, 15],
            routes_standby: vec![1, 2, 5, 6, 7, 8, 11, 12],
            standby_inputs: 40,
            standby_estimates: 3,
            standby_bytes: 52310,
            standby_malformed: 0,
        }),
    };
    let truth = TruthMsg {
        vehicle: "sc1".into(),
        t: 12.5,
        q: QuaternionMsg {
            w: 0.6,
            x: 0.0,
            y: -0.8,
            z: 0.0,
        },
        bias: [1.0e-6, -2.0e-6, 3.0e-7],
    };
    let error = attitude_service::wire::ToMessage::to_message(
        &Rejection::new(RejectCode::OutOfOrder, "too old"),
        "attitude/sc1/gyro",
    );
    let imu = full_imu();
    vec![
        ("gyro", v(&gyro)),
        ("gyro", v(vec![gyro.clone(), gyro])),
        ("vectors", v(&vectors)),
        ("vectors", v(vec![vectors])),
        ("imu", v(&imu)),
        ("imu", v(vec![imu.clone(), imu])),
        ("estimate", v(full_estimate())),
        ("state", v(full_estimate())),
        ("attitude", v(full_estimate().attitude())),
        ("covariance", v(full_estimate().covariance())),
        ("reset-request", v(&reset)),
        ("reset-request", v(&reset_other_forms)),
        ("reset-reply", v(&reset_reply)),
        ("error", v(&error)),
        ("vehicles", v(vec![vehicle])),
        ("health", v(&health)),
        ("truth", v(&truth)),
    ]
}

// ------------------------------------------------------------------------------------------------
// (a), (b): examples

#[test]
fn every_example_round_trips_through_its_rust_type() {
    let mut errors = Vec::new();
    for (file, _, round_trip) in EXAMPLES {
        if let Err(e) = round_trip(&example(file)) {
            errors.push(format!("examples/{file}: {e}"));
        }
    }
    fail_on(errors);
}

#[test]
fn every_example_file_is_in_the_table_and_every_schema_has_an_example() {
    let on_disk = files_in("examples", ".json");
    let listed: BTreeSet<String> = EXAMPLES.iter().map(|(f, _, _)| f.to_string()).collect();
    let stray: Vec<_> = on_disk.difference(&listed).collect();
    let missing: Vec<_> = listed.difference(&on_disk).collect();
    assert!(
        stray.is_empty(),
        "examples not in the table of tests/it/proto.rs: {stray:?}"
    );
    assert!(
        missing.is_empty(),
        "examples in the table but not in proto/examples: {missing:?}"
    );

    let schemas = schema_names();
    let used: BTreeSet<String> = EXAMPLES.iter().map(|(_, s, _)| s.to_string()).collect();
    assert_eq!(
        used, schemas,
        "every schema has an example, and every example a schema"
    );
}

#[test]
fn every_example_is_valid_under_its_schema() {
    let mut errors = Vec::new();
    for (file, schema_name, _) in EXAMPLES {
        for e in schema_errors(schema_name, &example(file)) {
            errors.push(format!("examples/{file}: {e}"));
        }
    }
    fail_on(errors);
}

#[test]
fn the_schemas_refuse_what_the_service_refuses() {
    let cases: &[(&str, Value)] = &[
        ("gyro", serde_json::json!({"t": 1.0, "omega": [0.0, 0.0]})),
        (
            "gyro",
            serde_json::json!({"t": 1.0, "omega": [0.0, 0.0, 0.0], "extra": 1}),
        ),
        ("gyro", serde_json::json!([])),
        ("gyro", serde_json::json!({"omega": [0.0, 0.0, 0.0]})),
        ("vectors", serde_json::json!({"t": 1.0, "obs": []})),
        (
            "vectors",
            serde_json::json!({"t": 1.0, "obs": [{"body": [1.0, 0.0, 0.0], "ref": [1.0, 0.0, 0.0], "sigma": 0.0}]}),
        ),
        (
            "vectors",
            serde_json::json!({"t": 1.0, "obs": [{"body": [1.0, 0.0, 0.0], "ref": [1.0, 0.0, 0.0], "sigma": 1.0, "sensor": ""}]}),
        ),
        (
            "attitude",
            serde_json::json!({"vehicle": "a.b", "t": 1.0, "q": {"w": 1.0, "x": 0.0, "y": 0.0, "z": 0.0}, "sigma_deg": [1.0, 1.0, 1.0]}),
        ),
        (
            "attitude",
            serde_json::json!({"vehicle": "a", "t": 1.0, "q": {"w": -1.0, "x": 0.0, "y": 0.0, "z": 0.0}, "sigma_deg": [1.0, 1.0, 1.0]}),
        ),
        (
            "error",
            serde_json::json!({"code": "no_such_code", "message": "", "key": "k"}),
        ),
        (
            "reset-request",
            serde_json::json!({"sigma_deg": [1.0, 2.0]}),
        ),
        ("reset-request", serde_json::json!({"filter": "ekf"})),
        ("imu", serde_json::json!({"t": 1.0, "gyr": [0.0, 0.0, 0.0]})),
        (
            "imu",
            serde_json::json!({"t": 1.0, "gyr": [0.0, 0.0], "acc": [0.0, 0.0, 9.81]}),
        ),
        (
            "imu",
            serde_json::json!({"t": 1.0, "gyr": [0.0, 0.0, 0.0], "acc": [0.0, 0.0, 9.81], "mag": [1.0, 2.0]}),
        ),
        (
            "imu",
            serde_json::json!({"t": 1.0, "gyr": [0.0, 0.0, 0.0], "acc": [0.0, 0.0, 9.81], "omega": [0.0, 0.0, 0.0]}),
        ),
        (
            "imu",
            serde_json::json!({"t": 1.0, "gyr": [0.0, 0.0, 0.0], "acc": [0.0, 0.0, 9.81], "mag": null}),
        ),
        ("imu", serde_json::json!([])),
        // One case for each keyword the schemas use that the cases above do not reach.
        // `maximum` and `type: integer`:
        ("reset-request", serde_json::json!({"particles": 1000001})),
        ("reset-request", serde_json::json!({"particles": 1000.5})),
        ("reset-request", serde_json::json!({"sigma_deg": 361.0})),
        // `additionalProperties` as a schema (a map of counts) and `propertyNames`:
        (
            "health",
            health_with_rejected(serde_json::json!({"queue_full": -1})),
        ),
        (
            "health",
            health_with_rejected(serde_json::json!({"queue_full": "2"})),
        ),
        (
            "health",
            health_with_rejected(serde_json::json!({"no_such_code": 1})),
        ),
        // Through a `$ref` into `$defs`:
        (
            "estimate",
            estimate_with("/diagnostics/imu/mag_dip_deg", serde_json::json!(91.0)),
        ),
        (
            "estimate",
            estimate_with("/diagnostics/gate/st1/accepted", serde_json::json!(-1)),
        ),
        ("estimate", estimate_with("/q/w", serde_json::json!(-0.6))),
        (
            "estimate",
            estimate_with("/cov/0", serde_json::json!([0.0])),
        ),
    ];
    let limits = InputLimits::default();
    for (schema_name, value) in cases {
        assert!(
            !schema_errors(schema_name, value).is_empty(),
            "{schema_name} accepts {value}"
        );
        // The inputs among them are refused by the service's decoding and validation too.
        let payload = value.to_string();
        let service_refuses = match *schema_name {
            "gyro" => decode_batch::<GyroMsg>(payload.as_bytes(), &limits)
                .and_then(|b| {
                    b.iter()
                        .map(|g| g.to_domain(&limits))
                        .collect::<Result<Vec<_>, _>>()
                })
                .is_err(),
            "vectors" => decode_batch::<VectorsMsg>(payload.as_bytes(), &limits)
                .and_then(|b| {
                    b.iter()
                        .map(|s| s.to_domain(&limits))
                        .collect::<Result<Vec<_>, _>>()
                })
                .is_err(),
            "imu" => decode_batch::<ImuMsg>(payload.as_bytes(), &limits)
                .and_then(|b| {
                    b.iter()
                        .map(|s| s.to_domain(&limits))
                        .collect::<Result<Vec<_>, _>>()
                })
                .is_err(),
            _ => continue,
        };
        assert!(
            service_refuses,
            "the service accepts {value}, which {schema_name}.schema.json refuses"
        );
    }
}

/// `health.json` with its `rejected` counters replaced.
fn health_with_rejected(rejected: Value) -> Value {
    let mut h = example("health.json");
    h["rejected"] = rejected;
    h
}

/// The fully populated estimate with the value at `pointer` replaced.
fn estimate_with(pointer: &str, value: Value) -> Value {
    let mut e = serde_json::to_value(full_estimate()).unwrap();
    *e.pointer_mut(pointer)
        .unwrap_or_else(|| panic!("the estimate has {pointer}")) = value;
    e
}

fn quaternion(msg: &QuaternionMsg) -> Quaternion {
    Quaternion::new(msg.x, msg.y, msg.z, msg.w)
}

fn check_unit(q: &QuaternionMsg, at: &str, errors: &mut Vec<String>) {
    let norm = quaternion(q).norm();
    if (norm - 1.0).abs() > 1e-9 {
        errors.push(format!("{at}: quaternion norm {norm}"));
    }
    if q.w < 0.0 {
        errors.push(format!(
            "{at}: sent quaternions have w ≥ 0, got w = {}",
            q.w
        ));
    }
}

fn check_covariance(cov: &[[f64; 6]; 6], sigma_deg: &[f64; 3], at: &str, errors: &mut Vec<String>) {
    let p = Matrix6::from_fn(|i, j| cov[i][j]);
    if p != p.transpose() {
        errors.push(format!("{at}: covariance is not symmetric"));
    }
    if p.cholesky().is_none() {
        errors.push(format!("{at}: covariance is not positive definite"));
    }
    for i in 0..3 {
        let expected = p[(i, i)].sqrt().to_degrees();
        if ((sigma_deg[i] - expected) / expected).abs() > 1e-12 {
            errors.push(format!(
                "{at}: sigma_deg[{i}] = {} but sqrt(cov[{i}][{i}]) = {expected} deg",
                sigma_deg[i]
            ));
        }
    }
}

fn check_estimate(e: &EstimateMsg, at: &str, errors: &mut Vec<String>) {
    check_unit(&e.q, at, errors);
    check_covariance(&e.cov, &e.sigma_deg, at, errors);
    let mekf = e.filter == "mekf";
    if mekf != e.fiducial.is_none() {
        errors.push(format!("{at}: fiducial is null exactly for the MEKF"));
    }
    if (e.filter == "qpf") != e.diagnostics.particles.is_some() {
        errors.push(format!(
            "{at}: diagnostics.particles is present exactly for the qpf"
        ));
    }
}

#[test]
fn example_numbers_are_consistent() {
    let mut errors = Vec::new();
    let estimate = |f: &str| -> EstimateMsg { serde_json::from_value(example(f)).unwrap() };
    for f in [
        "estimate-qpf.json",
        "estimate-mekf.json",
        "estimate-imu.json",
        "state.json",
    ] {
        check_estimate(&estimate(f), f, &mut errors);
    }
    let reply: ResetReplyMsg = serde_json::from_value(example("reset-reply.json")).unwrap();
    match &reply.estimate {
        Some(e) => check_estimate(e, "reset-reply.json", &mut errors),
        None => errors.push("reset-reply.json: the reply to a reset with q has an estimate".into()),
    }

    // attitude.json and covariance.json are the short forms of estimate-qpf.json.
    let qpf = estimate("estimate-qpf.json");
    let attitude: AttitudeMsg = serde_json::from_value(example("attitude.json")).unwrap();
    let covariance: CovarianceMsg = serde_json::from_value(example("covariance.json")).unwrap();
    if attitude != qpf.attitude() {
        errors.push("attitude.json is not estimate-qpf.json's attitude()".into());
    }
    if covariance != qpf.covariance() {
        errors.push("covariance.json is not estimate-qpf.json's covariance()".into());
    }

    // The reset reply starts from the request's attitude and sigmas.
    let request: ResetMsg = serde_json::from_value(example("reset-request.json")).unwrap();
    if let Some(e) = &reply.estimate {
        if Some(e.q) != request.q || Some(e.t) != request.t {
            errors.push("reset-reply.json does not start at reset-request.json's q and t".into());
        }
        let sigma = request.sigma_deg.unwrap().to_vector();
        for i in 0..3 {
            if (e.sigma_deg[i] - sigma[i]).abs() > 1e-12 * sigma[i] {
                errors.push("reset-reply.json's sigma_deg is not the request's".into());
            }
        }
    }

    let truth: TruthMsg = serde_json::from_value(example("truth.json")).unwrap();
    check_unit(&truth.q, "truth.json", &mut errors);
    let request_q = request.q.expect("reset-request.json gives q");
    if let Err(r) = request_q.to_domain() {
        errors.push(format!("reset-request.json: q refused: {}", r.message));
    }
    let vehicles: Vec<VehicleInfoMsg> = serde_json::from_value(example("vehicles.json")).unwrap();
    for v in &vehicles {
        if (v.filter == "mekf") != v.fiducial.is_none() {
            errors.push(format!(
                "vehicles.json {}: fiducial is null exactly for the MEKF",
                v.vehicle
            ));
        }
    }
    let health: HealthMsg = serde_json::from_value(example("health.json")).unwrap();
    if health.vehicles != vehicles.len() {
        errors.push("health.json and vehicles.json count different vehicles".into());
    }
    fail_on(errors);
}

/// The examples agree with the quaternion convention `b = A(q) r`: the star-tracker set of
/// `vectors.json` is `truth.json`'s attitude seen through 6-arcsec noise, the q-method recovers that
/// attitude, `estimate-qpf.json` is close to it, and the magnetometer reading of
/// `vectors-magnetometer.json` agrees with `estimate-mekf.json`.
#[test]
fn examples_follow_the_quaternion_convention() {
    let limits = InputLimits::default();
    let truth: TruthMsg = serde_json::from_value(example("truth.json")).unwrap();
    let q_true = truth.q.to_domain().unwrap();

    let set: VectorsMsg = serde_json::from_value(example("vectors.json")).unwrap();
    assert_eq!(set.t, truth.t);
    let set = set.to_domain(&limits).unwrap();
    for (i, o) in set.observations.iter().enumerate() {
        let residual = (o.body - q_true.attitude_matrix() * o.reference).norm();
        assert!(
            residual < 5.0 * o.sigma,
            "vectors.json obs {i}: |b - A(q) r| = {residual:e}"
        );
    }
    let solution = q_method(&set.observations).unwrap();
    // The q-method's error is within 4σ of its own covariance (a narrow field of view leaves the
    // roll about the boresight much less certain than the two other axes).
    let q_method_error = q_true.small_angle_error(&solution.q);
    for k in 0..3 {
        let sigma = solution.covariance[(k, k)].sqrt();
        assert!(
            q_method_error[k].abs() < 4.0 * sigma,
            "q-method error {q_method_error} vs 1σ {sigma:e} about axis {k}"
        );
    }

    let qpf: EstimateMsg = serde_json::from_value(example("estimate-qpf.json")).unwrap();
    let q_est = qpf.q.to_domain().unwrap();
    let error = q_true.small_angle_error(&q_est);
    for i in 0..3 {
        let sigma = qpf.sigma_deg[i].to_radians();
        assert!(
            error[i].abs() < 3.0 * sigma,
            "estimate-qpf.json error {error} vs 1σ {sigma:e}"
        );
    }

    let mag: VectorsMsg = serde_json::from_value(example("vectors-magnetometer.json")).unwrap();
    let mekf: EstimateMsg = serde_json::from_value(example("estimate-mekf.json")).unwrap();
    assert_eq!(mag.t, mekf.t);
    let a = mekf.q.to_domain().unwrap().attitude_matrix();
    for o in mag.to_domain(&limits).unwrap().observations {
        let residual = (o.body - a * o.reference).norm();
        assert!(
            residual < 5.0 * o.sigma,
            "magnetometer residual {residual} nT"
        );
    }

    // The worked example of proto/README.md: +90° about reference z sees reference y as body x.
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let q = QuaternionMsg {
        w: h,
        x: 0.0,
        y: 0.0,
        z: h,
    }
    .to_domain()
    .unwrap();
    let b = q.attitude_matrix() * Vector3::new(0.0, 1.0, 0.0);
    assert!((b - Vector3::new(1.0, 0.0, 0.0)).norm() < 1e-12, "b = {b}");
}

/// The IMU examples agree with the conventions: `estimate-imu.json` (East-North-Up, magnetic north) sees
/// the vertical where `imu.json`'s accelerometer points and the field's horizontal part where north is,
/// each within 3σ of its own covariance, and its field reference is the reading's norm and dip.
#[test]
fn imu_examples_follow_the_conventions() {
    let sample: ImuMsg = serde_json::from_value(example("imu.json")).unwrap();
    let e: EstimateMsg = serde_json::from_value(example("estimate-imu.json")).unwrap();
    assert_eq!(
        sample.t, e.t,
        "estimate-imu.json is the estimate at imu.json's sample"
    );
    let a = e.q.to_domain().unwrap().attitude_matrix();
    let p = Matrix6::from_fn(|i, j| e.cov[i][j])
        .fixed_view::<3, 3>(0, 0)
        .into_owned();
    // 1σ of the attitude error about a body axis.
    let sigma_about = |axis: &Vector3<f64>| (axis.dot(&(p * axis))).sqrt();

    let up = a * Vector3::z();
    let acc = Vector3::from(sample.acc).normalize();
    let tilt = up.cross(&acc);
    let tilt_angle = tilt.norm().asin();
    let tilt_sigma = sigma_about(&tilt.normalize());
    assert!(
        tilt_angle < 3.0 * tilt_sigma,
        "tilt error {:.3}° vs 1σ {:.3}°",
        tilt_angle.to_degrees(),
        tilt_sigma.to_degrees()
    );

    let mag = Vector3::from(sample.mag.expect("imu.json has a magnetometer reading"));
    let m = a.transpose() * mag;
    let heading_error = m.x.atan2(m.y);
    let heading_sigma = sigma_about(&up);
    assert!(
        heading_error.abs() < 3.0 * heading_sigma,
        "heading error {:.3}° vs 1σ {:.3}°",
        heading_error.to_degrees(),
        heading_sigma.to_degrees()
    );

    let d = e
        .diagnostics
        .imu
        .expect("an IMU vehicle's estimate has diagnostics.imu");
    let norm = d.mag_norm.expect("a field reference");
    assert!(
        (norm / mag.norm() - 1.0).abs() < 0.01,
        "mag_norm {norm} vs |mag| {}",
        mag.norm()
    );
    let dip = (-mag.normalize().dot(&acc)).asin().to_degrees();
    let dip_ref = d.mag_dip_deg.expect("a field reference");
    assert!(
        (dip - dip_ref).abs() < 0.5,
        "mag_dip_deg {dip_ref} vs the reading's {dip}"
    );
    assert!(d.at_rest, "imu.json is a vehicle at rest");

    // imu-batch.json turns about body z at 0.5 rad/s, sampled at 100 Hz.
    let batch: Vec<ImuMsg> = serde_json::from_value(example("imu-batch.json")).unwrap();
    for w in batch.windows(2) {
        assert!((w[1].t - w[0].t - 0.01).abs() < 1e-9, "100 Hz");
    }
    for s in &batch {
        assert!((s.gyr[2] - 0.5).abs() < 0.01, "turning at 0.5 rad/s");
        assert!((Vector3::from(s.acc).norm() - 9.81).abs() < 0.1, "gravity");
    }
}

/// The input examples pass the service's own decoding and validation.
#[test]
fn input_examples_are_accepted_by_the_service() {
    let limits = InputLimits::default();
    let bytes = |f: &str| std::fs::read(proto_dir().join("examples").join(f)).unwrap();
    for f in ["gyro.json", "gyro-batch.json"] {
        let batch: Vec<GyroMsg> = decode_batch(&bytes(f), &limits)
            .unwrap_or_else(|r| panic!("{f}: {} {}", r.code.as_str(), r.message));
        assert!(
            batch.windows(2).all(|w| w[0].t <= w[1].t),
            "{f}: times go back"
        );
        for g in batch {
            g.to_domain(&InputLimits::default())
                .unwrap_or_else(|r| panic!("{f}: {}", r.message));
        }
    }
    for f in [
        "vectors.json",
        "vectors-batch.json",
        "vectors-magnetometer.json",
    ] {
        let batch: Vec<VectorsMsg> = decode_batch(&bytes(f), &limits)
            .unwrap_or_else(|r| panic!("{f}: {} {}", r.code.as_str(), r.message));
        let mut previous = f64::NEG_INFINITY;
        for set in batch {
            assert!(set.t >= previous, "{f}: times go back");
            previous = set.t;
            set.to_domain(&limits)
                .unwrap_or_else(|r| panic!("{f}: {}", r.message));
        }
    }
    for f in ["imu.json", "imu-batch.json"] {
        let batch: Vec<ImuMsg> = decode_batch(&bytes(f), &limits)
            .unwrap_or_else(|r| panic!("{f}: {} {}", r.code.as_str(), r.message));
        // Strictly increasing: two IMU samples at one time are a duplicate.
        assert!(
            batch.windows(2).all(|w| w[0].t < w[1].t),
            "{f}: times do not increase"
        );
        for s in batch {
            s.to_domain(&limits)
                .unwrap_or_else(|r| panic!("{f}: {}", r.message));
        }
    }
}

// ------------------------------------------------------------------------------------------------
// (c): error codes

#[test]
fn every_code_is_in_the_readme_error_table_and_the_schemas() {
    let codes = all_codes();
    let readme = std::fs::read_to_string(proto_dir().join("README.md")).unwrap();
    let section = readme
        .split("\n## Errors")
        .nth(1)
        .expect("proto/README.md has a section ## Errors");
    let section = section.split("\n## ").next().unwrap();
    let table: BTreeSet<String> = section
        .lines()
        .filter_map(|l| l.strip_prefix("| `"))
        .filter_map(|l| l.split('`').next())
        .map(str::to_string)
        .collect();
    assert_eq!(
        table, codes,
        "the error table of proto/README.md lists exactly the codes"
    );

    let enum_of = |schema_name: &str, pointer: &str| -> BTreeSet<String> {
        schema(schema_name)
            .pointer(pointer)
            .and_then(Value::as_array)
            .unwrap_or_else(|| panic!("{schema_name}.schema.json has no enum at {pointer}"))
            .iter()
            .map(|c| c.as_str().unwrap().to_string())
            .collect()
    };
    assert_eq!(
        enum_of("error", "/properties/code/enum"),
        codes,
        "error.schema.json"
    );
    let mut health_keys = codes.clone();
    health_keys.insert(INGEST_OVERFLOW.to_string());
    assert_eq!(
        enum_of("health", "/properties/rejected/propertyNames/enum"),
        health_keys,
        "health.schema.json rejected: every code and ingest_overflow"
    );
    for s in ["estimate", "state"] {
        assert_eq!(
            enum_of(
                s,
                "/$defs/diagnostics/properties/rejected/propertyNames/enum"
            ),
            codes,
            "{s}.schema.json diagnostics.rejected"
        );
    }
}

// ------------------------------------------------------------------------------------------------
// (d): schema files

#[test]
fn every_schema_is_draft_2020_12_with_a_title_and_named_in_the_readme() {
    let readme = std::fs::read_to_string(proto_dir().join("README.md")).unwrap();
    let names = schema_names();
    assert!(names.len() >= 12, "schemas found: {names:?}");
    for name in &names {
        let s = schema(name);
        assert_eq!(s["$schema"], DRAFT_2020_12, "{name}.schema.json: $schema");
        assert!(
            s["title"].as_str().is_some_and(|t| !t.is_empty()),
            "{name}.schema.json has a title"
        );
        assert!(
            readme.contains(&format!("`{name}.schema.json`")),
            "README names {name}.schema.json"
        );
    }
    for file in files_in("examples", ".json") {
        assert!(
            readme.contains(&format!("`{file}`")),
            "README names examples/{file}"
        );
    }
    // state is the estimate under another name.
    let strip = |mut v: Value| {
        let o = v.as_object_mut().unwrap();
        o.remove("title");
        o.remove("description");
        v
    };
    assert_eq!(
        strip(schema("state")),
        strip(schema("estimate")),
        "state and estimate schemas agree"
    );
}

/// Every schema is valid under draft 2020-12's meta-schema, uses only the draft's keywords, and has no
/// pattern but the vehicle id's.
#[test]
fn every_schema_is_valid_and_uses_only_draft_2020_12_keywords() {
    let mut errors = Vec::new();
    for name in schema_names() {
        let root = schema(&name);
        if let Err(e) = jsonschema::draft202012::meta::validate(&root) {
            errors.push(format!(
                "{name}.schema.json is not a valid draft 2020-12 schema: {e}"
            ));
        }
        let mut parts = Vec::new();
        subschemas(&root, String::new(), &mut parts);
        for (at, part) in parts {
            for (keyword, arg) in part.as_object().unwrap() {
                if !KEYWORDS_2020_12.contains(&keyword.as_str()) {
                    errors.push(format!(
                        "{name}.schema.json#{at}: {keyword} is not a draft 2020-12 keyword"
                    ));
                }
                if keyword == "pattern" && arg != VEHICLE_PATTERN {
                    errors.push(format!(
                        "{name}.schema.json#{at}: pattern {arg} is not the vehicle id's"
                    ));
                }
            }
        }
    }
    fail_on(errors);
}

/// The schemas' vehicle-id pattern accepts exactly the ids the service accepts.
#[test]
fn the_vehicle_pattern_accepts_exactly_the_service_ids() {
    let id = serde_json::json!({"type": "string", "pattern": VEHICLE_PATTERN});
    let v = Validator { root: &id };
    let longest = "a".repeat(64);
    let too_long = "a".repeat(65);
    for candidate in [
        "sc1",
        "A-z_09",
        "-",
        longest.as_str(),
        too_long.as_str(),
        "",
        "a.b",
        "a b",
        "a/b",
        "a*",
        "$",
        "sc1\n",
        "é",
    ] {
        let schema_accepts = v.errors(&id, &Value::from(candidate), "id").is_empty();
        assert_eq!(
            schema_accepts,
            validate_vehicle_id(candidate).is_ok(),
            "{candidate:?}: the schema and the service disagree"
        );
    }
}

// ------------------------------------------------------------------------------------------------
// (e): Rust fields against schema properties

#[test]
fn every_rust_field_is_in_its_schema_and_every_schema_property_in_rust() {
    let messages = full_messages();
    let covered: BTreeSet<String> = messages.iter().map(|(s, _)| s.to_string()).collect();
    assert_eq!(
        covered,
        schema_names(),
        "every schema has a fully populated Rust message"
    );
    let mut errors = Vec::new();
    for (schema_name, value) in &messages {
        let root = schema(schema_name);
        let validator = Validator { root: &root };
        validator.compare_fields(&root, value, schema_name, &mut errors);
        // The Rust types' own serialisation is valid under the schema too.
        errors.extend(validator.errors(&root, value, schema_name));
    }
    fail_on(errors);
}

/// Required fields: the fields a Rust message always sends (a minimal message, every optional field
/// absent) are exactly the schema's `required`, at every depth.
#[test]
fn required_fields_are_what_rust_always_sends() {
    let mut minimal: Vec<(&str, Value)> = full_messages()
        .into_iter()
        .filter(|(s, _)| {
            ![
                "vectors",
                "imu",
                "estimate",
                "state",
                "reset-request",
                "reset-reply",
                "health",
            ]
            .contains(s)
        })
        .collect();
    for (s, v) in full_messages() {
        if s == "health" {
            let mut h: HealthMsg = serde_json::from_value(v).unwrap();
            h.checkpoints = None;
            minimal.push((s, serde_json::to_value(h).unwrap()));
        }
    }
    let estimate = EstimateMsg {
        fiducial: None,
        diagnostics: DiagnosticsMsg::default(),
        ..full_estimate()
    };
    minimal.extend([
        (
            "reset-request",
            serde_json::to_value(ResetMsg::default()).unwrap(),
        ),
        (
            "vectors",
            serde_json::to_value(VectorsMsg {
                t: 1.0,
                obs: vec![ObservationMsg {
                    sensor: None,
                    ..full_observation()
                }],
            })
            .unwrap(),
        ),
        (
            "imu",
            serde_json::to_value(ImuMsg {
                mag: None,
                ..full_imu()
            })
            .unwrap(),
        ),
        ("estimate", serde_json::to_value(&estimate).unwrap()),
        ("state", serde_json::to_value(&estimate).unwrap()),
        (
            "reset-reply",
            serde_json::to_value(ResetReplyMsg {
                vehicle: "sc1".into(),
                state: "initializing".into(),
                filter: "mekf".into(),
                fiducial: None,
                particles: None,
                level: None,
                estimate: None,
            })
            .unwrap(),
        ),
        (
            "reset-reply",
            serde_json::to_value(ResetReplyMsg {
                vehicle: "sc1".into(),
                state: "tracking".into(),
                filter: "mekf".into(),
                fiducial: None,
                particles: None,
                level: None,
                estimate: Some(estimate.clone()),
            })
            .unwrap(),
        ),
    ]);
    let mut errors = Vec::new();
    for (schema_name, value) in &minimal {
        let root = schema(schema_name);
        let validator = Validator { root: &root };
        errors.extend(validator.errors(&root, value, schema_name));
        validator.compare_required(&root, value, schema_name, &mut errors);
    }
    // `diagnostics.imu` is optional as a whole (absent above); its own required fields are checked
    // where each schema describes it.
    let imu = serde_json::to_value(ImuDiagnosticsMsg {
        mag_norm: None,
        mag_dip_deg: None,
        mag_offset: None,
        mag_reference: None,
        ..full_imu_diagnostics()
    })
    .unwrap();
    for schema_name in ["estimate", "state", "reset-reply"] {
        let root = schema(schema_name);
        let validator = Validator { root: &root };
        let at = format!("{schema_name}.diagnostics.imu");
        let sub = root
            .pointer("/$defs/diagnostics/properties/imu")
            .unwrap_or_else(|| panic!("{schema_name}.schema.json describes diagnostics.imu"));
        errors.extend(validator.errors(sub, &imu, &at));
        validator.compare_required(sub, &imu, &at, &mut errors);
    }
    fail_on(errors);
}
