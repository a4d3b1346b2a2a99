//! The work per message the service skips (issue 15): an estimate nobody subscribes to is kept for
//! the queries but never serialised nor put; the estimate-rate cap of an IMU vehicle decides before an
//! estimate is made; a batch is decoded straight into measurements.

use crate::common::{collecting_engine, free_port, open_zenoh, service_config, wait_until};
use attitude_service::engine::{Alone, Engine, EstimateOutlet, Inbound, Outlets, Sink};
use attitude_service::query;
use attitude_service::service::outlets::estimate_outlets;
use attitude_service::tools::synthetic::{imu_sample, star_set};
use attitude_service::wire::keys::Keys;
use attitude_service::wire::{EstimateMsg, ImuMsg};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// An outlet of the service that counts the estimates put through it.
struct Counting {
    inner: Box<dyn EstimateOutlet>,
    puts: Arc<AtomicUsize>,
}

impl EstimateOutlet for Counting {
    fn wanted(&self) -> bool {
        self.inner.wanted()
    }
    fn put(&self, payload: Vec<u8>) {
        self.puts.fetch_add(1, Ordering::SeqCst);
        self.inner.put(payload)
    }
}

fn seq_of(engine: &Engine, vehicle: &str) -> u64 {
    query::state_of(engine, vehicle).map(|e| e.seq).unwrap_or(0)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn estimates_are_serialised_only_while_someone_subscribes() {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let service = open_zenoh(&[endpoint.clone()], &[]).await;
    let client = open_zenoh(&[], &[endpoint]).await;
    let keys = Keys::new("skip");
    let (outlets, _watch) = estimate_outlets(&service, &keys).await.unwrap();
    let puts = Arc::new(AtomicUsize::new(0));
    let counting: Outlets = {
        let puts = puts.clone();
        Arc::new(move |key: &str| {
            Box::new(Counting {
                inner: outlets(key),
                puts: puts.clone(),
            }) as Box<dyn EstimateOutlet>
        })
    };
    let config = service_config(
        r#"{ service: { key_prefix: "skip", filter: { kind: "mekf" }, time: { reorder_window_s: 0 } } }"#,
    );
    let sink: Sink = Arc::new(|_: &str, _: Vec<u8>| {});
    let (engine, threads) = Engine::start(config, sink, counting, Arc::new(Alone)).unwrap();
    let mut t = 0.0;
    let mut set = || {
        t += 1.0;
        engine.dispatch(Inbound {
            key: "skip/v1/vectors".into(),
            payload: serde_json::to_vec(&star_set(t, 1)).unwrap(),
        });
    };

    // Nobody subscribes: every estimate is made and kept for the queries, none is serialised.
    for _ in 0..5 {
        set();
    }
    wait_until("five estimates", Duration::from_secs(10), || {
        seq_of(&engine, "v1") == 5
    })
    .unwrap();
    assert_eq!(
        puts.load(Ordering::SeqCst),
        0,
        "an estimate nobody wanted was put"
    );

    // A subscriber appears (matching is learnt asynchronously): estimates are serialised, put and
    // received, byte for byte what the snapshot serialises to.
    let got: Arc<Mutex<Vec<Vec<u8>>>> = Arc::default();
    let g = got.clone();
    let sub = client
        .declare_subscriber("skip/*/estimate")
        .callback(move |s| g.lock().unwrap().push(s.payload().to_bytes().into_owned()))
        .await
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(10);
    while got.lock().unwrap().is_empty() {
        assert!(
            Instant::now() < deadline,
            "no estimate reached the subscriber"
        );
        set();
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let made = seq_of(&engine, "v1");
    let received = || got.lock().unwrap().len();
    wait_until(
        "every estimate put to arrive",
        Duration::from_secs(10),
        || received() == puts.load(Ordering::SeqCst),
    )
    .unwrap();
    let last = got.lock().unwrap().last().cloned().unwrap();
    let snapshot = query::state_of(&engine, "v1").unwrap();
    assert_eq!(snapshot.seq, made, "no estimate since the last one was put");
    assert_eq!(last, serde_json::to_vec(&*snapshot).unwrap());
    let parsed: EstimateMsg = serde_json::from_slice(&last).unwrap();
    assert_eq!(parsed, *snapshot);
    assert!(made > 5 && puts.load(Ordering::SeqCst) as u64 <= made - 5);

    // The subscriber leaves: estimates are made again without being put.
    sub.undeclare().await.unwrap();
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        assert!(
            Instant::now() < deadline,
            "estimates are still put after the subscriber left"
        );
        let (before, seq) = (puts.load(Ordering::SeqCst), seq_of(&engine, "v1"));
        set();
        wait_until("the next estimate", Duration::from_secs(10), || {
            seq_of(&engine, "v1") == seq + 1
        })
        .unwrap();
        if puts.load(Ordering::SeqCst) == before {
            break;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    tokio::task::spawn_blocking(move || threads.shutdown())
        .await
        .unwrap();
    client.close().await.unwrap();
    service.close().await.unwrap();
}

/// The estimates an IMU vehicle publishes for 1.5 s of samples at 200 Hz, in batches of 10.
fn imu_estimates(config: &str) -> (Vec<EstimateMsg>, u64) {
    let (node, threads, out) = collecting_engine(service_config(config));
    let engine = node.engine.clone();
    let samples: Vec<ImuMsg> = (0..300).map(|k| imu_sample(k as f64 / 200.0, 3)).collect();
    for batch in samples.chunks(10) {
        engine.dispatch(Inbound {
            key: "attitude/c1/imu".into(),
            payload: serde_json::to_vec(batch).unwrap(),
        });
    }
    wait_until("every sample processed", Duration::from_secs(20), || {
        node.health().processed == 300
    })
    .unwrap();
    threads.shutdown();
    let estimates = out
        .lock()
        .unwrap()
        .iter()
        .filter(|(k, _)| k == "attitude/c1/estimate")
        .map(|(_, p)| serde_json::from_slice(p).unwrap())
        .collect();
    (estimates, node.health().estimates_published)
}

#[test]
fn the_estimate_rate_cap_is_applied_before_an_estimate_is_made() {
    // Without a cap: an estimate for every sample after the 0.1 s alignment.
    let (every, made) = imu_estimates(r#"{ service: { filter: { kind: "mekf" } } }"#);
    assert!(every.len() >= 270, "{} estimates uncapped", every.len());
    assert_eq!(made, every.len() as u64);
    // At most 10 per second of sample time: ~14 for the 1.4 s after alignment, each ≥ 0.1 s after the
    // one before and covering ~20 samples; no estimate beyond them is even made (counted), so none is
    // serialised.
    let (capped, made) = imu_estimates(
        r#"{ service: { filter: { kind: "mekf" }, imu: { max_estimate_rate_hz: 10 } } }"#,
    );
    assert!(
        (13..=15).contains(&capped.len()),
        "{} estimates capped",
        capped.len()
    );
    assert_eq!(made, capped.len() as u64);
    for w in capped.windows(2) {
        assert!(w[1].t - w[0].t >= 0.1 - 1e-9, "{} then {}", w[0].t, w[1].t);
        let samples = |e: &EstimateMsg| e.diagnostics.imu.as_ref().unwrap().samples;
        assert!(samples(&w[1]) - samples(&w[0]) >= 19);
    }
    // The seq counts the estimates published, with or without the cap.
    assert_eq!(capped.last().unwrap().seq, capped.len() as u64);
}

#[test]
fn a_vehicle_with_a_heavy_filter_and_a_backlog_does_not_hold_the_worker() {
    // One worker; a particle filter of 20 000 particles (a step of a millisecond or so) with 200
    // vector sets waiting, then one set of an MEKF vehicle: its estimate comes after a few of the
    // heavy steps (a worker's turn ends after 5 ms), not after all of them.
    let (node, threads, _out) = collecting_engine(service_config(
        r#"{ service: { workers: 1, filter: { kind: "mekf" }, time: { reorder_window_s: 0 },
             vehicles: { heavy: { kind: "qpf", particles: 20000 } } } }"#,
    ));
    let engine = node.engine.clone();
    let set = |vehicle: &str, t: f64| Inbound {
        key: format!("attitude/{vehicle}/vectors"),
        payload: serde_json::to_vec(&star_set(t, 2)).unwrap(),
    };
    for k in 0..200 {
        engine.dispatch(set("heavy", k as f64));
    }
    engine.dispatch(set("light", 0.0));
    wait_until(
        "the light vehicle's estimate",
        Duration::from_secs(60),
        || query::state_of(&engine, "light").is_ok(),
    )
    .unwrap();
    let heavy = engine.vehicle("heavy").unwrap().info().processed;
    assert!(
        heavy < 150,
        "{heavy} heavy steps ran before the light vehicle's one"
    );
    wait_until("every heavy step", Duration::from_secs(120), || {
        engine.vehicle("heavy").unwrap().info().processed == 200
    })
    .unwrap();
    threads.shutdown();
}
