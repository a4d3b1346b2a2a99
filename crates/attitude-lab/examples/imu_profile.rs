//! One recorded IMU trial through a vehicle of the service, over and over, for profilers (perf,
//! callgrind): the loop of `attitude-lab imu-bench` without the process start-up and file reading
//! in every run. `cargo run --release --example imu_profile -- TRIAL [runs] [config]`.

use attitude_lab::tools::imu_bench::bench_trial;
use attitude_lab::tools::imu_study::{load_config, read_trial, Setup};
use std::alloc::{GlobalAlloc, Layout, System};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

/// Counts allocations, to show what the loop allocates per sample.
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
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn main() {
    let mut args = std::env::args().skip(1);
    let trial = args
        .next()
        .expect("a trial file of scripts/broad-export.py");
    let runs: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(20);
    let config = args.next().unwrap_or_else(|| "config/imu.json5".into());
    let service = load_config(Path::new(&config), &[]).expect("a valid configuration");
    let setup = Setup::new(&service, None, None);
    let trial = read_trial(Path::new(&trial)).expect("a trial file");
    let n = trial.samples.len() as f64;
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    let mut ns: Vec<f64> = (0..runs)
        .map(|_| bench_trial(&trial, &setup, "profile").seconds * 1e9 / n)
        .collect();
    let allocations = (ALLOCATIONS.load(Ordering::Relaxed) - before) as f64 / (n * runs as f64);
    ns.sort_by(f64::total_cmp);
    println!(
        "{}: {} samples, {runs} runs: best {:.1} ns/sample ({:.2} M samples/s), median {:.1}; {allocations:.3} allocations per sample",
        trial.name,
        trial.samples.len(),
        ns[0],
        1e3 / ns[0],
        ns[runs / 2]
    );
}
