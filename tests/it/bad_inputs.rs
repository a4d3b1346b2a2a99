//! The table of bad inputs (`proto/bad-inputs.json`, readable in `proto/BAD_INPUTS.md`) against an
//! in-process [`Engine`] (no network):
//!
//! * the markdown table and the JSON agree row by row;
//! * every [`RejectCode`] an input or a reset can produce has at least one row ([`NOT_FROM_INPUTS`]
//!   lists, with the reason, the codes that cannot);
//! * every row, fed to an engine whose healthy vehicle is tracking, gives exactly one rejection with the
//!   row's code and a message, adds one to that code's health counter and to nothing else, and leaves
//!   the healthy vehicle's estimate, its counters and (checked with a probe measurement against a vehicle
//!   that never saw the row) its filter exactly as they were.
//!
//! The setup and the checks are described once, in `proto/BAD_INPUTS.md` ("How a row is tested");
//! `tests/python/test_bad_inputs.py` runs the same rows through the real binary over zenoh.
//!
//! A row with `propagated_to` is an update the filter refuses after its propagation to the set's time:
//! by the filters' contract (`filters::AttitudeFilter::process`) the filter stays propagated there, and
//! the row asserts exactly that (proto/BAD_INPUTS.md). There is no expected-failure marker: a row the
//! service gets wrong fails this test.

use crate::common::{collecting_engine, proto_dir, service_config, wait_until, Outputs};
use attitude_service::engine::{Engine, EngineThreads, Inbound, Ingest};
use attitude_service::query;
use attitude_service::service::Node;
use attitude_service::wire::keys::{route_of, ROUTES};
use attitude_service::wire::{
    decode_one, ErrorMsg, EstimateMsg, RejectCode, Rejection, ResetMsg, ResetReplyMsg,
};
use serde::Deserialize;
use serde_json::{json, Map, Value};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Key prefix of the engines of this test.
const PREFIX: &str = "bi";
/// The vehicle that tracks while the rows are sent (and the target of rows without `vehicle`).
const HEALTHY: &str = "healthy";
/// What the healthy vehicle is fed besides vector sets: gyro samples, or raw IMU samples (a vehicle
/// takes one or the other; proto/BAD_INPUTS.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Feed {
    Gyro,
    Imu,
}
/// Codes that no input and no reset request can produce, and why.
const NOT_FROM_INPUTS: &[(RejectCode, &str)] = &[
    (
        RejectCode::UnknownVehicle,
        "the error reply of a query (attitude, covariance, state) for a vehicle the service does not \
         know; an input creates its vehicle, and a reset of an unknown vehicle creates it or says why not",
    ),
    (
        RejectCode::Gap,
        "not a refusal: told when a gyro or raw-IMU sample after a gap in its stream was used (the \
         gap bridged and paid for in the covariance); no input is wrong, and the vehicle's filter \
         changes by design (the vehicle's tests in attitude-core check the event and its counts)",
    ),
    (
        RejectCode::Internal,
        "a failure inside the service (e.g. a reset its vehicle's worker did not answer within 10 s), \
         not something an input can be",
    ),
];

/// Codes decided by the vehicle, after the input's items were queued: the vehicle's `received` counts
/// them (proto/BAD_INPUTS.md). Every other code is decided before the queue.
const QUEUED_CODES: &[RejectCode] = &[
    RejectCode::OutOfOrder,
    RejectCode::Duplicate,
    RejectCode::TimeJump,
    RejectCode::MixedInputs,
    RejectCode::NotInitialized,
    RejectCode::FilterError,
];

/// One row of `proto/bad-inputs.json`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Row {
    id: String,
    case: String,
    leaf: String,
    /// The healthy vehicle's feed (`gyro`, `imu`) when it is not the row's leaf's.
    #[serde(default)]
    healthy: Option<String>,
    #[serde(default)]
    vehicle: Option<String>,
    #[serde(default)]
    payload: Option<String>,
    #[serde(default)]
    payload_hex: Option<String>,
    #[serde(default)]
    payload_gen: Option<Value>,
    /// Overrides of `service.limits`.
    #[serde(default)]
    config: Option<Map<String, Value>>,
    code: String,
    /// A refused update after the filter's propagation: the time (s) the filter and the vehicle stay
    /// propagated to.
    #[serde(default)]
    propagated_to: Option<f64>,
    /// `wrong`: the input goes on a routed key whose route is the vehicle's plus one.
    #[serde(default)]
    route: Option<String>,
    /// The DDS type name and type hash chunks of a ROS 2 row's key, when not its topic's.
    #[serde(default)]
    ros2_type: Option<String>,
    #[serde(default)]
    ros2_hash: Option<String>,
    /// No payload: zenoh reports this many puts of the key lost (proto/BAD_INPUTS.md, "Rows of
    /// samples missed").
    #[serde(default)]
    missed: Option<u64>,
}

/// The Jazzy type hashes of the ROS 2 rows' topics (as rosbags computes them; tests/python/test_ros2.py).
const IMU_HASH: &str = "RIHS01_7d9a00ff131080897a5ec7e26e315954b8eae3353c3f995c55faf71574000b5b";
const MAG_HASH: &str = "RIHS01_e80f32f56a20486c9923008fc1a1db07bbb273cbbf6a5b3bfa00835ee00e4dff";

impl Row {
    fn target(&self) -> &str {
        self.vehicle.as_deref().unwrap_or(HEALTHY)
    }

    fn is_reset(&self) -> bool {
        self.leaf == "reset"
    }

    /// The key a row's input is put on: `P/V/<leaf>`, or rmw_zenoh's key of the vehicle's ROS 2 topic.
    fn input_key(&self, vehicle: &str) -> String {
        let (topic, ty, hash) = match self.leaf.as_str() {
            "ros2_imu" => ("imu/data_raw", "sensor_msgs::msg::dds_::Imu_", IMU_HASH),
            "ros2_mag" => (
                "imu/mag",
                "sensor_msgs::msg::dds_::MagneticField_",
                MAG_HASH,
            ),
            leaf => {
                return match self.route.as_deref() {
                    None => format!("{PREFIX}/{vehicle}/{leaf}"),
                    Some("wrong") => format!(
                        "{PREFIX}/{vehicle}/{leaf}/{:x}",
                        (route_of(vehicle) + 1) % ROUTES as u8
                    ),
                    Some(other) => panic!("{}: route {other:?} (only \"wrong\")", self.id),
                }
            }
        };
        format!(
            "0/{vehicle}/{topic}/{}/{}",
            self.ros2_type.as_deref().unwrap_or(ty),
            self.ros2_hash.as_deref().unwrap_or(hash)
        )
    }

    /// The healthy vehicle's feed: the row's `healthy`, else IMU samples for the rows of leaf `imu`
    /// (and the ROS 2 rows).
    fn feed(&self) -> Feed {
        match (self.healthy.as_deref(), self.leaf.as_str()) {
            (Some("imu"), _) | (None, "imu" | "ros2_imu" | "ros2_mag") => Feed::Imu,
            _ => Feed::Gyro,
        }
    }

    fn config(&self) -> Map<String, Value> {
        self.config.clone().unwrap_or_default()
    }

    fn payload(&self) -> Vec<u8> {
        if self.missed.is_some() {
            assert!(
                self.payload.is_none() && self.payload_hex.is_none() && self.payload_gen.is_none(),
                "{}: a row of samples missed has no payload",
                self.id
            );
            return Vec::new();
        }
        match (&self.payload, &self.payload_hex, &self.payload_gen) {
            (Some(p), None, None) => p.as_bytes().to_vec(),
            (None, Some(h), None) => unhex(h),
            (None, None, Some(g)) => generate(g),
            _ => panic!(
                "{}: exactly one of payload, payload_hex, payload_gen",
                self.id
            ),
        }
    }
}

fn rows() -> Vec<Row> {
    let text = std::fs::read_to_string(proto_dir().join("bad-inputs.json")).unwrap();
    let rows: Vec<Row> =
        serde_json::from_str(&text).expect("proto/bad-inputs.json: an array of rows");
    let mut ids = BTreeSet::new();
    for r in &rows {
        assert!(ids.insert(r.id.clone()), "duplicate row id {}", r.id);
        assert!(
            !r.id.is_empty()
                && r.id
                    .bytes()
                    .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-'),
            "row id {:?}: lower case, digits and '-'",
            r.id
        );
        assert!(
            !r.case.is_empty() && !r.case.contains('|'),
            "{}: case",
            r.id
        );
        assert!(
            ["gyro", "vectors", "imu", "reset", "ros2_imu", "ros2_mag"].contains(&r.leaf.as_str()),
            "{}: leaf {:?} (gyro, vectors, imu, reset, ros2_imu, ros2_mag)",
            r.id,
            r.leaf
        );
        assert!(
            r.healthy
                .as_deref()
                .is_none_or(|h| ["gyro", "imu"].contains(&h)),
            "{}: healthy {:?} (gyro, imu)",
            r.id,
            r.healthy
        );
        assert!(
            code_of(&r.code).is_some(),
            "{}: unknown code {:?}",
            r.id,
            r.code
        );
        assert!(
            r.missed.is_none()
                || (r.code == "samples_missed"
                    && r.missed.is_some_and(|n| n > 0)
                    && ["gyro", "vectors", "imu"].contains(&r.leaf.as_str())
                    && r.vehicle.is_none()
                    && r.route.is_none()),
            "{}: missed rows are samples_missed of the healthy vehicle's own key, N > 0",
            r.id
        );
        if let Some(t) = r.propagated_to {
            assert!(
                r.code == "filter_error"
                    && r.leaf == "vectors"
                    && r.feed() == Feed::Gyro
                    && r.vehicle.is_none()
                    && t > 1.5
                    && t < 3.0
                    && serde_json::from_slice::<Value>(&r.payload()).unwrap()["t"].as_f64()
                        == Some(t),
                "{}: propagated_to is the time of a refused vector set of the healthy gyro-fed vehicle, \
                 after its time (1.5 s) and before the probe (3 s)",
                r.id
            );
        }
        let _ = r.payload();
    }
    rows
}

fn code_of(s: &str) -> Option<RejectCode> {
    RejectCode::ALL.iter().copied().find(|c| c.as_str() == s)
}

fn unhex(h: &str) -> Vec<u8> {
    assert!(h.len() % 2 == 0, "odd hex length: {h}");
    (0..h.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&h[i..i + 2], 16).expect("hex"))
        .collect()
}

/// The observations of the setup (consistent with the identity attitude).
const OBS: [&str; 2] = [
    r#"{"body": [1, 0, 0], "ref": [1, 0, 0], "sigma": 0.0001}"#,
    r#"{"body": [0, 1, 0], "ref": [0, 1, 0], "sigma": 0.0001}"#,
];

fn gyro(t: f64) -> String {
    format!(r#"{{"t": {t:?}, "omega": [0, 0, 0]}}"#)
}

fn vectors(t: f64) -> String {
    format!(r#"{{"t": {t:?}, "obs": [{}, {}]}}"#, OBS[0], OBS[1])
}

/// A raw IMU sample of the setup: at rest, level, facing north (the identity attitude in
/// East-North-Up), the field in µT.
fn imu(t: f64) -> String {
    format!(r#"{{"t": {t:?}, "gyr": [0, 0, 0], "acc": [0, 0, 9.81], "mag": [0, 15.6, -41.7]}}"#)
}

/// `payload_gen` (the rules are in proto/BAD_INPUTS.md).
fn generate(g: &Value) -> Vec<u8> {
    let num = |k: &str| {
        g[k].as_f64()
            .unwrap_or_else(|| panic!("payload_gen {g}: {k}"))
    };
    let n = || num("n") as usize;
    let text = match g["kind"].as_str() {
        Some("pad") => {
            let mut s = g["base"].as_str().expect("pad: base").to_string();
            let bytes = num("bytes") as usize;
            assert!(bytes >= s.len(), "pad: bytes < base");
            s.push_str(&" ".repeat(bytes - s.len()));
            s
        }
        Some("gyro_batch") => {
            let (t0, dt) = (num("t0"), num("dt"));
            let items: Vec<String> = (0..n()).map(|i| gyro(t0 + i as f64 * dt)).collect();
            format!("[{}]", items.join(", "))
        }
        Some("vectors_batch") => {
            let (t0, dt) = (num("t0"), num("dt"));
            let items: Vec<String> = (0..n()).map(|i| vectors(t0 + i as f64 * dt)).collect();
            format!("[{}]", items.join(", "))
        }
        Some("imu_batch") => {
            let (t0, dt) = (num("t0"), num("dt"));
            let items: Vec<String> = (0..n()).map(|i| imu(t0 + i as f64 * dt)).collect();
            format!("[{}]", items.join(", "))
        }
        Some("obs") => {
            let obs: Vec<&str> = (0..n()).map(|i| OBS[i % 2]).collect();
            format!(r#"{{"t": {:?}, "obs": [{}]}}"#, num("t"), obs.join(", "))
        }
        Some("nest") => {
            let d = num("depth") as usize;
            format!("{}{}", "[".repeat(d), "]".repeat(d))
        }
        _ => panic!("unknown payload_gen {g}"),
    };
    text.into_bytes()
}

// ------------------------------------------------------------------------------------------------
// (a) and (b)

#[test]
fn markdown_table_and_json_agree() {
    let rows = rows();
    let md = std::fs::read_to_string(proto_dir().join("BAD_INPUTS.md")).unwrap();
    let section = |title: &str| -> Vec<String> {
        let start = md
            .find(&format!("\n## {title}\n"))
            .unwrap_or_else(|| panic!("proto/BAD_INPUTS.md has a section ## {title}"));
        let rest = &md[start + title.len() + 5..];
        let end = rest.find("\n## ").unwrap_or(rest.len());
        rest[..end].lines().map(str::to_string).collect()
    };
    let table: Vec<String> = section("Rows")
        .into_iter()
        .filter(|l| l.starts_with("| `"))
        .collect();
    let expected: Vec<String> = rows
        .iter()
        .map(|r| format!("| `{}` | {} | `{}` | `{}` |", r.id, r.case, r.leaf, r.code))
        .collect();
    let mut problems = vec![];
    for (i, want) in expected.iter().enumerate() {
        match table.get(i) {
            Some(got) if got == want => {}
            Some(got) => problems.push(format!("line {}: has\n  {got}\nwant\n  {want}", i + 1)),
            None => problems.push(format!("missing line {}:\n  {want}", i + 1)),
        }
    }
    for extra in table.iter().skip(expected.len()) {
        problems.push(format!("a line without a JSON row:\n  {extra}"));
    }
    if md.contains("known_issue") || md.contains("\n## Known issues") {
        problems.push(
            "proto/BAD_INPUTS.md speaks of known issues: no row is an expected failure (a row asserts \
             the contract, and the test fails when the service does not keep it)"
                .into(),
        );
    }
    assert!(
        problems.is_empty(),
        "proto/BAD_INPUTS.md and proto/bad-inputs.json disagree:\n{}",
        problems.join("\n")
    );
}

#[test]
fn every_input_code_has_a_row() {
    let rows = rows();
    let used: BTreeSet<&str> = rows.iter().map(|r| r.code.as_str()).collect();
    let mut problems = vec![];
    for code in RejectCode::ALL {
        let excused = NOT_FROM_INPUTS.iter().any(|(c, _)| *c == code);
        match (used.contains(code.as_str()), excused) {
            (false, false) => problems.push(format!(
                "no row of proto/bad-inputs.json has code `{}`: add one (and its line in proto/BAD_INPUTS.md), \
                 or list the code in NOT_FROM_INPUTS with the reason no input can produce it",
                code.as_str()
            )),
            (true, true) => problems.push(format!(
                "`{}` is in NOT_FROM_INPUTS but a row produces it",
                code.as_str()
            )),
            _ => {}
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

// ------------------------------------------------------------------------------------------------
// (c) every row against an engine

/// An engine with a sink that collects `(key, payload)`.
struct Run {
    node: Node,
    engine: Arc<Engine>,
    threads: Option<EngineThreads>,
    out: Outputs,
}

impl Run {
    /// A configuration file as the service reads it: the MEKF, default limits but `limits`.
    fn start(limits: &Map<String, Value>) -> Run {
        let text = json!({
            "service": {
                "key_prefix": PREFIX,
                "filter": {"kind": "mekf"},
                "workers": 2,
                "limits": limits,
                // (The ROS 2 rows' inputs; the edge changes nothing for the others.)
                "ros2": {"enabled": true},
            }
        })
        .to_string();
        let (node, threads, out) = collecting_engine(service_config(&text));
        Run {
            engine: node.engine.clone(),
            node,
            threads: Some(threads),
            out,
        }
    }

    fn put(&self, vehicle: &str, leaf: &str, payload: impl Into<Vec<u8>>) {
        self.put_on(&format!("{PREFIX}/{vehicle}/{leaf}"), payload);
    }

    fn put_on(&self, key: &str, payload: impl Into<Vec<u8>>) {
        self.engine.dispatch(Inbound {
            key: key.to_string(),
            payload: payload.into(),
        });
    }

    fn outputs(&self) -> Vec<(String, Vec<u8>)> {
        self.out.lock().unwrap().clone()
    }

    fn rejections_since(&self, n: usize) -> Vec<(String, ErrorMsg)> {
        self.outputs()
            .into_iter()
            .skip(n)
            .filter(|(k, _)| k.ends_with("/rejected"))
            .map(|(k, p)| {
                (
                    k,
                    serde_json::from_slice::<ErrorMsg>(&p).expect("a rejection is an ErrorMsg"),
                )
            })
            // (A `gap` is told on the same key but is no refusal: the probe comes after one.)
            .filter(|(_, m)| m.code != "gap")
            .collect()
    }

    fn wait(&self, timeout: Duration, mut done: impl FnMut(&Run) -> bool) -> bool {
        wait_until("a condition of the bad-input run", timeout, || done(self)).is_ok()
    }

    fn estimate(&self) -> Option<EstimateMsg> {
        query::state_of(&self.engine, HEALTHY)
            .ok()
            .map(|e| (*e).clone())
    }

    /// The healthy vehicle of the setup, tracking at time 1.5 s: fed gyro samples, its estimate at 1 s
    /// with seq 2; fed IMU samples, at 1.5 s with seq 15 (one per sample from the alignment at 0.1 s).
    fn init_healthy(&self, feed: Feed) {
        if feed == Feed::Imu {
            for i in 0..=15 {
                self.put(HEALTHY, "imu", imu(i as f64 / 10.0));
            }
            let ok = self.wait(Duration::from_secs(10), |r| {
                r.estimate().is_some_and(|e| e.seq == 15 && e.t == 1.5)
                    && r.engine.vehicle(HEALTHY).is_some_and(|v| {
                        let i = v.info();
                        i.processed == 16 && i.t == Some(1.5)
                    })
            });
            assert!(
                ok,
                "the healthy IMU vehicle did not start: {:?}",
                self.rejections_since(0)
            );
            assert!(self.rejections_since(0).is_empty());
            return;
        }
        self.put(HEALTHY, "gyro", gyro(0.0));
        self.put(HEALTHY, "vectors", vectors(0.0));
        for i in 1..=10 {
            self.put(HEALTHY, "gyro", gyro(i as f64 / 10.0));
        }
        self.put(HEALTHY, "vectors", vectors(1.0));
        self.put(HEALTHY, "gyro", gyro(1.5));
        let ok = self.wait(Duration::from_secs(10), |r| {
            r.estimate().is_some_and(|e| e.seq == 2)
                && r.engine.vehicle(HEALTHY).is_some_and(|v| {
                    let i = v.info();
                    i.processed == 14 && i.t == Some(1.5)
                })
        });
        assert!(
            ok,
            "the healthy vehicle did not start: {:?}",
            self.rejections_since(0)
        );
        assert!(self.rejections_since(0).is_empty());
    }

    /// A gyro sample and a vector set at t = 3 s (an IMU sample for an IMU vehicle); the estimate they
    /// give.
    fn probe(&self, feed: Feed) -> Result<EstimateMsg, String> {
        match feed {
            Feed::Gyro => {
                self.put(HEALTHY, "gyro", gyro(3.0));
                self.put(HEALTHY, "vectors", vectors(3.0));
            }
            Feed::Imu => self.put(HEALTHY, "imu", imu(3.0)),
        }
        if self.wait(Duration::from_secs(10), |r| {
            r.estimate().is_some_and(|e| e.t == 3.0)
        }) {
            Ok(self.estimate().unwrap())
        } else {
            Err(format!(
                "the probe gave no estimate at t = 3 (estimate {:?})",
                self.estimate().map(|e| (e.t, e.seq))
            ))
        }
    }

    /// What the service's reset queryable does (`service::queryables`' `reset`): a concrete vehicle, the payload
    /// decoded with the input limits, `Engine::request_reset`, the worker's answer; a refusal is counted.
    fn reset(&self, vehicle: &str, payload: &[u8]) -> Result<ResetReplyMsg, Rejection> {
        let key = format!("{PREFIX}/{vehicle}/reset");
        let result = (|| {
            let (v, _) = self
                .engine
                .keys
                .split(&key)
                .filter(|(v, _)| !v.contains(['*', '$']))
                .ok_or_else(|| {
                    Rejection::new(RejectCode::BadRequest, "reset one vehicle at a time")
                })?;
            let req: ResetMsg = if payload.is_empty() {
                ResetMsg::default()
            } else {
                decode_one(payload, &self.engine.config.limits.input)?
            };
            let mut rx = self.engine.request_reset(v, req)?;
            let mut answer = None;
            let _ = wait_until("the reset's answer", Duration::from_secs(10), || {
                match rx.try_recv() {
                    Ok(r) => answer = Some(r),
                    Err(tokio::sync::oneshot::error::TryRecvError::Empty) => return false,
                    Err(tokio::sync::oneshot::error::TryRecvError::Closed) => {}
                }
                true
            });
            answer.unwrap_or_else(|| {
                Err(Rejection::new(
                    RejectCode::Internal,
                    "no answer to the reset",
                ))
            })
        })();
        if let Err(r) = &result {
            self.engine.counters.reject(r.code);
        }
        result
    }

    /// Stops the threads after processing everything accepted.
    fn shutdown(&mut self) {
        if let Some(t) = self.threads.take() {
            t.shutdown();
        }
    }
}

impl Drop for Run {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// The probe's estimate on a vehicle that never saw a bad input.
fn baseline(limits: &Map<String, Value>, feed: Feed) -> EstimateMsg {
    let mut run = Run::start(limits);
    run.init_healthy(feed);
    let e = run.probe(feed).expect("the baseline probe");
    run.shutdown();
    e
}

fn without_rejected(e: &EstimateMsg) -> EstimateMsg {
    let mut e = e.clone();
    e.diagnostics.rejected.clear();
    // The bookkeeping of a refused input is not filter state: a rolled-back step is counted, and the
    // gate saw its observations before the update failed.
    e.diagnostics.rollbacks = 0;
    e.diagnostics.gate.clear();
    e
}

/// Runs one row; returns what did not hold.
fn check(row: &Row, baselines: &mut HashMap<(String, Feed), EstimateMsg>) -> Vec<String> {
    let limits = row.config();
    let feed = row.feed();
    let key = (Value::Object(limits.clone()).to_string(), feed);
    let base = baselines
        .entry(key)
        .or_insert_with(|| baseline(&limits, feed))
        .clone();
    let code = row.code.as_str();
    let target = row.target();
    let mut run = Run::start(&limits);
    run.init_healthy(feed);

    let s0 = run.estimate().expect("tracking");
    let info0 = run.engine.vehicle(HEALTHY).unwrap().info();
    let h0 = run.node.health();
    let existed = run.engine.vehicle(target).is_some();
    let n0 = run.outputs().len();
    let mut fails = vec![];

    if row.is_reset() {
        match run.reset(target, &row.payload()) {
            Ok(reply) => fails.push(format!(
                "the reset was accepted: state {}, filter {}",
                reply.state, reply.filter
            )),
            Err(r) => {
                if r.code.as_str() != code {
                    fails.push(format!(
                        "reset refused with {} ({}), not {code}",
                        r.code.as_str(),
                        r.message
                    ));
                }
                if r.message.is_empty() {
                    fails.push("empty message".into());
                }
            }
        }
    } else {
        match row.missed {
            // What the service's advanced subscriber hands the engine when zenoh reports the loss.
            Some(count) => run.engine.dispatch_item(Ingest::Missed {
                key: row.input_key(target),
                count,
                source: "bad-inputs/0".into(),
            }),
            None => run.put_on(&row.input_key(target), row.payload()),
        }
        run.wait(Duration::from_secs(10), |r| {
            !r.rejections_since(n0).is_empty()
        });
    }

    // Right after the row: the healthy vehicle's estimate, its row, the counters.
    let s1 = run.estimate();
    let info1 = run.engine.vehicle(HEALTHY).unwrap().info();
    let h1 = run.node.health();
    if s1.as_ref() != Some(&s0) {
        fails.push(format!(
            "the healthy vehicle's estimate changed: t {} seq {} -> {:?}",
            s0.t,
            s0.seq,
            s1.map(|e| (e.t, e.seq))
        ));
    }
    let own_input = target == HEALTHY && !row.is_reset();
    let want_rejected = info0.rejected + u64::from(own_input);
    // The rows' inputs that reach the filter are single items.
    let queued = code_of(code).is_some_and(|c| QUEUED_CODES.contains(&c));
    let want_received = info0.received + u64::from(own_input && queued);
    // A refused update after the propagation: the filter, hence the vehicle's time, stays there.
    let want_t = row.propagated_to.or(info0.t);
    if (
        info1.t,
        info1.received,
        info1.processed,
        info1.rejected,
        &info1.state,
        &info1.filter,
    ) != (
        want_t,
        want_received,
        info0.processed,
        want_rejected,
        &info0.state,
        &info0.filter,
    ) {
        fails.push(format!(
            "the healthy vehicle's P/@/vehicles row: t {:?} received {} processed {} rejected {} {} {} -> \
             t {:?} received {} processed {} rejected {} {} {} (want t {want_t:?}, received \
             {want_received}, rejected {want_rejected}; a code decided by the filter after the queue belongs in QUEUED_CODES)",
            info0.t, info0.received, info0.processed, info0.rejected, info0.state, info0.filter,
            info1.t, info1.received, info1.processed, info1.rejected, info1.state, info1.filter,
        ));
    }
    let delta: BTreeMap<&String, i64> = h0
        .rejected
        .keys()
        .chain(h1.rejected.keys())
        .map(|k| {
            let d =
                *h1.rejected.get(k).unwrap_or(&0) as i64 - *h0.rejected.get(k).unwrap_or(&0) as i64;
            (k, d)
        })
        .filter(|(_, d)| *d != 0)
        .collect();
    let want_delta: BTreeMap<&String, i64> = [(&row.code, 1)].into_iter().collect();
    if delta != want_delta {
        fails.push(format!(
            "P/@/health rejected grew by {delta:?}, want {{{code}: 1}}"
        ));
    }
    if target != HEALTHY
        && !existed
        && code != "not_initialized"
        && run.engine.vehicle(target).is_some()
    {
        fails.push(format!("the refused input created vehicle {target}"));
    }

    // The probe: the filter is the one a vehicle that never saw the row has.
    match run.probe(feed) {
        Ok(p) => {
            // A refused update after the propagation to T keeps that propagation (the contract): the
            // probe then propagates from T, one propagation more than the baseline's, from which it
            // differs in nothing else (a zero rate: the split propagation is the same to the bit).
            let want_propagations =
                base.diagnostics.propagations + u64::from(row.propagated_to.is_some());
            if p.diagnostics.propagations != want_propagations {
                fails.push(format!(
                    "diagnostics.propagations of the probe's estimate is {}, want {want_propagations}",
                    p.diagnostics.propagations
                ));
            }
            let mut p = p;
            p.diagnostics.propagations = base.diagnostics.propagations;
            // The puts zenoh reported missed are counted in the vehicle's diagnostics.
            let want_missed = row.missed.unwrap_or(0);
            if p.diagnostics.missed != want_missed {
                fails.push(format!(
                    "diagnostics.missed of the probe's estimate is {}, want {want_missed}",
                    p.diagnostics.missed
                ));
            }
            p.diagnostics.missed = base.diagnostics.missed;
            if without_rejected(&p) != without_rejected(&base) {
                fails.push(format!(
                    "the probe's estimate differs from a vehicle that never saw the row: seq {} vs {}, \
                     t {} vs {}, q {:?} vs {:?}, diagnostics {:?} vs {:?}",
                    p.seq, base.seq, p.t, base.t, p.q, base.q, p.diagnostics, base.diagnostics
                ));
            }
            // A refused filter step is rolled back and counted (the vehicle stays healthy).
            let want_rollbacks =
                base.diagnostics.rollbacks + u64::from(own_input && code == "filter_error");
            if p.diagnostics.rollbacks != want_rollbacks {
                fails.push(format!(
                    "diagnostics.rollbacks of the probe's estimate is {}, want {want_rollbacks}",
                    p.diagnostics.rollbacks
                ));
            }
            let want: BTreeMap<String, u64> = if own_input {
                [(row.code.clone(), 1)].into_iter().collect()
            } else {
                BTreeMap::new()
            };
            if p.diagnostics.rejected != want {
                fails.push(format!(
                    "diagnostics.rejected of the probe's estimate is {:?}, want {want:?}",
                    p.diagnostics.rejected
                ));
            }
        }
        Err(e) => fails.push(e),
    }
    run.shutdown();

    // Everything published since the row (the threads have stopped: nothing more comes).
    let rejections = run.rejections_since(n0);
    if row.is_reset() {
        if !rejections.is_empty() {
            fails.push(format!("a reset published rejections: {rejections:?}"));
        }
    } else {
        let input_key = row.input_key(target);
        match rejections.as_slice() {
            [(k, m)] => {
                if *k != format!("{PREFIX}/{target}/rejected") {
                    fails.push(format!("rejection published on {k}"));
                }
                if m.code != code {
                    fails.push(format!(
                        "rejected with {} ({}), not {code}",
                        m.code, m.message
                    ));
                }
                if m.message.is_empty() {
                    fails.push("empty message".into());
                }
                if m.key != input_key {
                    fails.push(format!("the rejection's key is {}, not {input_key}", m.key));
                }
            }
            other => fails.push(format!(
                "{} rejections, want exactly one: {:?}",
                other.len(),
                other
                    .iter()
                    .map(|(_, m)| (&m.code, &m.message))
                    .collect::<Vec<_>>()
            )),
        }
    }
    fails
}

#[test]
fn every_row_is_refused_counted_and_changes_nothing() {
    let rows = rows();
    let only = std::env::var("BAD_INPUTS_ROW").ok();
    let mut baselines = HashMap::new();
    let mut problems = vec![];
    let t0 = Instant::now();
    for row in rows
        .iter()
        .filter(|r| only.as_ref().is_none_or(|o| *o == r.id))
    {
        let started = Instant::now();
        let fails = check(row, &mut baselines);
        let took = started.elapsed().as_secs_f64() * 1e3;
        if fails.is_empty() {
            println!("ok    {:45} {:20} {took:7.1} ms", row.id, row.code);
        } else {
            println!("FAIL  {:45} {:20} {took:7.1} ms", row.id, row.code);
            problems.push(format!("{} ({}): {}", row.id, row.case, fails.join("; ")));
        }
    }
    println!("{} rows in {:.1} s", rows.len(), t0.elapsed().as_secs_f64());
    assert!(
        problems.is_empty(),
        "{} rows failed:\n{}",
        problems.len(),
        problems.join("\n")
    );
}
