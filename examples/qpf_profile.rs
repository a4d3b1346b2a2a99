//! A steady-state particle-filter loop for profilers (perf, callgrind):
//! `cargo run --release --example qpf_profile -- [steps] [particles] [spec]`.

use attitude_service::tools::bench::SteadyState;

fn main() {
    let mut args = std::env::args().skip(1);
    let steps: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(2000);
    let particles: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(1000);
    let spec = args.next().unwrap_or_else(|| "qpf:average".into());
    let mut s = SteadyState::new(&spec, particles).expect("a valid filter");
    let start = std::time::Instant::now();
    let mut stages = 0u64;
    for _ in 0..steps {
        s.step().expect("a steady step");
        stages += s.filter.estimate().diagnostics.pc_stages.unwrap_or(0) as u64;
    }
    let per = start.elapsed().as_secs_f64() / steps as f64;
    println!(
        "{spec}, {particles} particles: {:.1} us/step, {:.1} ns/particle-step, {:.2} progressive-correction stages per update, {:?} resamplings",
        per * 1e6,
        per * 1e9 / particles as f64,
        stages as f64 / steps as f64,
        s.filter.estimate().diagnostics.resamples
    );
}
