//! Per-step cost of every filter at its default size (gyro propagation + an update with three vector
//! observations), the quaternion average, the wire messages, and the particle filter's normal draws
//! (our Ziggurat against `rand_distr::StandardNormal`). `cargo bench`; one group: `cargo bench --bench
//! filters -- normal`.

use attitude_core::attitude::{weighted_average, Quaternion};
use attitude_core::rng::{fill_normals, ziggurat, Xoshiro256PlusPlus};
use attitude_core::simd::Isa;
use attitude_lab::tools::bench::SteadyState;
use attitude_service::wire::{decode_batch, EstimateMsg, GyroMsg, ImuMsg, VectorsMsg};
use criterion::{black_box, criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};

fn filters(c: &mut Criterion) {
    let mut group = c.benchmark_group("step (gyro + 3 vectors)");
    for (name, spec, n) in [
        ("mekf", "mekf", 0),
        ("usque:average", "usque:average", 0),
        ("usque:propagated", "usque:propagated", 0),
        ("qpf:average/250", "qpf:average", 250),
        ("qpf:average/1000", "qpf:average", 1000),
        ("qpf:average/4000", "qpf:average", 4000),
        ("qpf:propagated/1000", "qpf:propagated", 1000),
    ] {
        let b = std::cell::RefCell::new(SteadyState::new(spec, n.max(2)).unwrap());
        group.bench_function(name, |bench| {
            bench.iter_batched(
                || b.borrow_mut().measurements(),
                |(g, v)| {
                    let mut b = b.borrow_mut();
                    b.filter.process(&g).unwrap();
                    b.filter.process(&v).unwrap();
                },
                BatchSize::SmallInput,
            )
        });
    }
    group.finish();
}

fn average(c: &mut Criterion) {
    let qs: Vec<Quaternion> = (0..1000)
        .map(|i| {
            let x = (i as f64 * 0.37).sin() * 0.01;
            Quaternion::from_rotation_vector(&Vector3::new(x, -x * 0.5, x * 0.3))
        })
        .collect();
    let w: Vec<f64> = (0..1000).map(|i| 1.0 + (i % 7) as f64).collect();
    c.bench_function("weighted quaternion average, 1000", |b| {
        b.iter(|| weighted_average(black_box(&qs), black_box(&w), None).unwrap())
    });
}

fn wire(c: &mut Criterion) {
    let gyro = br#"{"t": 12.5, "omega": [0.001, -0.002, 0.0005]}"#;
    let vectors = br#"{"t": 12.5, "obs": [{"body": [0.1, 0.2, 0.97], "ref": [0.0, 0.0, 1.0], "sigma": 2.9e-5, "sensor": "st1"},
        {"body": [0.3, 0.2, 0.93], "ref": [0.2, 0.0, 0.98], "sigma": 2.9e-5, "sensor": "st1"},
        {"body": [0.1, 0.4, 0.91], "ref": [0.0, 0.3, 0.95], "sigma": 2.9e-5, "sensor": "st1"}]}"#;
    let limits = Default::default();
    c.bench_function("parse gyro", |b| {
        b.iter(|| decode_batch::<GyroMsg>(black_box(gyro), &limits).unwrap())
    });
    c.bench_function("parse vectors (3 obs)", |b| {
        b.iter(|| decode_batch::<VectorsMsg>(black_box(vectors), &limits).unwrap())
    });
    // The P/V/imu load: one sample per put, and a batch of 100 (per batch; divide for per sample).
    let imu = br#"{"t": 12.5, "gyr": [0.001, -0.002, 0.0005], "acc": [0.12, -0.05, 9.81], "mag": [0.2, 15.6, -41.7]}"#;
    let imu_batch = format!(
        "[{}]",
        (0..100)
            .map(|i| format!(
                r#"{{"t": {}, "gyr": [0.001, -0.002, 0.0005], "acc": [0.12, -0.05, 9.81], "mag": [0.2, 15.6, -41.7]}}"#,
                12.5 + 0.01 * i as f64
            ))
            .collect::<Vec<_>>()
            .join(", ")
    );
    c.bench_function("parse imu", |b| {
        b.iter(|| decode_batch::<ImuMsg>(black_box(imu), &limits).unwrap())
    });
    c.bench_function("parse imu batch (100)", |b| {
        b.iter(|| decode_batch::<ImuMsg>(black_box(imu_batch.as_bytes()), &limits).unwrap())
    });
    let mut bench = SteadyState::new("qpf:average", 300).unwrap();
    bench.step().unwrap();
    let e = bench.filter.estimate();
    let spec = bench.filter.spec();
    c.bench_function("serialise estimate", |b| {
        b.iter(|| {
            serde_json::to_vec(&EstimateMsg::from_domain(
                "sc1",
                &spec,
                black_box(&e),
                1,
                Some(300),
            ))
            .unwrap()
        })
    });
}

/// Standard normal draws from the particle filter's generator (Xoshiro256++), per draw: the Ziggurat
/// of `crate::rng` one draw at a time, on eight generators side by side as the QPF draws them
/// (`fill_normals`, the detected instruction set), and `rand_distr::StandardNormal`.
fn normal(c: &mut Criterion) {
    const DRAWS: usize = 1024;
    let mut group = c.benchmark_group("normal");
    group.throughput(Throughput::Elements(DRAWS as u64));
    let z = ziggurat();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    group.bench_function("ziggurat", |b| {
        b.iter(|| (0..DRAWS).map(|_| z.sample(&mut rng)).sum::<f64>())
    });
    let mut rows = vec![[0.0; 8]; DRAWS / 8];
    let mut key = 0;
    group.bench_function("ziggurat lanes", |b| {
        b.iter(|| {
            key += 1;
            fill_normals(Isa::active(), key, 0, &mut rows);
            rows[0][0]
        })
    });
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    group.bench_function("rand_distr StandardNormal", |b| {
        b.iter(|| {
            (0..DRAWS)
                .map(|_| rng.sample::<f64, _>(rand_distr::StandardNormal))
                .sum::<f64>()
        })
    });
    group.finish();
}

criterion_group!(benches, filters, average, wire, normal);
criterion_main!(benches);
