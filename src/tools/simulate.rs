//! `attitude-service simulate`: publishes the simulator's scenarios for N vehicles to a running
//! service over zenoh, in real time or faster, with the truth on `P/V/truth`.

use super::publish::{Inputs, Publishing};
use crate::filters::FilterSpec;
use crate::fleet::sender::{RoutedSender, FLUSH_S};
use crate::rng::derive_seed;
use crate::sensors::Measurement;
use crate::sim::{simulate as simulate_run, ScenarioParams, SimulatedRun};
use crate::wire::keys::{Keys, Leaf};
use crate::wire::{
    GyroMsg, ObservationMsg, PerAxis, QuaternionMsg, ResetMsg, ResetReplyMsg, TruthMsg, VectorsMsg,
};
use std::time::{Duration, Instant};
use thiserror::Error;
use tokio_util::sync::CancellationToken;
use zenoh::bytes::Encoding;
use zenoh::key_expr::KeyExpr;
use zenoh::query::ConsolidationMode;

#[derive(Debug, Error)]
pub enum SimulateError {
    #[error("zenoh: {0}")]
    Zenoh(String),
    #[error("reset of {vehicle} refused: {message}")]
    Reset { vehicle: String, message: String },
    #[error(
        "no reply to the reset of {vehicle}: is a service running with key prefix '{prefix}'?"
    )]
    NoService { vehicle: String, prefix: String },
}

/// What to simulate.
#[derive(Clone, Debug)]
pub struct SimulateOptions {
    pub scenario: ScenarioParams,
    pub vehicles: usize,
    /// Vehicle ids are `<vehicle_prefix><n>`, n = 1..=vehicles.
    pub vehicle_prefix: String,
    /// Filters assigned round-robin by a reset before streaming; empty keeps the service's default.
    pub filters: Vec<FilterSpec>,
    pub particles: Option<usize>,
    /// Sparse-grid level of the SGHQF vehicles.
    pub level: Option<u8>,
    /// Simulated seconds per wall-clock second; 0 publishes as fast as possible.
    pub speed: f64,
    pub seed: u64,
    /// Send each vehicle a reset with the scenario's initial estimate before streaming (an operator
    /// who knows roughly where the vehicle points); without it the service initialises itself.
    pub reset: bool,
    /// Inputs on their routed keys, and batched for the routes' standby members
    /// (`super::routed`).
    pub routed: bool,
    /// How the inputs on their plain keys are put ([`super::publish`]: advanced publishers by default).
    pub publishing: Publishing,
}

/// What was published.
#[derive(Clone, Debug, Default)]
pub struct SimulateStats {
    pub vehicles: usize,
    pub gyro_messages: u64,
    pub vector_messages: u64,
    pub truth_messages: u64,
    pub sim_time_s: f64,
    pub wall_s: f64,
}

fn zerr(e: impl std::fmt::Display) -> SimulateError {
    SimulateError::Zenoh(e.to_string())
}

pub fn vehicle_ids(options: &SimulateOptions) -> Vec<String> {
    (1..=options.vehicles)
        .map(|n| format!("{}{n}", options.vehicle_prefix))
        .collect()
}

/// The reset a vehicle gets before its stream: its filter and the scenario's initial estimate.
pub fn reset_request(options: &SimulateOptions, index: usize, run: &SimulatedRun) -> ResetMsg {
    let spec =
        (!options.filters.is_empty()).then(|| options.filters[index % options.filters.len()]);
    let init = &run.initial;
    let sigma = init.sigma_att_rad.map(f64::to_degrees);
    let t0 = run.truth.first().map(|s| s.t_s);
    ResetMsg {
        filter: spec.map(|s| s.kind.as_str().to_string()),
        fiducial: spec
            .and_then(|s| s.fiducial)
            .map(|f| f.as_str().to_string()),
        particles: options
            .particles
            .filter(|_| spec.is_none_or(|s| s.kind == crate::filters::FilterKind::Qpf)),
        level: options
            .level
            .filter(|_| spec.is_none_or(|s| s.kind == crate::filters::FilterKind::Sghqf))
            .map(u64::from),
        // A uniformly random initial attitude is not known: the service initialises from vectors.
        q: (!init.uniform_attitude).then(|| QuaternionMsg::from_domain(&init.q)),
        sigma_deg: (!init.uniform_attitude)
            .then_some(PerAxis::Three([sigma[0], sigma[1], sigma[2]])),
        bias: (!init.uniform_attitude).then_some([
            init.bias_rad_s[0],
            init.bias_rad_s[1],
            init.bias_rad_s[2],
        ]),
        bias_sigma: Some(PerAxis::Three([
            init.bias_sigma_rad_s[0],
            init.bias_sigma_rad_s[1],
            init.bias_sigma_rad_s[2],
        ])),
        t: t0,
        sensor: None,
    }
}

async fn send_reset(
    session: &zenoh::Session,
    keys: &Keys,
    vehicle: &str,
    req: &ResetMsg,
) -> Result<ResetReplyMsg, SimulateError> {
    let payload = serde_json::to_vec(req).map_err(zerr)?;
    let replies = session
        .get(keys.vehicle(vehicle, Leaf::Reset))
        .payload(payload)
        .encoding(Encoding::APPLICATION_JSON)
        .consolidation(ConsolidationMode::None)
        .timeout(Duration::from_secs(10))
        .await
        .map_err(zerr)?;
    match replies.recv_async().await {
        Ok(reply) => match reply.result() {
            Ok(sample) => serde_json::from_slice(&sample.payload().to_bytes()).map_err(zerr),
            Err(e) => Err(SimulateError::Reset {
                vehicle: vehicle.to_string(),
                message: String::from_utf8_lossy(&e.payload().to_bytes()).into_owned(),
            }),
        },
        Err(_) => Err(SimulateError::NoService {
            vehicle: vehicle.to_string(),
            prefix: keys.prefix().to_string(),
        }),
    }
}

fn gyro_msg(m: &Measurement) -> Option<Vec<u8>> {
    let Measurement::Gyro(g) = m else { return None };
    let w = g.omega_body_rad_s;
    serde_json::to_vec(&GyroMsg {
        t: g.t_s,
        omega: [w[0], w[1], w[2]],
    })
    .ok()
}

fn vectors_msg(m: &Measurement) -> Option<Vec<u8>> {
    let Measurement::Vectors(set) = m else {
        return None;
    };
    let obs = set
        .observations
        .iter()
        .map(|o| ObservationMsg {
            body: [o.body[0], o.body[1], o.body[2]],
            reference: [o.reference[0], o.reference[1], o.reference[2]],
            sigma: o.sigma,
            sensor: o.sensor.clone(),
        })
        .collect();
    serde_json::to_vec(&VectorsMsg { t: set.t_s, obs }).ok()
}

/// Publishes the scenario for every vehicle until the run ends or `stop` is cancelled (between two
/// time steps: a step is published for every vehicle or for none).
pub async fn simulate(
    session: &zenoh::Session,
    keys: &Keys,
    options: &SimulateOptions,
    stop: &CancellationToken,
) -> Result<SimulateStats, SimulateError> {
    let ids = vehicle_ids(options);
    let runs: Vec<SimulatedRun> = (0..options.vehicles)
        .map(|i| simulate_run(&options.scenario, derive_seed(options.seed, i as u64)))
        .collect();
    if options.reset {
        for (i, (id, run)) in ids.iter().zip(&runs).enumerate() {
            send_reset(session, keys, id, &reset_request(options, i, run)).await?;
        }
    }
    let dt = options.scenario.dt_gyro_s;
    let mut stats = SimulateStats {
        vehicles: ids.len(),
        ..Default::default()
    };
    let start = Instant::now();
    let t0 = runs
        .first()
        .and_then(|r| r.truth.first())
        .map(|s| s.t_s)
        .unwrap_or(0.0);
    let steps = runs.iter().map(|r| r.measurements.len()).min().unwrap_or(0);
    let routed = options
        .routed
        .then(|| RoutedSender::start(session, keys, Duration::from_secs_f64(FLUSH_S)));
    let inputs = Inputs::new(session, options.publishing.clone());
    // An input: on its routed key (and batched) or its plain key.
    let input = |id: &str, leaf: Leaf, payload: Vec<u8>| {
        let (routed, id, inputs) = (routed.as_ref(), id.to_string(), &inputs);
        async move {
            match routed {
                Some(r) => r.put(&id, leaf, &r.key(&id, leaf)?, payload).await,
                None => {
                    inputs
                        .put(&KeyExpr::try_from(keys.vehicle(&id, leaf))?, payload)
                        .await
                }
            }
        }
    };
    for j in 0..steps {
        let t = runs[0].measurements[j].t_s();
        let due = (options.speed > 0.0)
            .then(|| start + Duration::from_secs_f64(((t - t0) / options.speed).max(0.0)));
        tokio::select! {
            biased;
            _ = stop.cancelled() => break,
            _ = async {
                if let Some(due) = due {
                    tokio::time::sleep_until(due.into()).await;
                }
            } => {}
        }
        for (id, run) in ids.iter().zip(&runs) {
            let m = &run.measurements[j];
            if let Some(p) = gyro_msg(m) {
                input(id, Leaf::Gyro, p).await.map_err(zerr)?;
                stats.gyro_messages += 1;
            } else if let Some(p) = vectors_msg(m) {
                let k = ((m.t_s() - t0) / dt).round().max(0.0) as usize;
                if let Some(truth) = run.truth.get(k) {
                    let b = truth.bias_rad_s;
                    let msg = TruthMsg {
                        vehicle: id.clone(),
                        t: truth.t_s,
                        q: QuaternionMsg::from_domain(&truth.q),
                        bias: [b[0], b[1], b[2]],
                    };
                    if let Ok(tp) = serde_json::to_vec(&msg) {
                        // Like the inputs (an advanced publisher with a cache by default): a
                        // subscriber this session reaches only once gossip has connected them (a
                        // viewer beside the service) recovers the truths put before.
                        let key = KeyExpr::try_from(keys.vehicle(id, Leaf::Truth)).map_err(zerr)?;
                        inputs.put(&key, tp).await.map_err(zerr)?;
                        stats.truth_messages += 1;
                    }
                }
                input(id, Leaf::Vectors, p).await.map_err(zerr)?;
                stats.vector_messages += 1;
            }
        }
        stats.sim_time_s = t - t0;
    }
    if let Some(r) = routed {
        r.close().await;
    }
    stats.wall_s = start.elapsed().as_secs_f64();
    Ok(stats)
}
