//! `P/@/metrics`: the engine's counters, gauges and step-time histograms as OpenMetrics text, written
//! by prometheus-client's encoder. A scrape reads the same atomics and snapshots as `P/@/health` (no
//! filter is touched, no lock is held longer than one vehicle's inbox length); only the step-time
//! histograms are kept for it, filled by the workers.

use crate::engine::{Engine, Vehicle, VehicleTotals, INGEST_CAPACITY, KINDS};
use crate::fleet::{FleetMode, Member};
use prometheus_client::collector::Collector;
use prometheus_client::encoding::{DescriptorEncoder, EncodeLabelSet, EncodeMetric};
use prometheus_client::metrics::counter::ConstCounter;
use prometheus_client::metrics::gauge::ConstGauge;
use prometheus_client::metrics::info::Info;
use prometheus_client::metrics::MetricType;
use prometheus_client::registry::{Registry, Unit};
use std::collections::BTreeMap;
use std::fmt;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// The zenoh encoding of a `P/@/metrics` reply, which zenoh's REST plugin sends as the HTTP
/// Content-Type: what Prometheus needs to parse the text as OpenMetrics (`# EOF`, `_total`, units).
pub const METRICS_ENCODING: &str = "application/openmetrics-text; version=1.0.0; charset=utf-8";

/// The metrics as OpenMetrics text. `ingest_depth`: raw samples waiting in the ingest channel (the
/// service owns its sender).
pub fn metrics_text(engine: &Arc<Engine>, member: &Arc<Member>, ingest_depth: usize) -> String {
    let mut registry = Registry::default();
    registry.register_collector(Box::new(Scrape {
        engine: engine.clone(),
        member: member.clone(),
        ingest_depth,
    }));
    let mut out = String::new();
    // (Writing into a String cannot fail; a collector's error would leave the text partial.)
    if let Err(e) = prometheus_client::encoding::text::encode(&mut out, &registry) {
        tracing::error!(error = %e, "cannot encode the metrics");
    }
    out
}

/// One scrape of an engine.
struct Scrape {
    engine: Arc<Engine>,
    member: Arc<Member>,
    ingest_depth: usize,
}

impl fmt::Debug for Scrape {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("Scrape")
    }
}

fn counter(e: &mut DescriptorEncoder, name: &str, help: &str, v: u64) -> fmt::Result {
    ConstCounter::new(v).encode(e.encode_descriptor(name, help, None, MetricType::Counter)?)
}

fn gauge(e: &mut DescriptorEncoder, name: &str, help: &str, v: i64) -> fmt::Result {
    ConstGauge::new(v).encode(e.encode_descriptor(name, help, None, MetricType::Gauge)?)
}

/// A metric family: one series per label set.
fn family<L: EncodeLabelSet, M: EncodeMetric>(
    e: &mut DescriptorEncoder,
    name: &str,
    help: &str,
    unit: Option<&Unit>,
    rows: impl IntoIterator<Item = (L, M)>,
) -> fmt::Result {
    let first = rows.into_iter().collect::<Vec<_>>();
    let Some((_, m)) = first.first() else {
        return Ok(());
    };
    let mut family = e.encode_descriptor(name, help, unit, m.metric_type())?;
    for (labels, m) in &first {
        m.encode(family.encode_family(labels)?)?;
    }
    Ok(())
}

fn load(a: &AtomicU64) -> u64 {
    a.load(Ordering::Relaxed)
}

/// Gauges are signed in OpenMetrics; our counts never come near `i64::MAX`.
fn signed(n: usize) -> i64 {
    i64::try_from(n).unwrap_or(i64::MAX)
}

impl Collector for Scrape {
    fn encode(&self, mut e: DescriptorEncoder) -> fmt::Result {
        let engine = &self.engine;
        let c = &engine.counters;
        let vehicles = engine.vehicles();
        let config = &engine.config;

        Info::new([
            ("version", env!("CARGO_PKG_VERSION")),
            ("fleet_instance", config.fleet.instance.as_str()),
            ("fleet_group", config.fleet.group.as_str()),
            ("fleet_mode", config.fleet.mode.as_str()),
        ])
        .encode(e.encode_descriptor(
            "attitude_service",
            "the service: its version and fleet identity",
            None,
            MetricType::Info,
        )?)?;
        ConstGauge::new(engine.uptime_s()).encode(e.encode_descriptor(
            "attitude_uptime",
            "time since the service started",
            Some(&Unit::Seconds),
            MetricType::Gauge,
        )?)?;

        // Service-wide counters (as in P/@/health).
        counter(
            &mut e,
            "attitude_received",
            "measurement samples received (a batch counts its items; a payload that does not decode counts once)",
            load(&c.received),
        )?;
        counter(
            &mut e,
            "attitude_processed",
            "samples the filters used",
            load(&c.processed),
        )?;
        counter(
            &mut e,
            "attitude_estimates_published",
            "estimates published on P/V/estimate",
            load(&c.estimates),
        )?;
        counter(
            &mut e,
            "attitude_queries",
            "queries received, answered or refused",
            load(&c.queries),
        )?;
        counter(
            &mut e,
            "attitude_ingest_overflow",
            "inputs refused on arrival for want of room (each told on P/V/rejected as queue_full)",
            load(&c.ingest_overflow),
        )?;
        counter(
            &mut e,
            "attitude_samples_missed",
            "puts of the vehicles' inputs zenoh reported lost and not recovered (samples_missed)",
            load(&c.missed),
        )?;
        let a = &engine.admission;
        counter(
            &mut e,
            "attitude_ingest_waited",
            "inputs of plain publishers that waited for room (back-pressure on their sender)",
            load(&a.waited),
        )?;
        ConstCounter::new(load(&a.waited_ns) as f64 * 1e-9).encode(e.encode_descriptor(
            "attitude_ingest_wait",
            "time inputs of plain publishers waited for room",
            Some(&Unit::Seconds),
            MetricType::Counter,
        )?)?;
        counter(
            &mut e,
            "attitude_ingest_redelivered",
            "samples of restored vehicles delivered again from a publisher's cache after a restart, skipped",
            load(&a.redelivered),
        )?;
        // Every code, zeros included, so that a rate over a code that has not happened yet exists.
        family(
            &mut e,
            "attitude_rejected",
            "refused inputs and requests by code (proto/README.md, Errors)",
            None,
            c.rejected_counts()
                .map(|(code, n)| ([("code", code.as_str())], ConstCounter::new(n))),
        )?;
        family(
            &mut e,
            "attitude_checkpoints",
            "checkpoint files: vehicles restored and files skipped at start, files written and failed writes",
            None,
            [
                ("restored", &c.restored),
                ("skipped", &c.skipped),
                ("written", &c.written),
                ("failed", &c.write_failed),
            ]
            .map(|(outcome, n)| ([("outcome", outcome)], ConstCounter::new(load(n)))),
        )?;
        let (takeovers, released, _) = self.member.moves();
        family(
            &mut e,
            "attitude_fleet_moves",
            "vehicles taken over from and released to other fleet members",
            None,
            [("takeover", takeovers), ("released", released)]
                .map(|(kind, n)| ([("kind", kind)], ConstCounter::new(n))),
        )?;

        // Gauges: what the service holds now.
        let mut by_kind: BTreeMap<(&'static str, &'static str), i64> = BTreeMap::new();
        let mut inbox = Vec::with_capacity(vehicles.len());
        for v in &vehicles {
            let kind = v.kind().as_str();
            let state = if v.is_tracking() {
                "tracking"
            } else {
                "initializing"
            };
            *by_kind.entry((kind, state)).or_default() += 1;
            inbox.push(v.inbox_len());
        }
        family(
            &mut e,
            "attitude_vehicles",
            "vehicles known, by filter kind and state",
            None,
            by_kind.iter().map(|((kind, state), n)| {
                ([("filter", *kind), ("state", *state)], ConstGauge::new(*n))
            }),
        )?;
        gauge(
            &mut e,
            "attitude_ingest_queue_depth",
            "raw samples waiting for the dispatcher (the bounded ingest channel)",
            signed(self.ingest_depth),
        )?;
        gauge(
            &mut e,
            "attitude_ingest_queue_capacity",
            "capacity of the ingest channel",
            signed(INGEST_CAPACITY),
        )?;
        gauge(
            &mut e,
            "attitude_work_queue_depth",
            "vehicles scheduled and waiting for a worker",
            signed(engine.work_queue_depth()),
        )?;
        gauge(
            &mut e,
            "attitude_inbox_depth",
            "inputs waiting in the vehicles' inboxes, summed",
            signed(inbox.iter().sum()),
        )?;
        gauge(
            &mut e,
            "attitude_inbox_depth_max",
            "inputs waiting in the fullest inbox",
            signed(inbox.iter().copied().max().unwrap_or(0)),
        )?;
        gauge(
            &mut e,
            "attitude_held_samples",
            "samples held in the vehicles' reorder windows, summed",
            signed(vehicles.iter().map(|v| v.totals().held).sum()),
        )?;
        gauge(
            &mut e,
            "attitude_fleet_members",
            "live members of this instance's fleet (itself included)",
            signed(match config.fleet.mode {
                FleetMode::Single => 1,
                FleetMode::Dynamic => self.member.members().map_or(0, |m| m.len()),
            }),
        )?;

        family(
            &mut e,
            "attitude_step",
            "time of one sample through its vehicle's filter, on a worker, by filter kind",
            Some(&Unit::Seconds),
            KINDS
                .iter()
                .map(|k| ([("filter", k.as_str())], c.step_times().of(*k).clone())),
        )?;

        self.per_vehicle(&mut e, &vehicles, &inbox)
    }
}

impl Scrape {
    /// Per-vehicle series (label `vehicle`) for the first `metrics.max_vehicles` vehicles by id: the
    /// cap bounds a scrape's size and the series count of a large fleet.
    fn per_vehicle(
        &self,
        e: &mut DescriptorEncoder,
        vehicles: &[Arc<Vehicle>],
        inbox: &[usize],
    ) -> fmt::Result {
        let cap = self.engine.config.metrics.max_vehicles;
        let shown = &vehicles[..vehicles.len().min(cap)];
        gauge(
            e,
            "attitude_vehicles_without_series",
            "vehicles beyond service.metrics.max_vehicles, which have no per-vehicle series",
            signed(vehicles.len() - shown.len()),
        )?;
        let each = |f: &dyn Fn(&VehicleTotals) -> u64| {
            shown
                .iter()
                .map(move |v| {
                    (
                        [("vehicle", v.id.clone())],
                        ConstCounter::new(f(&v.totals())),
                    )
                })
                .collect::<Vec<_>>()
        };
        family(
            e,
            "attitude_vehicle_received",
            "samples accepted into the vehicle's queue",
            None,
            each(&|t| t.received),
        )?;
        family(
            e,
            "attitude_vehicle_processed",
            "samples the vehicle's filter used",
            None,
            each(&|t| t.processed),
        )?;
        family(
            e,
            "attitude_vehicle_estimates_published",
            "estimates the vehicle published (the seq of its last one)",
            None,
            each(&|t| t.estimates),
        )?;
        // Only the codes that occurred: per vehicle and code the zeros would be most of the text.
        let mut rejected = Vec::new();
        for v in shown {
            let codes = v.rejected_by_code();
            for (code, n) in codes {
                rejected.push((
                    [("vehicle", v.id.clone()), ("code", code)],
                    ConstCounter::new(n),
                ));
            }
        }
        family(
            e,
            "attitude_vehicle_rejected",
            "the vehicle's refused inputs by code (codes that occurred)",
            None,
            rejected,
        )?;
        family(
            e,
            "attitude_vehicle_gaps",
            "gaps in the vehicle's gyro or raw-IMU samples, bridged and paid for in the covariance (gap)",
            None,
            each(&|t| t.gaps),
        )?;
        family(
            e,
            "attitude_vehicle_blind",
            "seconds the gaps in the vehicle's raw-IMU samples hid",
            Some(&Unit::Seconds),
            shown
                .iter()
                .map(|v| {
                    (
                        [("vehicle", v.id.clone())],
                        ConstCounter::new(v.totals().blind_us as f64 * 1e-6),
                    )
                })
                .collect::<Vec<_>>(),
        )?;
        family(
            e,
            "attitude_vehicle_samples_missed",
            "puts of the vehicle's inputs zenoh reported lost and not recovered",
            None,
            each(&|t| t.missed),
        )?;
        family(
            e,
            "attitude_vehicle_inbox_depth",
            "inputs waiting in the vehicle's inbox",
            None,
            shown
                .iter()
                .zip(inbox)
                .map(|(v, n)| ([("vehicle", v.id.clone())], ConstGauge::new(signed(*n)))),
        )?;
        family(
            e,
            "attitude_vehicle_held_samples",
            "samples held in the vehicle's reorder window",
            None,
            shown.iter().map(|v| {
                (
                    [("vehicle", v.id.clone())],
                    ConstGauge::new(signed(v.totals().held)),
                )
            }),
        )
    }
}
