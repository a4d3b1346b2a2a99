//! Per-step cost of every filter at its default size (gyro propagation + an update with three vector
//! observations), the quaternion average, and the wire messages. `cargo bench`.

use attitude_service::attitude::{weighted_average, Quaternion};
use attitude_service::filters::{build_filter, AttitudeFilter, FilterConfig, InitialState};
use attitude_service::sensors::{
    GyroNoise, GyroSample, Measurement, ObservationSet, VectorObservation,
};
use attitude_service::wire::{decode_batch, EstimateMsg, GyroMsg, VectorsMsg};
use criterion::{black_box, criterion_group, criterion_main, BatchSize, Criterion};
use nalgebra::Vector3;

const DT: f64 = 0.1;

/// A steady-state filter and a generator of its next (gyro, vectors) pair.
struct Bench {
    filter: Box<dyn AttitudeFilter>,
    truth: Quaternion,
    t: f64,
    omega: Vector3<f64>,
}

impl Bench {
    fn new(spec: &str, particles: usize) -> Bench {
        let mut config = FilterConfig::new(spec.parse().unwrap(), GyroNoise::standard());
        config.particles = particles;
        let truth = Quaternion::new(0.1, -0.2, 0.3, 0.9).normalized().unwrap();
        let init = InitialState {
            t_s: Some(0.0),
            q: truth,
            sigma_att_rad: Vector3::repeat(1e-3),
            bias_rad_s: Vector3::zeros(),
            bias_sigma_rad_s: Vector3::repeat(1e-6),
            uniform_attitude: false,
        };
        let mut b = Bench {
            filter: build_filter(&config, &init, 1).unwrap(),
            truth,
            t: 0.0,
            omega: Vector3::new(0.01, -0.02, 0.005),
        };
        for _ in 0..50 {
            b.step();
        }
        b
    }

    fn measurements(&mut self) -> (Measurement, Measurement) {
        let gyro = Measurement::Gyro(GyroSample {
            t_s: self.t,
            omega_body_rad_s: self.omega,
        });
        self.truth = self.truth.propagate(&self.omega, DT);
        self.t += DT;
        let a = self.truth.attitude_matrix();
        let refs = [
            Vector3::x(),
            Vector3::new(0.0, 0.6, 0.8),
            Vector3::new(0.0, -0.8, 0.6),
        ];
        let observations = refs
            .iter()
            .map(|r| VectorObservation {
                body: a * r,
                reference: *r,
                sigma: 1e-4,
                sensor: None,
            })
            .collect();
        (
            gyro,
            Measurement::Vectors(ObservationSet {
                t_s: self.t,
                observations,
            }),
        )
    }

    fn step(&mut self) {
        let (g, v) = self.measurements();
        self.filter.process(&g).unwrap();
        self.filter.process(&v).unwrap();
    }
}

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
        let b = std::cell::RefCell::new(Bench::new(spec, n.max(2)));
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
    let mut bench = Bench::new("qpf:average", 300);
    bench.step();
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

criterion_group!(benches, filters, average, wire);
criterion_main!(benches);
