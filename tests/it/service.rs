//! The service over real zenoh on loopback: a service session and a client session in one process.

use crate::common::{free_port, open_zenoh, repo, service_config, wait_until_async};
use attitude_service::attitude::Quaternion;
use attitude_service::service::config::{parse, ServiceConfig};
use attitude_service::wire::{
    AttitudeMsg, ErrorMsg, EstimateMsg, GyroMsg, HealthMsg, ObservationMsg, QuaternionMsg,
    ResetMsg, ResetReplyMsg, VectorsMsg, VehicleInfoMsg,
};
use nalgebra::Vector3;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::query::ConsolidationMode;

struct Harness {
    client: zenoh::Session,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    service: Option<tokio::task::JoinHandle<Result<(), attitude_service::service::ServiceError>>>,
}

impl Harness {
    async fn start(service: ServiceConfig) -> Harness {
        let endpoint = format!("tcp/127.0.0.1:{}", free_port());
        let s = open_zenoh(&[endpoint.clone()], &[]).await;
        let (tx, rx) = tokio::sync::oneshot::channel::<()>();
        let task = tokio::spawn(attitude_service::service::run(s, service, async {
            let _ = rx.await;
        }));
        let client = open_zenoh(&[], &[endpoint]).await;
        let h = Harness {
            client,
            stop: Some(tx),
            service: Some(task),
        };
        // Declarations propagate asynchronously: poll the health queryable with a deadline.
        let hr = &h;
        wait_until_async(
            "the service to answer on attitude/@/health",
            Duration::from_secs(10),
            || async move { hr.get::<HealthMsg>("attitude/@/health").await.is_ok() },
        )
        .await
        .unwrap();
        h
    }

    async fn replies(
        &self,
        key: &str,
        payload: Option<Vec<u8>>,
    ) -> Vec<(String, Result<Vec<u8>, Vec<u8>>)> {
        let mut get = self
            .client
            .get(key)
            .consolidation(ConsolidationMode::None)
            .timeout(Duration::from_secs(5));
        if let Some(p) = payload {
            get = get.payload(p);
        }
        let rx = get.await.unwrap();
        let mut out = Vec::new();
        while let Ok(reply) = rx.recv_async().await {
            match reply.result() {
                Ok(s) => out.push((
                    s.key_expr().to_string(),
                    Ok(s.payload().to_bytes().into_owned()),
                )),
                Err(e) => out.push((String::new(), Err(e.payload().to_bytes().into_owned()))),
            }
        }
        out
    }

    /// One reply, parsed; an error reply comes back as its ErrorMsg.
    async fn get<T: serde::de::DeserializeOwned>(&self, key: &str) -> Result<T, ErrorMsg> {
        let mut r = self.replies(key, None).await;
        assert!(r.len() <= 1, "{key}: {} replies", r.len());
        match r.pop() {
            Some((_, Ok(p))) => Ok(serde_json::from_slice(&p).unwrap()),
            Some((_, Err(p))) => Err(serde_json::from_slice(&p).unwrap()),
            None => Err(ErrorMsg {
                code: "no_reply".into(),
                message: String::new(),
                key: key.into(),
            }),
        }
    }

    async fn put<T: serde::Serialize>(&self, key: &str, msg: &T) {
        self.client
            .put(key, serde_json::to_vec(msg).unwrap())
            .await
            .unwrap();
    }

    async fn stop(mut self) {
        let _ = self.stop.take().unwrap().send(());
        let r = tokio::time::timeout(Duration::from_secs(10), self.service.take().unwrap())
            .await
            .expect("the service stops within 10 s");
        r.unwrap().unwrap();
        self.client.close().await.unwrap();
    }
}

fn star_set(q_true: &Quaternion, t: f64) -> VectorsMsg {
    let refs = [
        Vector3::new(1.0, 0.0, 0.0),
        Vector3::new(0.0, 0.6, 0.8),
        Vector3::new(0.0, -0.8, 0.6),
    ];
    VectorsMsg {
        t,
        obs: refs
            .iter()
            .map(|r| {
                let b = q_true.attitude_matrix() * r;
                ObservationMsg {
                    body: [b[0], b[1], b[2]],
                    reference: [r[0], r[1], r[2]],
                    sigma: 1e-4,
                    sensor: Some("st1".into()),
                }
            })
            .collect(),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn measurements_estimates_queries_and_rejections() {
    let h = Harness::start(service_config(
        r#"{ service: { filter: { kind: "qpf", particles: 300 }, vehicles: { "m1": { kind: "mekf" } } } }"#,
    ))
    .await;
    let estimates: Arc<Mutex<Vec<EstimateMsg>>> = Arc::default();
    let e2 = estimates.clone();
    let _sub = h
        .client
        .declare_subscriber("attitude/*/estimate")
        .callback(move |s| {
            if let Ok(e) = serde_json::from_slice::<EstimateMsg>(&s.payload().to_bytes()) {
                e2.lock().unwrap().push(e);
            }
        })
        .await
        .unwrap();
    let rejected: Arc<Mutex<Vec<ErrorMsg>>> = Arc::default();
    let r2 = rejected.clone();
    let _rsub = h
        .client
        .declare_subscriber("attitude/*/rejected")
        .callback(move |s| {
            if let Ok(e) = serde_json::from_slice::<ErrorMsg>(&s.payload().to_bytes()) {
                r2.lock().unwrap().push(e);
            }
        })
        .await
        .unwrap();
    tokio::time::sleep(Duration::from_millis(300)).await;

    let omega = Vector3::new(0.0, -0.001, 0.0005);
    let q0 = Quaternion::new(0.2, -0.1, 0.3, 0.9).normalized().unwrap();
    for vehicle in ["m1", "p1"] {
        let mut q = q0;
        for k in 0..30 {
            let t = k as f64;
            h.put(
                &format!("attitude/{vehicle}/gyro"),
                &GyroMsg {
                    t,
                    omega: [omega[0], omega[1], omega[2]],
                },
            )
            .await;
            q = q.propagate(&omega, 1.0);
            h.put(
                &format!("attitude/{vehicle}/vectors"),
                &star_set(&q, t + 1.0),
            )
            .await;
        }
    }
    // Bad inputs, each with its own code.
    h.client
        .put("attitude/m1/gyro", b"{not json".to_vec())
        .await
        .unwrap();
    h.client
        .put(
            "attitude/m1/vectors",
            br#"{"t": 40, "obs": [{"body": [0,0,0], "ref": [1,0,0], "sigma": 1e-4}]}"#.to_vec(),
        )
        .await
        .unwrap();
    h.client
        .put(
            "attitude/bad.id/gyro",
            br#"{"t": 1, "omega": [0,0,0]}"#.to_vec(),
        )
        .await
        .unwrap();

    let counts = || {
        (
            estimates.lock().unwrap().len(),
            rejected.lock().unwrap().len(),
        )
    };
    wait_until_async(
        "60 estimates and 3 rejections",
        Duration::from_secs(20),
        || {
            let (n_est, n_rej) = counts();
            std::future::ready(n_est >= 60 && n_rej >= 3)
        },
    )
    .await
    .unwrap_or_else(|e| {
        let (n_est, n_rej) = counts();
        panic!("{e}: {n_est} estimates, {n_rej} rejections")
    });
    let codes: Vec<String> = rejected
        .lock()
        .unwrap()
        .iter()
        .map(|r| r.code.clone())
        .collect();
    for c in ["invalid_json", "zero_vector", "invalid_vehicle_id"] {
        assert!(codes.contains(&c.to_string()), "{c} missing from {codes:?}");
    }
    // Estimates: in order per vehicle, right filter, close to the truth.
    let truth = (0..30).fold(q0, |q, _| q.propagate(&omega, 1.0));
    for (vehicle, filter) in [("m1", "mekf"), ("p1", "qpf")] {
        let est: Vec<EstimateMsg> = estimates
            .lock()
            .unwrap()
            .iter()
            .filter(|e| e.vehicle == vehicle)
            .cloned()
            .collect();
        assert_eq!(est.len(), 30, "{vehicle}");
        assert!(
            est.windows(2)
                .all(|w| w[1].seq == w[0].seq + 1 && w[1].t > w[0].t),
            "{vehicle}: ordered"
        );
        let last = est.last().unwrap();
        assert_eq!(last.filter, filter);
        assert_eq!(last.t, 30.0);
        // Near the truth: the observations are exact (σ = 1e-4 rad told), so the error is well inside
        // the covariance; a gross check, NEES below χ²₃(0.9995) = 17.73 (0.999 over the two vehicles;
        // one sample cannot tell a covariance 1.5× off, tests/it/qpf.rs and tests/it/usque.rs do). Measured:
        // 9e-23 (MEKF) and 0.0097 (QPF).
        let q = last.q.to_domain().unwrap();
        let err = truth.small_angle_error(&q);
        let p = nalgebra::Matrix3::from_fn(|i, j| last.cov[i][j]);
        let nees = err.dot(&p.cholesky().unwrap().solve(&err));
        eprintln!("{vehicle}: NEES of the last estimate {nees:e}");
        assert!(
            nees <= 17.73,
            "{vehicle}: error {err} rad, NEES {nees}, σ {:?}°",
            last.sigma_deg
        );
    }
    // Queries: one vehicle, wildcard, unknown.
    let a: AttitudeMsg = h.get("attitude/m1/attitude").await.unwrap();
    assert_eq!((a.vehicle.as_str(), a.t), ("m1", 30.0));
    let all = h.replies("attitude/*/attitude", None).await;
    let mut keys: Vec<String> = all.iter().map(|(k, _)| k.clone()).collect();
    keys.sort();
    assert_eq!(keys, ["attitude/m1/attitude", "attitude/p1/attitude"]);
    let unknown = h
        .get::<AttitudeMsg>("attitude/nobody/attitude")
        .await
        .unwrap_err();
    assert_eq!(unknown.code, "unknown_vehicle");
    let cov = h.replies("attitude/p1/covariance", None).await;
    assert_eq!(cov.len(), 1);
    let vehicles: Vec<VehicleInfoMsg> = h.get("attitude/@/vehicles").await.unwrap();
    assert_eq!(
        vehicles
            .iter()
            .map(|v| v.vehicle.as_str())
            .collect::<Vec<_>>(),
        ["m1", "p1"]
    );
    assert!(vehicles
        .iter()
        .all(|v| v.state == "tracking" && v.processed == 60));
    let health: HealthMsg = h.get("attitude/@/health").await.unwrap();
    assert_eq!(health.vehicles, 2);
    assert_eq!(health.estimates_published, 60);
    assert!(health.received >= 123, "{health:?}");
    for c in [
        "invalid_json",
        "zero_vector",
        "invalid_vehicle_id",
        "unknown_vehicle",
    ] {
        assert!(
            health.rejected.get(c).copied().unwrap_or(0) >= 1,
            "{c}: {health:?}"
        );
    }
    h.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn reset_gives_an_attitude_and_refuses_bad_parameters() {
    let h = Harness::start(ServiceConfig::default()).await;
    let q = QuaternionMsg {
        w: 0.9,
        x: 0.3,
        y: -0.2,
        z: 0.1,
    };
    let n = (q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z).sqrt();
    let q = QuaternionMsg {
        w: q.w / n,
        x: q.x / n,
        y: q.y / n,
        z: q.z / n,
    };
    let req = ResetMsg {
        filter: Some("mekf".into()),
        q: Some(q),
        t: Some(100.0),
        ..Default::default()
    };
    let r = h
        .replies("attitude/r1/reset", Some(serde_json::to_vec(&req).unwrap()))
        .await;
    let reply: ResetReplyMsg = serde_json::from_slice(r[0].1.as_ref().unwrap()).unwrap();
    assert_eq!(
        (reply.state.as_str(), reply.filter.as_str()),
        ("tracking", "mekf")
    );
    let a: AttitudeMsg = h.get("attitude/r1/attitude").await.unwrap();
    assert_eq!(a.t, 100.0);
    assert!((a.q.w - q.w).abs() < 1e-12 && (a.q.x - q.x).abs() < 1e-12);
    assert!(
        (a.sigma_deg[0] - 1.0).abs() < 1e-9,
        "default reset sigma 1°"
    );
    for bad in [
        r#"{"filter": "ekf"}"#,
        r#"{"sigma_deg": -1, "q": {"w": 1, "x": 0, "y": 0, "z": 0}}"#,
        r#"{"q": {"w": 2, "x": 0, "y": 0, "z": 0}}"#,
        r#"{"unknown": 1}"#,
        "not json",
    ] {
        let r = h
            .replies("attitude/r1/reset", Some(bad.as_bytes().to_vec()))
            .await;
        let err: ErrorMsg = serde_json::from_slice(r[0].1.as_ref().unwrap_err()).unwrap();
        assert!(
            !err.code.is_empty() && err.message.len() > 5,
            "{bad}: {err:?}"
        );
    }
    let after: AttitudeMsg = h.get("attitude/r1/attitude").await.unwrap();
    assert_eq!(after, a, "refused resets change nothing");
    // A reset without q re-initialises from the next vector set.
    let r = h
        .replies(
            "attitude/r1/reset",
            Some(br#"{"filter": "qpf", "particles": 200}"#.to_vec()),
        )
        .await;
    let reply: ResetReplyMsg = serde_json::from_slice(r[0].1.as_ref().unwrap()).unwrap();
    assert_eq!(
        (reply.state.as_str(), reply.particles),
        ("initializing", Some(200))
    );
    assert_eq!(
        h.get::<AttitudeMsg>("attitude/r1/attitude")
            .await
            .unwrap_err()
            .code,
        "not_initialized"
    );
    h.stop().await;
}

#[test]
fn the_default_configuration_file_loads_and_matches_the_built_in_defaults() {
    let file =
        attitude_service::service::config::load(&repo().join("config/default.json5")).unwrap();
    assert_eq!(file.service, ServiceConfig::default());
    zenoh::Config::from_json5(&file.zenoh_json).unwrap();
    assert!(file.zenoh_json.contains("tcp/127.0.0.1:7447"));
    for bad in [
        r#"{ service: { key_prefix: "a/*/b" } }"#,
        r#"{ service: { filter: { kind: "ekf" } } }"#,
        r#"{ service: { filter: { init: "uniform", kind: "mekf" } } }"#,
        r#"{ service: { limits: { max_vehicles: 0 } } }"#,
        r#"{ service: { unknown_option: 1 } }"#,
        r#"{ service: { vehicles: { "bad id": {} } } }"#,
        r#"{ service: { ingest: { query_timeout_s: 0 } } }"#,
        r#"{ service: { ingest: { wait_s: 5 } } }"#,
        r#"{ service: { ingest: { pending_bytes_per_vehicle: 1000 } } }"#,
        r#"{ service: { ingest: { pending_bytes: 1048576, pending_bytes_per_vehicle: 2097152 } } }"#,
    ] {
        assert!(parse(bad, "test").is_err(), "{bad} accepted");
    }
}

/// A vehicle whose estimates come fast (raw IMU samples, an estimate each) gets a publisher of its
/// own after its first 256 estimates (`service::outlets`): across that switch a subscriber gets
/// every estimate once, in order (`seq` 1, 2, 3, … without a gap), on the vehicle's key.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_fast_vehicle_switches_to_its_own_publisher_without_losing_an_estimate() {
    use attitude_service::tools::synthetic::imu_sample;
    use attitude_service::wire::ImuMsg;
    let text = std::fs::read_to_string(repo().join("config/imu.json5")).unwrap();
    let h = Harness::start(service_config(&text)).await;
    let got: Arc<Mutex<Vec<(String, u64)>>> = Arc::default();
    let g2 = got.clone();
    let _sub = h
        .client
        .declare_subscriber("attitude/*/estimate")
        .callback(move |s| {
            let e: EstimateMsg = serde_json::from_slice(&s.payload().to_bytes()).unwrap();
            g2.lock().unwrap().push((s.key_expr().to_string(), e.seq));
        })
        .await
        .unwrap();
    tokio::time::sleep(Duration::from_millis(300)).await;
    let samples: Vec<ImuMsg> = (0..1200).map(|k| imu_sample(k as f64 / 200.0, 3)).collect();
    for batch in samples.chunks(100) {
        h.put("attitude/fast/imu", &batch).await;
    }
    async fn info(h: &Harness) -> Option<VehicleInfoMsg> {
        h.get::<Vec<VehicleInfoMsg>>("attitude/@/vehicles")
            .await
            .ok()
            .and_then(|v| v.into_iter().find(|i| i.vehicle == "fast"))
    }
    let hr = &h;
    wait_until_async(
        "every sample processed",
        Duration::from_secs(20),
        || async move { info(hr).await.is_some_and(|i| i.processed == 1200) },
    )
    .await
    .unwrap();
    let published = info(&h).await.unwrap().estimates;
    let g3 = got.clone();
    wait_until_async("every estimate received", Duration::from_secs(10), || {
        let n = g3.lock().unwrap().len() as u64;
        async move { n >= published }
    })
    .await
    .unwrap_or_else(|e| panic!("{e}: {} of {published}", got.lock().unwrap().len()));
    let got = got.lock().unwrap().clone();
    assert!(published > 800, "{published} estimates");
    assert!(got.iter().all(|(k, _)| k == "attitude/fast/estimate"));
    let seqs: Vec<u64> = got.iter().map(|(_, s)| *s).collect();
    assert_eq!(seqs, (1..=published).collect::<Vec<_>>());
    h.stop().await;
}
