//! The service's own work per estimate, without zenoh (BENCHMARKS.md, "The engine alone"): the engine
//! of `serve` (dispatcher, workers, housekeeping; `config/default.json5` with the MEKF) takes the
//! inputs `attitude-lab loadgen` sends (per vehicle and tick, a vector set of three stars and a gyro
//! sample, JSON) on its ingest channel, where zenoh's subscriber callbacks hand them, and every estimate
//! is serialised for a subscriber that takes it. A tick's inputs of every vehicle go in at once (a
//! burst), then the next tick once every estimate of this one is out.
//!
//!   cargo run --release --example engine_cost -- [VEHICLES] [TICKS] [CONFIG]
//!
//! Printed (one JSON line): the engine threads' CPU time per estimate (`/proc/self/task/*/stat`, the
//! threads named `attitude-*`; the feeding thread is not counted), allocations per estimate (every
//! thread's: the inputs are made before the count starts), and the wall time. Under `valgrind
//! --tool=callgrind`, two runs with different TICKS give the instructions per estimate by difference
//! (the start-up cancels); `callgrind_annotate --inclusive=yes` splits them by stage. zenoh's own work
//! on the three messages (receiving, routing, sending) is not in these figures: `examples/route_cost.rs`
//! and the load tools measure it.

use attitude_service::engine::{Alone, Engine, EstimateOutlet, Inbound, Outlets, Sink};
use attitude_service::service::config::parse;
use attitude_service::tools::synthetic::star_set;
use attitude_service::wire::keys::{Keys, Leaf};
use attitude_service::wire::GyroMsg;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// The system allocator (what `attitude-service` links is its own `main.rs`'s choice), counted.
struct Counting;

static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// CPU time, s, of this process's threads whose name starts with `attitude-` (the engine's).
fn engine_cpu_s() -> f64 {
    let mut total = 0.0;
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return f64::NAN;
    };
    for task in tasks.flatten() {
        let comm = std::fs::read_to_string(task.path().join("comm")).unwrap_or_default();
        if !comm.starts_with("attitude-") {
            continue;
        }
        let stat = std::fs::read_to_string(task.path().join("stat")).unwrap_or_default();
        let rest = &stat[stat.rfind(')').map_or(0, |i| i + 2)..];
        let f: Vec<&str> = rest.split(' ').collect();
        let ticks = |i: usize| f.get(i).and_then(|s| s.parse::<f64>().ok()).unwrap_or(0.0);
        total += (ticks(11) + ticks(12)) / 100.0;
    }
    total
}

/// An outlet whose subscriber takes every estimate (the engine serialises each), counted.
struct Taken {
    puts: Arc<AtomicU64>,
    bytes: Arc<AtomicU64>,
}

impl EstimateOutlet for Taken {
    fn wanted(&self) -> bool {
        true
    }
    fn put(&self, payload: Vec<u8>) {
        self.bytes
            .fetch_add(payload.len() as u64, Ordering::Relaxed);
        self.puts.fetch_add(1, Ordering::Release);
    }
}

fn main() {
    let mut args = std::env::args().skip(1);
    let vehicles: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(1000);
    let ticks: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(50);
    let text = match args.next() {
        Some(path) => std::fs::read_to_string(&path).expect("a configuration file"),
        None => r#"{ service: { filter: { kind: "mekf" } } }"#.to_string(),
    };
    let config = parse(&text, "engine_cost")
        .expect("a valid configuration")
        .service;
    let keys = Keys::new(&config.key_prefix);
    let (puts, bytes) = (Arc::new(AtomicU64::new(0)), Arc::new(AtomicU64::new(0)));
    let outlets: Outlets = {
        let (puts, bytes) = (puts.clone(), bytes.clone());
        Arc::new(move |_key: &str| {
            Box::new(Taken {
                puts: puts.clone(),
                bytes: bytes.clone(),
            }) as Box<dyn EstimateOutlet>
        })
    };
    let sink: Sink = Arc::new(|_: &str, _: Vec<u8>| {});
    let (engine, threads) =
        Engine::start(config, sink, outlets, Arc::new(Alone)).expect("the engine starts");

    // Every input made first, as loadgen sends it: the vector set, then the gyro sample.
    let ids: Vec<String> = (0..vehicles).map(|i| format!("veh-{i:05}")).collect();
    let mut inputs: Vec<Vec<Inbound>> = (0..ticks)
        .map(|k| {
            let t = k as f64 * 0.1;
            ids.iter()
                .enumerate()
                .flat_map(|(i, id)| {
                    [
                        Inbound {
                            key: keys.vehicle(id, Leaf::Vectors),
                            payload: serde_json::to_vec(&star_set(t, i)).unwrap(),
                        },
                        Inbound {
                            key: keys.vehicle(id, Leaf::Gyro),
                            payload: serde_json::to_vec(&GyroMsg { t, omega: [0.0; 3] }).unwrap(),
                        },
                    ]
                })
                .collect()
        })
        .collect();

    let (cpu0, alloc0, wall0) = (
        engine_cpu_s(),
        ALLOCATIONS.load(Ordering::Relaxed),
        Instant::now(),
    );
    for (k, tick) in inputs.drain(..).enumerate() {
        for inbound in tick {
            if threads.ingest.send(Some(inbound.into())).is_err() {
                panic!("the engine stopped");
            }
        }
        let want = ((k + 1) * vehicles) as u64;
        while puts.load(Ordering::Acquire) < want {
            std::thread::sleep(std::time::Duration::from_micros(200));
        }
    }
    let (cpu, allocations, wall) = (
        engine_cpu_s() - cpu0,
        ALLOCATIONS.load(Ordering::Relaxed) - alloc0,
        wall0.elapsed().as_secs_f64(),
    );
    let estimates = puts.load(Ordering::Relaxed);
    threads.shutdown();
    drop(engine);
    let n = estimates as f64;
    println!(
        "{}",
        serde_json::json!({
            "vehicles": vehicles,
            "ticks": ticks,
            "estimates": estimates,
            "engine_cpu_us_per_estimate": cpu * 1e6 / n,
            "allocations_per_estimate": allocations as f64 / n,
            "bytes_per_estimate": bytes.load(Ordering::Relaxed) as f64 / n,
            "wall_s": wall,
        })
    );
}
