//! Standard normal draws per nanosecond on a busy machine: our Ziggurat (one draw at a time, and in
//! pairs as the particle filter draws them) against `rand_distr::StandardNormal`, on the same generator
//! (Xoshiro256++). The three are interleaved in short blocks (20 000 draws, ≈ 50 µs) for many rounds,
//! so that other processes slow all three alike; it prints each one's min / median ns per draw and the
//! median of the per-round ratios. The criterion group `normal` of `benches/filters.rs` measures the
//! same loops one after the other. `cargo run --release --example normal_draws -- [rounds]`.

use attitude_service::rng::Xoshiro256PlusPlus;
use attitude_service::rng::{ziggurat, Ziggurat};
use rand::{Rng, SeedableRng};
use std::hint::black_box;
use std::time::Instant;

const DRAWS: usize = 20_000;

/// `DRAWS` normals from the generator, summed.
type Sampler = fn(Ziggurat, &mut Xoshiro256PlusPlus) -> f64;

#[inline(never)]
fn single(z: Ziggurat, rng: &mut Xoshiro256PlusPlus) -> f64 {
    (0..DRAWS).map(|_| z.sample(rng)).sum()
}

#[inline(never)]
fn pairs(z: Ziggurat, rng: &mut Xoshiro256PlusPlus) -> f64 {
    (0..DRAWS / 2)
        .map(|_| {
            let (u, v) = z.sample_pair(rng);
            u + v
        })
        .sum()
}

#[inline(never)]
fn rand_distr_normal(_: Ziggurat, rng: &mut Xoshiro256PlusPlus) -> f64 {
    (0..DRAWS)
        .map(|_| rng.sample::<f64, _>(rand_distr::StandardNormal))
        .sum()
}

fn main() {
    let rounds: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(3000);
    let samplers: [(&str, Sampler); 3] = [
        ("ziggurat", single),
        ("ziggurat pairs", pairs),
        ("rand_distr StandardNormal", rand_distr_normal),
    ];
    let z = ziggurat();
    let mut rngs = [0; 3].map(|_| Xoshiro256PlusPlus::seed_from_u64(1));
    let mut ns: [Vec<f64>; 3] = Default::default();
    for round in 0..rounds {
        for k in 0..3 {
            // Rotate the order so that none always runs first.
            let k = (k + round) % 3;
            let start = Instant::now();
            black_box(samplers[k].1(z, &mut rngs[k]));
            ns[k].push(start.elapsed().as_secs_f64() * 1e9 / DRAWS as f64);
        }
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    for (k, (name, _)) in samplers.iter().enumerate() {
        let min = ns[k].iter().copied().fold(f64::INFINITY, f64::min);
        println!(
            "{name:26} min {min:.2} ns/draw, median {:.2} ns/draw",
            median(ns[k].clone())
        );
    }
    for (k, name) in [(0, "ziggurat"), (1, "ziggurat pairs")] {
        let ratios = ns[k].iter().zip(&ns[2]).map(|(a, b)| a / b).collect();
        println!(
            "{name} / StandardNormal: {:.2} (median of per-round ratios)",
            median(ratios)
        );
    }
}
