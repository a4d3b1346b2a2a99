//! Standard normal draws per nanosecond on a busy machine: our Ziggurat one draw at a time, the same
//! on eight generators side by side as the particle filter draws them (`rng::fill_normals`, on every
//! instruction set this machine has), and `rand_distr::StandardNormal` on the same generator
//! (Xoshiro256++). They are interleaved in short blocks (24 576 draws) for many rounds, so that other
//! processes slow all of them alike; it prints each one's min / median ns per draw and the median of
//! the per-round ratios to `StandardNormal`. `cargo run --release --example normal_draws -- [rounds]`.

use attitude_service::rng::{fill_normals, ziggurat, Xoshiro256PlusPlus};
use attitude_service::simd::Isa;
use rand::{Rng, SeedableRng};
use std::hint::black_box;
use std::time::Instant;

const ROWS: usize = 3072;
const DRAWS: usize = ROWS * 8;

fn main() {
    let rounds: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(2000);
    let z = ziggurat();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    let mut rows = vec![[0.0; 8]; ROWS];
    let isas: Vec<Isa> = Isa::ALL.into_iter().filter(|i| i.supported()).collect();
    let mut names = vec![
        "rand_distr StandardNormal".to_string(),
        "ziggurat, one at a time".to_string(),
    ];
    names.extend(
        isas.iter()
            .map(|i| format!("ziggurat lanes ({})", i.name())),
    );
    let mut ns: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    for round in 0..rounds {
        for k in 0..names.len() {
            let k = (k + round) % names.len();
            let start = Instant::now();
            match k {
                0 => {
                    black_box(
                        (0..DRAWS)
                            .map(|_| rng.sample::<f64, _>(rand_distr::StandardNormal))
                            .sum::<f64>(),
                    );
                }
                1 => {
                    black_box((0..DRAWS).map(|_| z.sample(&mut rng)).sum::<f64>());
                }
                _ => {
                    fill_normals(isas[k - 2], round as u64, 0, &mut rows);
                    black_box(&rows);
                }
            }
            ns[k].push(start.elapsed().as_secs_f64() * 1e9 / DRAWS as f64);
        }
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    for (k, name) in names.iter().enumerate() {
        let min = ns[k].iter().copied().fold(f64::INFINITY, f64::min);
        let ratio = median(ns[k].iter().zip(&ns[0]).map(|(a, b)| a / b).collect());
        println!(
            "{name:30} min {min:.2} ns/draw, median {:.2} ns/draw, {ratio:.2}× StandardNormal",
            median(ns[k].clone())
        );
    }
}
