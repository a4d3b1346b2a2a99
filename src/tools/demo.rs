//! `attitude-service demo`: the service and simulated spacecraft in one process, talking over real
//! zenoh (two sessions on a loopback TCP link), with a live table of every vehicle's estimation error
//! against the simulated truth.

use super::simulate::{simulate, SimulateError, SimulateOptions, SimulateStats};
use crate::attitude::Quaternion;
use crate::service::config::ServiceConfig;
use crate::wire::keys::{Keys, Leaf};
use crate::wire::{EstimateMsg, QuaternionMsg, TruthMsg};
use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use thiserror::Error;
use tokio_util::sync::CancellationToken;

#[derive(Debug, Error)]
pub enum DemoError {
    #[error("zenoh: {0}")]
    Zenoh(String),
    #[error(transparent)]
    Simulate(#[from] SimulateError),
    #[error("the service did not come up on {0}")]
    NoService(String),
}

fn zerr(e: impl std::fmt::Display) -> DemoError {
    DemoError::Zenoh(e.to_string())
}

/// One row of the live table.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Row {
    pub vehicle: String,
    pub filter: String,
    pub t_s: f64,
    /// Attitude error against the truth at the estimate's time, deg.
    pub error_deg: Option<f64>,
    /// Largest per-axis 3σ of the estimate, deg.
    pub three_sigma_deg: f64,
    pub ess: Option<f64>,
    pub estimates: u64,
}

#[derive(Default)]
struct Live {
    truth: HashMap<String, BTreeMap<i64, QuaternionMsg>>,
    rows: BTreeMap<String, Row>,
}

fn time_key(t: f64) -> i64 {
    (t * 1e6).round() as i64
}

impl Live {
    fn on_truth(&mut self, t: TruthMsg) {
        let h = self.truth.entry(t.vehicle).or_default();
        h.insert(time_key(t.t), t.q);
        while h.len() > 4096 {
            h.pop_first();
        }
    }

    fn on_estimate(&mut self, e: EstimateMsg) {
        let error_deg = self
            .truth
            .get(&e.vehicle)
            .and_then(|h| h.get(&time_key(e.t)))
            .and_then(|q| {
                let truth = q.to_domain().ok()?;
                let est = e.q.to_domain().ok()?;
                Some(truth.compose(&est.inverse()).angle().to_degrees())
            });
        let filter = match &e.fiducial {
            Some(f) => format!("{}:{f}", e.filter),
            None => e.filter.clone(),
        };
        let three_sigma_deg = 3.0 * e.sigma_deg.iter().cloned().fold(0.0, f64::max);
        self.rows.insert(
            e.vehicle.clone(),
            Row {
                vehicle: e.vehicle,
                filter,
                t_s: e.t,
                error_deg,
                three_sigma_deg,
                ess: e.diagnostics.ess,
                estimates: e.seq,
            },
        );
    }
}

fn angle(deg: f64) -> String {
    if deg < 1.0 / 60.0 {
        format!("{:.2}″", deg * 3600.0)
    } else if deg < 1.0 {
        format!("{:.2}′", deg * 60.0)
    } else {
        format!("{deg:.2}°")
    }
}

/// The table as text.
pub fn render(rows: &[Row], stats: Option<&SimulateStats>) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:<10} {:<17} {:>9} {:>11} {:>11} {:>9} {:>9}  {}",
        "vehicle", "filter", "t (s)", "error", "3σ", "ESS", "estimates", "within 3σ"
    );
    for r in rows {
        let err = r.error_deg.map(angle).unwrap_or_else(|| "—".into());
        let within = match r.error_deg {
            Some(e) if e <= r.three_sigma_deg => "yes",
            Some(_) => "NO",
            None => "",
        };
        let _ = writeln!(
            s,
            "{:<10} {:<17} {:>9.0} {:>11} {:>11} {:>9} {:>9}  {}",
            r.vehicle,
            r.filter,
            r.t_s,
            err,
            angle(r.three_sigma_deg),
            r.ess
                .map(|e| format!("{e:.0}"))
                .unwrap_or_else(|| "—".into()),
            r.estimates,
            within
        );
    }
    if let Some(st) = stats {
        let _ = writeln!(
            s,
            "\n{} vehicles, {:.0} s simulated in {:.1} s; {} gyro and {} vector messages published",
            st.vehicles, st.sim_time_s, st.wall_s, st.gyro_messages, st.vector_messages
        );
    }
    s
}

/// Runs the demo. `endpoint` is where the in-process service listens and the simulator connects;
/// `interactive` redraws the table in place (a terminal), otherwise it is printed every few seconds.
/// Cancelling `stop` ends the simulation early; the demo then ends as after a whole run (the last
/// estimates, the service's shutdown, the final table).
pub async fn demo(
    zenoh_service_json: &str,
    endpoint: &str,
    service: ServiceConfig,
    options: SimulateOptions,
    interactive: bool,
    stop: CancellationToken,
) -> Result<(Vec<Row>, SimulateStats), DemoError> {
    let keys = Keys::new(&service.key_prefix);
    let mut service_config = zenoh::Config::from_json5(zenoh_service_json).map_err(zerr)?;
    service_config
        .insert_json5(
            "listen/endpoints",
            &serde_json::json!([endpoint]).to_string(),
        )
        .map_err(zerr)?;
    let service_session = zenoh::open(service_config).await.map_err(zerr)?;
    // The in-process service stops after the simulation, not with it (not a child of `stop`), so
    // that the last estimates still arrive; on an early return too (the guard).
    let service_stop = CancellationToken::new();
    let _stop_service_on_return = service_stop.clone().drop_guard();
    let service_task = tokio::spawn(crate::service::run(
        service_session,
        service,
        service_stop.clone().cancelled_owned(),
    ));

    let client_json = serde_json::json!({
        "mode": "peer",
        "connect": {"endpoints": [endpoint]},
        "listen": {"endpoints": []},
        "scouting": {"multicast": {"enabled": false}},
    });
    let client = zenoh::open(zenoh::Config::from_json5(&client_json.to_string()).map_err(zerr)?)
        .await
        .map_err(zerr)?;
    wait_for_service(&client, &keys, endpoint).await?;

    let live = Arc::new(Mutex::new(Live::default()));
    let l = live.clone();
    let _truth = client
        .declare_subscriber(keys.all(Leaf::Truth))
        .callback(move |s: zenoh::sample::Sample| {
            if let Ok(t) = serde_json::from_slice::<TruthMsg>(&s.payload().to_bytes()) {
                l.lock().unwrap_or_else(|e| e.into_inner()).on_truth(t);
            }
        })
        .await
        .map_err(zerr)?;
    let l = live.clone();
    let _estimates = client
        .declare_subscriber(keys.all(Leaf::Estimate))
        .callback(move |s: zenoh::sample::Sample| {
            if let Ok(e) = serde_json::from_slice::<EstimateMsg>(&s.payload().to_bytes()) {
                l.lock().unwrap_or_else(|e| e.into_inner()).on_estimate(e);
            }
        })
        .await
        .map_err(zerr)?;

    let sim = {
        let client = client.clone();
        let keys = keys.clone();
        tokio::spawn(async move { simulate(&client, &keys, &options, &stop).await })
    };
    let rows = |live: &Mutex<Live>| -> Vec<Row> {
        live.lock()
            .unwrap_or_else(|e| e.into_inner())
            .rows
            .values()
            .cloned()
            .collect()
    };
    let period = if interactive {
        Duration::from_millis(500)
    } else {
        Duration::from_secs(5)
    };
    let mut tick = tokio::time::interval(period);
    while !sim.is_finished() {
        tick.tick().await;
        let table = render(&rows(&live), None);
        if interactive {
            print!("\x1b[2J\x1b[H{table}");
        } else {
            println!("{table}");
        }
    }
    let stats = sim.await.map_err(zerr)??;
    // Let the last estimates arrive.
    tokio::time::sleep(Duration::from_millis(500)).await;
    let final_rows = rows(&live);
    service_stop.cancel();
    let _ = service_task.await;
    let _ = client.close().await;
    Ok((final_rows, stats))
}

async fn wait_for_service(
    client: &zenoh::Session,
    keys: &Keys,
    endpoint: &str,
) -> Result<(), DemoError> {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(10);
    while tokio::time::Instant::now() < deadline {
        if let Ok(replies) = client
            .get(keys.health())
            .timeout(Duration::from_secs(1))
            .await
        {
            if let Ok(r) = replies.recv_async().await {
                if r.result().is_ok() {
                    return Ok(());
                }
            }
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    Err(DemoError::NoService(endpoint.to_string()))
}

/// The error of an estimate against a truth quaternion, deg (used by tests too).
pub fn error_deg(truth: &Quaternion, estimate: &Quaternion) -> f64 {
    truth.compose(&estimate.inverse()).angle().to_degrees()
}
