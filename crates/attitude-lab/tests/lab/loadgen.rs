//! `loadgen` against the service in this process and against the bare echo: every input answered,
//! nothing lost or refused (plain and routed keys, gyro and vector sets, raw IMU batches, a capped IMU
//! estimate rate).

use crate::common::{service_config, Service};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn loadgen_against_the_service_and_the_echo_loses_nothing() {
    use attitude_lab::tools::loadgen::{echo, run, LoadOptions};
    use attitude_service::wire::keys::Keys;
    let h = Service::start(service_config(
        r#"{ service: { filter: { kind: "mekf" } } }"#,
    ))
    .await;
    let options = LoadOptions {
        vehicles: 3,
        rate_hz: 20.0,
        duration_s: 1.0,
        vehicle_prefix: "lg".into(),
        drain_s: 5.0,
        imu_batch: 0,
        covering: false,
        routed: false,
        spread: false,
        publishing: Default::default(),
    };
    let keys = Keys::new("attitude");
    let r = run(&h.client, &keys, &options, "service").await.unwrap();
    assert_eq!(
        (r.sent, r.estimates, r.lost, r.rejected),
        (60, 60, 0, 0),
        "{r:?}"
    );
    assert!(r.p50_us > 0.0 && r.p99_us >= r.p50_us && r.max_us >= r.p99_us);
    // Routed inputs (P/V/<leaf>/<r>, and their batches, which a single instance ignores), spread
    // over the period: the same.
    let routed = LoadOptions {
        routed: true,
        spread: true,
        vehicle_prefix: "lgr".into(),
        ..options.clone()
    };
    let r = run(&h.client, &keys, &routed, "service").await.unwrap();
    assert_eq!(
        (r.sent, r.estimates, r.lost, r.rejected),
        (60, 60, 0, 0),
        "{r:?}"
    );
    // The bare round trip through the echo, measured the same way on another prefix.
    let echo_keys = Keys::new("echo-test");
    let _echo = echo(&h.client, &echo_keys).await.unwrap();
    let e = run(&h.client, &echo_keys, &options, "echo").await.unwrap();
    assert_eq!((e.sent, e.estimates, e.lost), (60, 60, 0), "{e:?}");
    // Raw IMU samples: every one of them comes back as an estimate.
    let imu = LoadOptions {
        imu_batch: 10,
        vehicle_prefix: "lgi".into(),
        ..options
    };
    let r = run(&h.client, &keys, &imu, "service").await.unwrap();
    assert_eq!(
        (r.sent, r.estimates, r.messages, r.lost, r.rejected),
        (600, 600, 600, 0, 0),
        "{r:?}"
    );
    // Through the echo each put of ten samples comes back as one message.
    let e = run(&h.client, &echo_keys, &imu, "echo").await.unwrap();
    assert_eq!(
        (e.sent, e.estimates, e.messages, e.lost),
        (600, 600, 60, 0),
        "{e:?}"
    );
    h.stop().await;
    // A service that caps IMU estimates at 20 per second (one per put of ten samples at 200 Hz):
    // each estimate answers the samples up to its time, and nothing is lost.
    let h = Service::start(service_config(
        r#"{ service: { filter: { kind: "mekf" }, imu: { max_estimate_rate_hz: 20 } } }"#,
    ))
    .await;
    let capped = LoadOptions {
        covering: true,
        routed: false,
        vehicle_prefix: "lgc".into(),
        ..imu
    };
    let r = run(&h.client, &keys, &capped, "service").await.unwrap();
    assert_eq!(
        (r.sent, r.estimates, r.lost, r.rejected),
        (600, 600, 0, 0),
        "{r:?}"
    );
    assert!((50..=70).contains(&r.messages), "{r:?}");
    h.stop().await;
}
