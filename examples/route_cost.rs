//! What subscribing by route costs zenoh 1.10 (DEPLOYMENT.md, "What routing costs zenoh"): two peer
//! sessions in one process on a loopback TCP link; one subscribes to some routes of a key layout (and a
//! third session, another "member", to the others), the other puts small messages on undeclared keys
//! of the routes subscribed to. Printed: this process's CPU time per message delivered.
//!
//!   cargo run --release --example route_cost -- [MESSAGES]
//!
//! zenoh matches a received key against every subscription of the session and walks its routing tree
//! over the declared key expressions. As published, zenoh 1.10.2 visited every declared sibling on that
//! walk, so the cost grew with the number of subscriptions, which is why a fleet uses 16 routes and few
//! subscriptions per member, not a route per vehicle or hundreds of buckets; this build's zenoh looks a
//! verbatim chunk up instead and keeps an undeclared key's route until a declaration changes
//! (vendor/README.md), a stock router does neither.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use zenoh::Wait;

/// This process's CPU time (utime + stime, /proc/self/stat), s.
fn cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let rest = &stat[stat.rfind(')').map_or(0, |i| i + 2)..];
    let f: Vec<&str> = rest.split(' ').collect();
    let ticks = |i: usize| f.get(i).and_then(|s| s.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

fn config(listen: Option<u16>, connect: Option<u16>) -> zenoh::Config {
    let mut c = zenoh::Config::default();
    c.insert_json5("mode", "\"peer\"").unwrap();
    c.insert_json5("scouting/multicast/enabled", "false")
        .unwrap();
    if let Some(p) = listen {
        c.insert_json5("listen/endpoints", &format!("[\"tcp/127.0.0.1:{p}\"]"))
            .unwrap();
    }
    if let Some(p) = connect {
        c.insert_json5("connect/endpoints", &format!("[\"tcp/127.0.0.1:{p}\"]"))
            .unwrap();
    }
    c
}

/// A key layout: its name, the key of a vehicle's gyro input, how many buckets it has, and the
/// subscription of bucket `b` (`None`: one subscription for all).
struct Layout {
    name: String,
    key: Box<dyn Fn(&str) -> String>,
    buckets: u32,
    held: u32,
}

#[tokio::main(flavor = "multi_thread", worker_threads = 2)]
async fn main() {
    use attitude_service::wire::keys::route_of;
    let messages: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(200_000);
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let bucketed = |buckets: u32, held: u32| Layout {
        name: format!("P/V/gyro/<b>: {buckets} buckets, {held} subscribed here"),
        key: Box::new(move |v: &str| {
            let b = if buckets == 16 {
                route_of(v) as u32
            } else {
                attitude_service::rng::fnv1a(v.bytes(), attitude_service::rng::FNV_OFFSET) as u32
                    % buckets
            };
            format!("p/{v}/gyro/{b:x}")
        }),
        buckets,
        held,
    };
    let layouts = vec![
        Layout {
            name: "P/V/gyro: one subscription P/*/gyro".into(),
            key: Box::new(|v: &str| format!("p/{v}/gyro")),
            buckets: 1,
            held: 1,
        },
        bucketed(16, 1),
        bucketed(16, 4),
        bucketed(16, 8),
        bucketed(16, 16),
        bucketed(64, 32),
        bucketed(256, 128),
    ];
    let server = zenoh::open(config(Some(port), None)).await.unwrap();
    let other = zenoh::open(config(None, Some(port))).await.unwrap();
    let client = zenoh::open(config(None, Some(port))).await.unwrap();
    let vehicles: Vec<String> = (0..1000).map(|i| format!("load{i}")).collect();
    println!("{:52} {:>14} {:>12}", "layout", "CPU/message", "messages/s");
    for l in &layouts {
        let sub_of = |b: u32| {
            if l.buckets == 1 {
                "p/*/gyro".to_string()
            } else {
                format!("p/*/*/{b:x}")
            }
        };
        let got = Arc::new(AtomicU64::new(0));
        let mut declared = Vec::new();
        for b in 0..l.held {
            let g = got.clone();
            declared.push(
                server
                    .declare_subscriber(sub_of(b))
                    .callback(move |_| {
                        g.fetch_add(1, Ordering::Relaxed);
                    })
                    .await
                    .unwrap(),
            );
        }
        // The other buckets: another member's.
        let mut others = Vec::new();
        for b in l.held..l.buckets {
            others.push(
                other
                    .declare_subscriber(sub_of(b))
                    .callback(|_| {})
                    .await
                    .unwrap(),
            );
        }
        // The vehicles of the buckets subscribed to here: every put is delivered here.
        let keys: Vec<zenoh::key_expr::KeyExpr<'static>> = vehicles
            .iter()
            .map(|v| zenoh::key_expr::KeyExpr::try_from((l.key)(v)).unwrap())
            .filter(|k| {
                (0..l.held).any(|b| {
                    zenoh::key_expr::KeyExpr::try_from(sub_of(b))
                        .unwrap()
                        .intersects(k)
                })
            })
            .collect();
        tokio::time::sleep(Duration::from_millis(500)).await;
        let payload = vec![b'x'; 60];
        let run = |n: u64| {
            for i in 0..n {
                client
                    .put(
                        keys[(i % keys.len() as u64) as usize].clone(),
                        payload.clone(),
                    )
                    .congestion_control(zenoh::qos::CongestionControl::Block)
                    .wait()
                    .unwrap();
            }
        };
        run(10_000);
        let want = got.load(Ordering::Relaxed) + messages;
        let (c0, w0) = (cpu_s(), Instant::now());
        run(messages);
        while got.load(Ordering::Relaxed) < want && w0.elapsed() < Duration::from_secs(60) {
            tokio::time::sleep(Duration::from_millis(1)).await;
        }
        let (c1, w1) = (cpu_s(), w0.elapsed().as_secs_f64());
        println!(
            "{:52} {:>11.2} µs {:>12.0}",
            l.name,
            (c1 - c0) / messages as f64 * 1e6,
            messages as f64 / w1
        );
        for d in declared.into_iter().chain(others) {
            d.undeclare().await.unwrap();
        }
        tokio::time::sleep(Duration::from_millis(300)).await;
    }
}
