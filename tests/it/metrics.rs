//! `P/@/metrics` over real zenoh on loopback, the encoding of every reply and publication, and zenoh's
//! REST plugin inside the service (`service::session::open` with `plugins/rest`): HTTP GETs of an
//! attitude and of the metrics.

use crate::common::{
    collecting_engine, free_port, open_zenoh, proto_dir, service_config, wait_until_async,
};
use attitude_service::engine::Inbound;
use attitude_service::query::METRICS_ENCODING;
use attitude_service::service::session::{self, ServiceSession};
use attitude_service::wire::{AttitudeMsg, GyroMsg, ObservationMsg, VectorsMsg};
use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::query::ConsolidationMode;

/// One series: the metric's name and its labels.
type Series = (String, BTreeMap<String, String>);

/// The samples of an OpenMetrics text (`name{label="value",...} number`), and checks that it is one:
/// `# EOF` last, every sample after a `# TYPE` of its family. Label values here never hold `,`, `"`
/// or `\`, so a split suffices.
fn parse_openmetrics(text: &str) -> BTreeMap<Series, f64> {
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.last(), Some(&"# EOF"), "the text ends with # EOF");
    let mut families: Vec<String> = Vec::new();
    let mut out = BTreeMap::new();
    for line in &lines[..lines.len() - 1] {
        if let Some(rest) = line.strip_prefix("# TYPE ") {
            families.push(rest.split(' ').next().unwrap().to_string());
            continue;
        }
        if line.starts_with('#') {
            continue;
        }
        let (series, value) = line.rsplit_once(' ').expect("name and value");
        let (name, labels) = match series.split_once('{') {
            Some((n, l)) => (n, l.strip_suffix('}').expect("closing brace")),
            None => (series, ""),
        };
        assert!(
            families.iter().any(|f| name.starts_with(f.as_str())),
            "{name} before its # TYPE"
        );
        let labels = labels
            .split(',')
            .filter(|l| !l.is_empty())
            .map(|l| {
                let (k, v) = l.split_once('=').expect("label=value");
                (k.to_string(), v.trim_matches('"').to_string())
            })
            .collect();
        out.insert((name.to_string(), labels), value.parse().expect("a number"));
    }
    out
}

fn value(m: &BTreeMap<Series, f64>, name: &str, labels: &[(&str, &str)]) -> Option<f64> {
    let labels = labels
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    m.get(&(name.to_string(), labels)).copied()
}

/// The service on a session of its own (with the REST plugin when `rest` is given) and a client.
struct Running {
    client: zenoh::Session,
    stop: tokio::sync::oneshot::Sender<()>,
    task: tokio::task::JoinHandle<()>,
}

async fn start(config: &str, http: Option<u16>) -> (Running, Option<std::net::SocketAddr>) {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let mut zc = zenoh::Config::from_json5(
        &serde_json::json!({
            "mode": "peer",
            "listen": {"endpoints": [endpoint]},
            "scouting": {"multicast": {"enabled": false}},
        })
        .to_string(),
    )
    .unwrap();
    if let Some(port) = http {
        zc.insert_json5("plugins/rest/http_port", &format!("\"127.0.0.1:{port}\""))
            .unwrap();
    }
    let opened: ServiceSession = session::open(zc).await.unwrap();
    let addr = opened.http_addr();
    let (stop, rx) = tokio::sync::oneshot::channel::<()>();
    let config = service_config(config);
    let task = tokio::spawn(async move {
        attitude_service::service::run(opened.session.clone(), config, async {
            let _ = rx.await;
        })
        .await
        .unwrap();
        opened.close().await.unwrap();
    });
    let client = open_zenoh(&[], &[endpoint]).await;
    let c = &client;
    wait_until_async(
        "the service to answer on attitude/@/metrics",
        Duration::from_secs(10),
        || async move { !replies(c, "attitude/@/metrics").await.is_empty() },
    )
    .await
    .unwrap();
    (Running { client, stop, task }, addr)
}

impl Running {
    async fn stop(self) {
        let _ = self.stop.send(());
        tokio::time::timeout(Duration::from_secs(10), self.task)
            .await
            .expect("the service stops within 10 s")
            .unwrap();
        self.client.close().await.unwrap();
    }

    async fn put(&self, key: &str, payload: Vec<u8>) {
        self.client.put(key, payload).await.unwrap();
    }

    async fn metrics(&self) -> BTreeMap<Series, f64> {
        let r = replies(&self.client, "attitude/@/metrics").await;
        assert_eq!(r.len(), 1);
        let (encoding, payload) = r[0].1.as_ref().expect("a metrics reply");
        assert_eq!(encoding, METRICS_ENCODING);
        parse_openmetrics(std::str::from_utf8(payload).unwrap())
    }
}

/// Every reply to a get: key, and (encoding, payload) or the error reply's.
async fn replies(
    client: &zenoh::Session,
    key: &str,
) -> Vec<(String, Result<(String, Vec<u8>), (String, Vec<u8>)>)> {
    let rx = client
        .get(key)
        .consolidation(ConsolidationMode::None)
        .timeout(Duration::from_secs(5))
        .await
        .unwrap();
    let mut out = Vec::new();
    while let Ok(reply) = rx.recv_async().await {
        out.push(match reply.result() {
            Ok(s) => (
                s.key_expr().to_string(),
                Ok((
                    s.encoding().to_string(),
                    s.payload().to_bytes().into_owned(),
                )),
            ),
            Err(e) => (
                String::new(),
                Err((
                    e.encoding().to_string(),
                    e.payload().to_bytes().into_owned(),
                )),
            ),
        });
    }
    out
}

fn star_set(t: f64) -> Vec<u8> {
    // The identity attitude: body = reference.
    let obs = [[1.0, 0.0, 0.0], [0.0, 0.6, 0.8], [0.0, -0.8, 0.6]]
        .map(|r| ObservationMsg {
            body: r,
            reference: r,
            sigma: 1e-4,
            sensor: None,
        })
        .to_vec();
    serde_json::to_vec(&VectorsMsg { t, obs }).unwrap()
}

fn gyro(t: f64) -> Vec<u8> {
    serde_json::to_vec(&GyroMsg { t, omega: [0.0; 3] }).unwrap()
}

/// Two vehicles (MEKF and particle filter), series for the first only (`max_vehicles: 1`): the counters
/// move with the inputs, a rejection shows under its code, the step-time histograms count what the
/// filters processed, the per-vehicle series stop at the cap; and every reply and publication of the
/// service carries its encoding (the REST plugin's HTTP Content-Type).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn metrics_move_with_inputs_and_every_reply_carries_its_encoding() {
    let (s, _) = start(
        r#"{ service: { filter: { kind: "qpf", particles: 100 }, vehicles: { "m1": { kind: "mekf" } },
             metrics: { max_vehicles: 1 } } }"#,
        None,
    )
    .await;
    let before = s.metrics().await;
    assert_eq!(value(&before, "attitude_received_total", &[]), Some(0.0));
    assert_eq!(
        value(
            &before,
            "attitude_rejected_total",
            &[("code", "invalid_json")]
        ),
        Some(0.0),
        "every code is there from the start"
    );

    let published: Arc<Mutex<Vec<(String, String)>>> = Arc::default();
    let p = published.clone();
    let _sub = s
        .client
        .declare_subscriber("attitude/*/*")
        .callback(move |x| {
            let leaf = x
                .key_expr()
                .as_str()
                .rsplit('/')
                .next()
                .unwrap()
                .to_string();
            if leaf == "estimate" || leaf == "rejected" {
                p.lock().unwrap().push((leaf, x.encoding().to_string()));
            }
        })
        .await
        .unwrap();
    tokio::time::sleep(Duration::from_millis(300)).await;
    for vehicle in ["m1", "q1"] {
        for k in 0..10 {
            let t = k as f64;
            s.put(&format!("attitude/{vehicle}/gyro"), gyro(t)).await;
            s.put(&format!("attitude/{vehicle}/vectors"), star_set(t + 0.5))
                .await;
        }
    }
    s.put("attitude/m1/gyro", b"{not json".to_vec()).await;

    let sr = &s;
    wait_until_async(
        "20 estimates and the samples out of the reorder windows",
        Duration::from_secs(20),
        || async move {
            let m = sr.metrics().await;
            value(&m, "attitude_estimates_published_total", &[]) == Some(20.0)
                && value(&m, "attitude_processed_total", &[]) == Some(40.0)
        },
    )
    .await
    .unwrap();
    let m = s.metrics().await;
    for (name, want) in [
        ("attitude_received_total", 41.0),
        ("attitude_processed_total", 40.0),
        ("attitude_estimates_published_total", 20.0),
        ("attitude_ingest_overflow_total", 0.0),
        ("attitude_held_samples", 0.0),
        ("attitude_vehicles_without_series", 1.0),
    ] {
        assert_eq!(value(&m, name, &[]), Some(want), "{name}");
    }
    assert_eq!(
        value(&m, "attitude_rejected_total", &[("code", "invalid_json")]),
        Some(1.0)
    );
    for (filter, n) in [
        ("mekf", 20.0),
        ("qpf", 20.0),
        ("usque", 0.0),
        ("sghqf", 0.0),
    ] {
        assert_eq!(
            value(&m, "attitude_step_seconds_count", &[("filter", filter)]),
            Some(n),
            "{filter}: one observation per processed sample"
        );
        assert_eq!(
            value(
                &m,
                "attitude_step_seconds_bucket",
                &[("filter", filter), ("le", "+Inf")]
            ),
            Some(n)
        );
    }
    assert!(value(&m, "attitude_step_seconds_sum", &[("filter", "qpf")]).unwrap() > 0.0);
    for (filter, state) in [("mekf", "tracking"), ("qpf", "tracking")] {
        assert_eq!(
            value(
                &m,
                "attitude_vehicles",
                &[("filter", filter), ("state", state)]
            ),
            Some(1.0)
        );
    }
    let m1 = [("vehicle", "m1")];
    assert_eq!(
        value(&m, "attitude_vehicle_received_total", &m1),
        Some(20.0)
    );
    assert_eq!(
        value(&m, "attitude_vehicle_processed_total", &m1),
        Some(20.0)
    );
    assert_eq!(
        value(&m, "attitude_vehicle_estimates_published_total", &m1),
        Some(10.0)
    );
    assert_eq!(
        value(
            &m,
            "attitude_vehicle_rejected_total",
            &[("vehicle", "m1"), ("code", "invalid_json")]
        ),
        Some(1.0)
    );
    assert!(
        !m.keys()
            .any(|(_, labels)| labels.get("vehicle").map(String::as_str) == Some("q1")),
        "q1 is beyond max_vehicles: no series of its own"
    );

    // Every reply and publication is JSON and says so.
    for key in [
        "attitude/m1/attitude",
        "attitude/m1/covariance",
        "attitude/m1/state",
        "attitude/*/attitude",
        "attitude/@/vehicles",
        "attitude/@/health",
        "attitude/@/instance/*/health",
        "attitude/@/instance/*/vehicles",
        "attitude/nobody/attitude",
        "attitude/m1/reset",
    ] {
        let r = replies(&s.client, key).await;
        assert!(!r.is_empty(), "{key}: no reply");
        for (_, reply) in r {
            let (encoding, _) = match &reply {
                Ok(x) | Err(x) => x,
            };
            assert_eq!(encoding, "application/json", "{key}");
        }
    }
    let published = published.lock().unwrap().clone();
    assert!(published.iter().any(|(leaf, _)| leaf == "estimate"));
    assert!(published.iter().any(|(leaf, _)| leaf == "rejected"));
    for (leaf, encoding) in &published {
        assert_eq!(encoding, "application/json", "{leaf}");
    }
    s.stop().await;
}

/// A GET over HTTP/1.0 (the server closes after the reply): status, headers (lower-case names), body.
fn http_get(addr: std::net::SocketAddr, path: &str) -> (u16, BTreeMap<String, String>, Vec<u8>) {
    let mut c = std::net::TcpStream::connect(addr).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    write!(c, "GET {path} HTTP/1.0\r\nHost: {addr}\r\n\r\n").unwrap();
    let mut raw = Vec::new();
    c.read_to_end(&mut raw).unwrap();
    let split = raw.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
    let head = String::from_utf8(raw[..split].to_vec()).unwrap();
    let mut lines = head.split("\r\n");
    let status = lines
        .next()
        .unwrap()
        .split(' ')
        .nth(1)
        .unwrap()
        .parse()
        .unwrap();
    let headers = lines
        .filter_map(|l| l.split_once(':'))
        .map(|(k, v)| (k.trim().to_ascii_lowercase(), v.trim().to_string()))
        .collect();
    (status, headers, raw[split + 4..].to_vec())
}

/// zenoh's REST plugin inside the service: an attitude as JSON (the plugin's list of samples, and the
/// raw reply with its Content-Type), and the metrics text as Prometheus scrapes it (`?_raw=true`).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_rest_plugin_serves_an_attitude_and_the_metrics_over_http() {
    let port = free_port();
    let (s, addr) = start(r#"{ service: { filter: { kind: "mekf" } } }"#, Some(port)).await;
    let addr = addr.expect("the REST plugin runs");
    assert_eq!(addr.port(), port);
    s.put("attitude/sc1/vectors", star_set(1.0)).await;
    let sr = &s;
    wait_until_async(
        "an estimate of sc1",
        Duration::from_secs(10),
        || async move {
            let m = sr.metrics().await;
            value(&m, "attitude_estimates_published_total", &[]) == Some(1.0)
        },
    )
    .await
    .unwrap();
    let (status, headers, body) =
        tokio::task::spawn_blocking(move || http_get(addr, "/attitude/sc1/attitude"))
            .await
            .unwrap();
    assert_eq!(status, 200);
    assert_eq!(headers["content-type"], "application/json");
    let samples: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(samples[0]["key"], "attitude/sc1/attitude");
    assert_eq!(samples[0]["encoding"], "application/json");
    let a: AttitudeMsg = serde_json::from_value(samples[0]["value"].clone()).unwrap();
    assert_eq!((a.vehicle.as_str(), a.t), ("sc1", 1.0));

    let (status, headers, body) =
        tokio::task::spawn_blocking(move || http_get(addr, "/attitude/sc1/attitude?_raw=true"))
            .await
            .unwrap();
    assert_eq!(status, 200);
    assert_eq!(headers["content-type"], "application/json");
    let raw: AttitudeMsg = serde_json::from_slice(&body).unwrap();
    assert_eq!(raw, a);

    let (status, headers, body) =
        tokio::task::spawn_blocking(move || http_get(addr, "/attitude/@/metrics?_raw=true"))
            .await
            .unwrap();
    assert_eq!(status, 200);
    assert_eq!(headers["content-type"], METRICS_ENCODING);
    let m = parse_openmetrics(std::str::from_utf8(&body).unwrap());
    assert_eq!(
        value(
            &m,
            "attitude_vehicle_estimates_published_total",
            &[("vehicle", "sc1")]
        ),
        Some(1.0)
    );
    s.stop().await;
}

/// A port that is taken is an error at start, not a log line.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_taken_http_port_is_an_error() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port();
    let mut zc = zenoh::Config::from_json5(
        r#"{mode: "peer", listen: {endpoints: ["tcp/127.0.0.1:0"]}, scouting: {multicast: {enabled: false}}}"#,
    )
    .unwrap();
    zc.insert_json5("plugins/rest/http_port", &format!("\"127.0.0.1:{port}\""))
        .unwrap();
    let e = session::open(zc).await.err().expect("an error");
    assert!(
        e.to_string()
            .contains("HTTP (zenoh's REST plugin): cannot listen on"),
        "{e}"
    );
}

/// `# TYPE` lines: family name → type.
fn families(text: &str) -> BTreeMap<String, String> {
    text.lines()
        .filter_map(|l| l.strip_prefix("# TYPE "))
        .map(|l| {
            let (name, kind) = l.split_once(' ').unwrap();
            (name.to_string(), kind.to_string())
        })
        .collect()
}

/// The families the service writes (an engine fed a good and a refused input, so that every
/// per-vehicle family has a series) are those of proto/README.md's table and of
/// proto/examples/metrics.txt, with the same types.
#[test]
fn the_metrics_families_are_those_of_the_contract() {
    let (node, threads, _) = collecting_engine(service_config("{}"));
    for (leaf, payload) in [("vectors", star_set(1.0)), ("gyro", b"{not json".to_vec())] {
        node.engine.dispatch(Inbound {
            key: format!("attitude/sc1/{leaf}"),
            payload,
        });
    }
    threads.shutdown();
    let text = node.metrics_text(0);
    let written = families(&text);
    assert_eq!(
        value(
            &parse_openmetrics(&text),
            "attitude_vehicle_rejected_total",
            &[("vehicle", "sc1"), ("code", "invalid_json")]
        ),
        Some(1.0)
    );

    let example = std::fs::read_to_string(proto_dir().join("examples/metrics.txt")).unwrap();
    parse_openmetrics(&example);
    assert_eq!(families(&example), written, "proto/examples/metrics.txt");

    let readme = std::fs::read_to_string(proto_dir().join("README.md")).unwrap();
    let section = readme
        .split("### Metrics (`P/@/metrics`)")
        .nth(1)
        .expect("proto/README.md has a section ### Metrics")
        .split("\n#")
        .next()
        .unwrap();
    let mut table = BTreeMap::new();
    for row in section.lines().filter(|l| l.starts_with("| `")) {
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        for name in cells[1].split(", ") {
            table.insert(name.trim_matches('`').to_string(), cells[2].to_string());
        }
    }
    assert_eq!(table, written, "the table of proto/README.md");
}

/// `serve --rest-http-port` with something that is not a port: the command fails at once and says why.
#[test]
fn serve_refuses_a_bad_rest_http_port() {
    let out = crate::common::service_bin()
        .args([
            "serve",
            "--listen",
            "tcp/127.0.0.1:0",
            "--rest-http-port",
            "eighty",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("plugins/rest (--rest-http-port): invalid port"),
        "{stderr}"
    );
}
