//! What subscriptions per routing bucket cost zenoh: two peer sessions in one process on a loopback TCP
//! link, one subscribing (per layout), the other putting small messages on undeclared keys; the
//! process's CPU time per message delivered.
//!
//!   cargo run --release --example route_cost -- [MESSAGES]

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use zenoh::Wait;

fn cpu_s() -> f64 {
    // utime + stime of this process (fields 14 and 15 of /proc/self/stat), in clock ticks of 10 ms.
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap();
    let rest = &stat[stat.rfind(')').unwrap() + 2..];
    let f: Vec<&str> = rest.split(' ').collect();
    (f[11].parse::<f64>().unwrap() + f[12].parse::<f64>().unwrap()) / 100.0
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

fn bucket(v: &str) -> u8 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in v.bytes() {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h as u8
}

#[tokio::main(flavor = "multi_thread", worker_threads = 2)]
async fn main() {
    let messages: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(200_000);
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    // (name, key of a vehicle, the subscriptions of the measured session)
    type Layout = (String, Box<dyn Fn(&str) -> String>, Vec<String>);
    let flat = |b: u32, held: u32| -> Layout {
        (
            format!("P/*/*/<rr>: {b} buckets, subscribing to {held}"),
            Box::new(move |v: &str| format!("p/{v}/gyro/{:02x}", bucket(v) as u32 % b)),
            (0..held).map(|k| format!("p/*/*/{k:02x}")).collect(),
        )
    };
    let first = |b: u32, held: u32| -> Layout {
        (
            format!("P/<rr>/V/<leaf>: {b} buckets, subscribing to {held}"),
            Box::new(move |v: &str| format!("p/{:02x}/{v}/gyro", bucket(v) as u32 % b)),
            (0..held).map(|k| format!("p/{k:02x}/*/*")).collect(),
        )
    };
    let layouts: Vec<Layout> = vec![
        (
            "plain P/*/gyro (one subscription)".into(),
            Box::new(|v: &str| format!("p/{v}/gyro")),
            vec!["p/*/gyro".into()],
        ),
        flat(256, 256),
        flat(256, 128),
        flat(64, 64),
        flat(64, 32),
        flat(16, 16),
        flat(16, 8),
        flat(16, 4),
        flat(16, 1),
        first(256, 128),
        first(64, 32),
        first(16, 16),
        first(16, 8),
        first(16, 4),
        (
            "P/*/*/<x$*>: 256 buckets, 16 prefix subscriptions".into(),
            Box::new(|v: &str| format!("p/{v}/gyro/{:02x}", bucket(v))),
            (0..16).map(|k| format!("p/*/*/{k:x}$*")).collect(),
        ),
    ];
    let server = zenoh::open(config(Some(port), None)).await.unwrap();
    // Another member: subscribes to the buckets the measured one does not hold.
    let other = zenoh::open(config(None, Some(port))).await.unwrap();
    let client = zenoh::open(config(None, Some(port))).await.unwrap();
    let vehicles: Vec<String> = (0..1000).map(|i| format!("load{i}")).collect();
    for ((name, key_of, subs), declare) in layouts.iter().flat_map(|l| [(l, false), (l, true)]) {
        let got = Arc::new(AtomicU64::new(0));
        let mut declared = Vec::new();
        for s in subs {
            let g = got.clone();
            declared.push(
                server
                    .declare_subscriber(s.clone())
                    .callback(move |_| {
                        g.fetch_add(1, Ordering::Relaxed);
                    })
                    .await
                    .unwrap(),
            );
        }
        let mut others = Vec::new();
        if std::env::var("OTHER").is_ok() && subs.len() > 1 && subs.len() < 256 {
            let total: usize = if name.contains("256 buckets") {
                256
            } else if name.contains("64 buckets") {
                64
            } else {
                16
            };
            for k in subs.len()..total {
                others.push(
                    other
                        .declare_subscriber(format!("p/*/*/{k:02x}"))
                        .callback(|_| {})
                        .await
                        .unwrap(),
                );
            }
        }
        // Only the vehicles of the buckets subscribed to (every put is delivered).
        let keys: Vec<String> = vehicles
            .iter()
            .map(|v| key_of(v))
            .filter(|k| {
                let k = zenoh::key_expr::KeyExpr::try_from(k.as_str()).unwrap();
                subs.iter().any(|s| {
                    zenoh::key_expr::KeyExpr::try_from(s.as_str())
                        .unwrap()
                        .intersects(&k)
                })
            })
            .collect();
        // Declared key expressions: the routes are cached per key.
        let declared_keys: Vec<zenoh::key_expr::KeyExpr<'static>> = if declare {
            let mut v = Vec::new();
            for k in &keys {
                v.push(client.declare_keyexpr(k.clone()).await.unwrap());
            }
            v
        } else {
            keys.iter()
                .map(|k| zenoh::key_expr::KeyExpr::try_from(k.clone()).unwrap())
                .collect()
        };
        // Declarations propagate; then a warm-up.
        tokio::time::sleep(Duration::from_millis(500)).await;
        let payload = vec![b'x'; 60];
        let run = |n: u64| {
            for i in 0..n {
                client
                    .put(
                        declared_keys[(i % keys.len() as u64) as usize].clone(),
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
            "{name:52} {:8} {:6.2} µs CPU per message ({:.0} messages/s; {} of {} delivered)",
            if declare { "declared" } else { "" },
            (c1 - c0) / messages as f64 * 1e6,
            messages as f64 / w1,
            got.load(Ordering::Relaxed) + messages - want,
            messages
        );
        for k in declared_keys.into_iter().filter(|_| declare) {
            client.undeclare(k).await.unwrap();
        }
        for d in others {
            d.undeclare().await.unwrap();
        }
        for d in declared {
            d.undeclare().await.unwrap();
        }
        tokio::time::sleep(Duration::from_millis(300)).await;
    }
}
