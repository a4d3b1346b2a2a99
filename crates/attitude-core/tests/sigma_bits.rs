//! The sigma-point filters (USQUE with three charts and λs, the SGHQF at every level, both
//! fiducials) through one fixed scenario, every estimate, refusal and saved state written out exactly
//! (`{:?}` of an `f64` is its shortest round-trip form), compared with the record of the code as it
//! was when the two filters became one (issue 29): a change of any bit of any of them fails.
//!
//! The golden file `tests/data/sigma_bits.golden` holds a digest (FNV-1a) of each section of the
//! record, one line a section. After a change meant to move the numbers, the failing test prints the
//! new lines to paste; to see what moved, write the whole record at both commits and diff them:
//! `SIGMA_BITS_OUT=/tmp/a.txt cargo test -p attitude-core --release --test sigma_bits -- --ignored`.
//!
//! The record goes through `sin`, `cos` and `exp` of the platform's libm, whose last bits are not
//! the same everywhere: the comparison runs on Linux x86-64 (where the golden was made).

use attitude_core::attitude::{Grp, Quaternion};
use attitude_core::filters::{
    build_filter, AttitudeFilter, Driver, Fiducial, FilterConfig, FilterCore, FilterSpec,
    GyroErrors, InitialState, Sghqf, Usque, UsqueOptions,
};
use attitude_core::sensors::{
    Aspect, GyroNoise, GyroSample, Measurement, ObservationSet, VectorObservation,
};
use nalgebra::{Matrix3, Matrix6, Vector3};
use std::fmt::Write;

/// SplitMix64: a fixed stream of uniform numbers, independent of any library.
struct Stream(u64);

impl Stream {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [−1, 1).
    fn sym(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
    fn vec3(&mut self, scale: f64) -> Vector3<f64> {
        Vector3::new(self.sym(), self.sym(), self.sym()) * scale
    }
}

#[derive(Clone, Copy, Debug)]
enum Kind {
    Usque(UsqueOptions),
    Sghqf(u8),
}

fn kinds() -> Vec<Kind> {
    vec![
        Kind::Usque(UsqueOptions::default()),
        // k = 4 (the MRP chart) and a λ ≠ 1: the unit conversions and the weights.
        Kind::Usque(UsqueOptions {
            grp: Grp::MRP,
            lambda: 2.5,
        }),
        // k = 2 (the Gibbs vector), a small λ.
        Kind::Usque(UsqueOptions {
            grp: Grp::GIBBS,
            lambda: 0.5,
        }),
        Kind::Sghqf(2),
        Kind::Sghqf(3),
        Kind::Sghqf(4),
    ]
}

fn config(kind: Kind, fiducial: Fiducial, errors: bool) -> FilterConfig {
    let name = match kind {
        Kind::Usque(_) => "usque",
        Kind::Sghqf(_) => "sghqf",
    };
    let spec: FilterSpec = format!("{name}:{}", fiducial.as_str()).parse().unwrap();
    let mut c = FilterConfig::new(spec, GyroNoise::standard());
    match kind {
        Kind::Usque(o) => c.usque = o,
        Kind::Sghqf(l) => c.level = l,
    }
    if errors {
        c.gyro_errors = GyroErrors {
            rate_noise_sqrt_s: 2e-3,
            bias_limit_rad_s: 1e-4,
        };
    }
    c
}

fn initial(sigma_att: f64, sigma_bias: f64) -> InitialState {
    InitialState {
        t_s: Some(0.0),
        q: Quaternion::new(0.3, -0.2, 0.5, 0.8).normalized().unwrap(),
        sigma_att_rad: Vector3::new(sigma_att, 0.8 * sigma_att, 1.3 * sigma_att),
        bias_rad_s: Vector3::new(1e-5, -2e-5, 3e-6),
        bias_sigma_rad_s: Vector3::repeat(sigma_bias),
        uniform_attitude: false,
        covariance: None,
    }
}

fn obs(
    truth: &Quaternion,
    reference: Vector3<f64>,
    sigma: f64,
    aspect: Aspect,
    s: &mut Stream,
) -> VectorObservation {
    let reference = reference.normalize();
    VectorObservation {
        body: truth.attitude_matrix() * reference + s.vec3(sigma),
        reference,
        sigma,
        sensor: None,
        aspect,
    }
}

fn record(out: &mut String, what: &str, f: &dyn AttitudeFilter) {
    writeln!(out, "{what}: {:?}", f.estimate()).unwrap();
}

fn outcome(out: &mut String, what: &str, r: Result<(), impl std::fmt::Debug>) {
    if let Err(e) = r {
        writeln!(out, "{what}: refused {e:?}").unwrap();
    }
}

/// The driven scenario: updates at the start time (twice), gyro samples with noise, vector sets with
/// full, heading and tilt observations, extra variance, bias observations, an inflation, a gyro gap,
/// repeated updates at one time, and state round trips after a propagation and after an update.
fn driven(out: &mut String, kind: Kind, fiducial: Fiducial, errors: bool, sigma_att: f64) {
    let c = config(kind, fiducial, errors);
    writeln!(
        out,
        "== {kind:?} {fiducial:?} errors={errors} sigma={sigma_att:?}"
    )
    .unwrap();
    let mut f = match build_filter(&c, &initial(sigma_att, 1e-4), 7) {
        Ok(f) => f,
        Err(e) => {
            writeln!(out, "build refused {e:?}").unwrap();
            return;
        }
    };
    let mut s = Stream(0x5eed_0000 + sigma_att.to_bits());
    let mut truth = Quaternion::new(0.31, -0.18, 0.52, 0.79)
        .normalized()
        .unwrap();
    let up = Vector3::z();
    let sun = Vector3::new(0.6, -0.3, 0.74);
    let mag = Vector3::new(0.2, 0.4, -0.9);
    let mut t = 0.0;
    let set = |f: &mut Box<dyn AttitudeFilter>, t: f64, o: Vec<VectorObservation>| {
        f.process(&Measurement::Vectors(ObservationSet {
            t_s: t,
            observations: o,
        }))
    };
    // At the start time: no propagation, the points redrawn; then again at the same time.
    let o = vec![obs(&truth, sun, 1e-3, Aspect::Full, &mut s)];
    outcome(out, "start update", set(&mut f, t, o));
    record(out, "start update", f.as_ref());
    let o = vec![
        obs(&truth, mag, 2e-3, Aspect::Full, &mut s),
        obs(&truth, sun, 1e-3, Aspect::Full, &mut s),
    ];
    outcome(out, "start update 2", set(&mut f, t, o));
    record(out, "start update 2", f.as_ref());
    let mut saved = Vec::new();
    for k in 1..=60 {
        let dt = 0.1;
        let omega = Vector3::new(0.05 * (0.1 * k as f64).sin(), -0.03, 0.02);
        let bias = Vector3::new(1e-5, -2e-5, 3e-6);
        let meas = omega + bias + s.vec3(1e-4);
        if (30..35).contains(&k) {
            // A gyro gap: no sample for half a second; the driver inflates at the next step.
            truth = truth.propagate(&omega, dt);
            t += dt;
            continue;
        }
        if k % 7 == 3 {
            outcome(
                out,
                &format!("k={k} interval"),
                f.gyro_interval_with(t, &meas, t + dt, 1e-9),
            );
        } else {
            outcome(
                out,
                &format!("k={k} gyro"),
                f.process(&Measurement::Gyro(GyroSample {
                    t_s: t,
                    omega_body_rad_s: meas,
                })),
            );
        }
        truth = truth.propagate(&omega, dt);
        t += dt;
        if k % 3 == 0 {
            let aspect = match k % 9 {
                0 => Aspect::Heading(up),
                3 => Aspect::Tilt(up),
                _ => Aspect::Full,
            };
            let o = vec![
                obs(&truth, sun, 1e-3, Aspect::Full, &mut s),
                obs(&truth, mag, 3e-3, aspect, &mut s),
            ];
            outcome(out, &format!("k={k} vectors"), set(&mut f, t, o));
        } else if k % 5 == 0 {
            let o = obs(&truth, up, 5e-3, Aspect::Tilt(up), &mut s);
            outcome(out, &format!("k={k} observe"), f.observe(t, &o));
            // Again at the same time: no propagation between.
            let o = obs(&truth, mag, 5e-3, Aspect::Full, &mut s);
            outcome(out, &format!("k={k} observe again"), f.observe(t, &o));
        } else {
            outcome(out, &format!("k={k} advance"), f.advance_to(t));
        }
        if k == 20 || k == 41 {
            let z = bias + s.vec3(1e-6);
            outcome(out, &format!("k={k} bias"), f.observe_bias(t, &z, 2e-6));
        }
        if k == 25 || k == 44 {
            let a = Matrix3::new(2.0, 0.3, -0.1, 0.3, 1.5, 0.2, -0.1, 0.2, 1.0) * 1e-7;
            outcome(out, &format!("k={k} inflate"), f.inflate_attitude(&a));
            // A refused one.
            let bad = Matrix3::new(1.0, 2.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
            outcome(out, &format!("k={k} inflate bad"), f.inflate_attitude(&bad));
        }
        record(out, &format!("k={k} t={t:?}"), f.as_ref());
        // Round trips: after a propagation (points kept) and after an update.
        if k == 16 || k == 18 || k == 45 {
            let state = f.state();
            writeln!(out, "k={k} state: {state:?}").unwrap();
            let mut into = f.state();
            f.state_into(&mut into);
            writeln!(out, "k={k} state_into equal: {}", into == state).unwrap();
            match state.restore() {
                Ok(g) => saved.push((k, g)),
                Err(e) => writeln!(out, "k={k} restore refused {e:?}").unwrap(),
            }
        }
        // The restored filters follow the same inputs below only through comparison at the end.
    }
    record(out, "end", f.as_ref());
    writeln!(out, "end state: {:?}", f.state()).unwrap();
    for (k, mut g) in saved {
        // A restored filter continues exactly as the saved one would have: one step and an update.
        let mut h = f.state().restore().unwrap();
        for x in [&mut g, &mut h] {
            let _ = x.process(&Measurement::Gyro(GyroSample {
                t_s: t,
                omega_body_rad_s: Vector3::new(0.01, 0.0, -0.01),
            }));
            let _ = x.advance_to(t + 0.1);
            let _ = x.observe(
                t + 0.1,
                &VectorObservation {
                    body: sun.normalize(),
                    reference: sun.normalize(),
                    sigma: 1e-3,
                    sensor: None,
                    aspect: Aspect::Full,
                },
            );
        }
        record(out, &format!("restored at k={k}, continued"), g.as_ref());
        record(out, "end state restored, continued", h.as_ref());
    }
}

/// Direct `FilterCore` use: empty sets, non-finite and singular observations, extra variance,
/// refused propagations, and the constructors' refusals (in their order).
fn direct(out: &mut String) {
    let q0 = Quaternion::new(0.3, -0.2, 0.5, 0.8).normalized().unwrap();
    let good = vec![
        VectorObservation {
            body: q0.attitude_matrix() * Vector3::x(),
            reference: Vector3::x(),
            sigma: 1e-3,
            sensor: None,
            aspect: Aspect::Full,
        },
        VectorObservation {
            body: q0.attitude_matrix() * Vector3::y(),
            reference: Vector3::y(),
            sigma: 1e-3,
            sensor: Some("s".into()),
            aspect: Aspect::Heading(Vector3::z()),
        },
    ];
    let singular = VectorObservation {
        body: Vector3::x(),
        reference: Vector3::zeros(),
        sigma: 0.0,
        sensor: None,
        aspect: Aspect::Full,
    };
    let nan = VectorObservation {
        body: Vector3::new(f64::NAN, 0.0, 0.0),
        ..good[0].clone()
    };
    for kind in kinds() {
        for fiducial in [Fiducial::Propagated, Fiducial::Average] {
            for errors in [false, true] {
                let c = config(kind, fiducial, errors);
                writeln!(out, "== direct {kind:?} {fiducial:?} errors={errors}").unwrap();
                for (sa, sb) in [
                    (0.01, 1e-6),
                    (10f64.to_radians(), 200f64.to_radians() / 3600.0),
                    // The averaged fiducial falls back at L = 2.
                    (100f64.to_radians(), 1f64.to_radians() / 3600.0),
                ] {
                    let init = initial(sa, sb);
                    let mut d: Box<dyn AttitudeFilter> = match kind {
                        Kind::Usque(o) => {
                            let mut f = Usque::new(&c, &init, o).unwrap();
                            steps(out, &mut f, &good, &singular, &nan);
                            Box::new(Driver::new(f, Some(0.0)))
                        }
                        Kind::Sghqf(_) => {
                            let mut f = Sghqf::new(&c, &init).unwrap();
                            steps(out, &mut f, &good, &singular, &nan);
                            Box::new(Driver::new(f, Some(0.0)))
                        }
                    };
                    writeln!(out, "direct state: {:?}", d.state()).unwrap();
                    outcome(
                        out,
                        "driver bias",
                        d.observe_bias(0.0, &Vector3::zeros(), 0.0),
                    );
                }
            }
        }
    }
    // A start from a full covariance whose zeros are negative: USQUE converts it (`k = 1` and yet
    // not to the bit: the products make the zeros positive), the SGHQF takes it as it is.
    writeln!(out, "== negative zeros").unwrap();
    let mut p = Matrix6::from_element(-0.0);
    for i in 0..6 {
        p[(i, i)] = if i < 3 { 1e-4 } else { 1e-10 };
    }
    let init = InitialState {
        covariance: Some(p),
        ..initial(0.01, 1e-6)
    };
    for kind in [Kind::Usque(UsqueOptions::default()), Kind::Sghqf(3)] {
        let c = config(kind, Fiducial::Average, false);
        let mut d: Box<dyn AttitudeFilter> = match kind {
            Kind::Usque(o) => Box::new(Driver::new(Usque::new(&c, &init, o).unwrap(), Some(0.0))),
            Kind::Sghqf(_) => Box::new(Driver::new(Sghqf::new(&c, &init).unwrap(), Some(0.0))),
        };
        record(out, &format!("{kind:?} start"), d.as_ref());
        outcome(
            out,
            "inflate",
            d.inflate_attitude(&Matrix3::from_element(-0.0)),
        );
        record(out, &format!("{kind:?} inflated"), d.as_ref());
        outcome(out, "update", d.observe(0.0, &good[0]));
        record(out, &format!("{kind:?} updated"), d.as_ref());
    }
    // The constructors' refusals, with several things wrong at once (the first check that fails).
    writeln!(out, "== constructors").unwrap();
    let good_init = initial(0.01, 1e-6);
    let bad_q = InitialState {
        q: Quaternion::new(0.0, 0.0, 0.0, 0.0),
        ..good_init.clone()
    };
    let bad_sigma = InitialState {
        sigma_att_rad: Vector3::new(0.0, 1.0, 1.0),
        ..good_init.clone()
    };
    let bad_cov = InitialState {
        covariance: Some(Matrix6::from_element(1.0)),
        ..good_init.clone()
    };
    for kind in [Kind::Usque(UsqueOptions::default()), Kind::Sghqf(3)] {
        let base = config(kind, Fiducial::Average, false);
        let mut bad_gyro = base.clone();
        bad_gyro.gyro.sigma_v = f64::NAN;
        let mut bad_errors = base.clone();
        bad_errors.gyro_errors.rate_noise_sqrt_s = -1.0;
        let mut bad_level = base.clone();
        bad_level.level = 9;
        let mut both = bad_errors.clone();
        both.gyro.sigma_u = -1.0;
        let bad_options = UsqueOptions {
            lambda: 0.0,
            ..UsqueOptions::default()
        };
        let cases: Vec<(&str, &FilterConfig, &InitialState, UsqueOptions)> = vec![
            ("good", &base, &good_init, UsqueOptions::default()),
            ("bad gyro", &bad_gyro, &good_init, UsqueOptions::default()),
            (
                "bad errors",
                &bad_errors,
                &good_init,
                UsqueOptions::default(),
            ),
            (
                "bad errors and q",
                &bad_errors,
                &bad_q,
                UsqueOptions::default(),
            ),
            (
                "bad errors and sigma",
                &bad_errors,
                &bad_sigma,
                UsqueOptions::default(),
            ),
            (
                "bad errors and cov",
                &bad_errors,
                &bad_cov,
                UsqueOptions::default(),
            ),
            (
                "bad errors and gyro",
                &both,
                &good_init,
                UsqueOptions::default(),
            ),
            ("bad q", &base, &bad_q, UsqueOptions::default()),
            ("bad sigma", &base, &bad_sigma, UsqueOptions::default()),
            ("bad cov", &base, &bad_cov, UsqueOptions::default()),
            (
                "bad level and gyro",
                &bad_level,
                &bad_q,
                UsqueOptions::default(),
            ),
            ("bad options and gyro", &bad_gyro, &bad_q, bad_options),
        ];
        for (what, c, i, o) in cases {
            let r = match kind {
                Kind::Usque(_) => Usque::new(c, i, o).map(|f| format!("{:?}", f.estimate())),
                Kind::Sghqf(_) => Sghqf::new(c, i).map(|f| format!("{:?}", f.estimate())),
            };
            writeln!(out, "new {kind:?} {what}: {r:?}").unwrap();
        }
    }
}

fn steps<F: FilterCore>(
    out: &mut String,
    f: &mut F,
    good: &[VectorObservation],
    singular: &VectorObservation,
    nan: &VectorObservation,
) {
    let e = |f: &F| format!("{:?}", f.estimate());
    writeln!(out, "new: {}", e(f)).unwrap();
    outcome(out, "empty", f.update(&[]));
    writeln!(out, "empty: {}", e(f)).unwrap();
    outcome(out, "nan", f.update(std::slice::from_ref(nan)));
    outcome(
        out,
        "singular first",
        f.update(std::slice::from_ref(singular)),
    );
    outcome(
        out,
        "singular second",
        f.update(&[good[0].clone(), singular.clone()]),
    );
    outcome(out, "update unpropagated", f.update(good));
    writeln!(out, "update unpropagated: {}", e(f)).unwrap();
    outcome(out, "bad propagate", f.propagate(&Vector3::zeros(), 0.0));
    outcome(
        out,
        "bad propagate nan",
        f.propagate(&Vector3::new(f64::NAN, 0.0, 0.0), 1.0),
    );
    for (i, dt) in [1.0, 10.0, 0.01, 3000.0].into_iter().enumerate() {
        let omega = Vector3::new(0.1, -0.1, 0.05) * (i as f64 + 1.0);
        outcome(
            out,
            "propagate_with",
            f.propagate_with(&omega, dt, 1e-8 * i as f64),
        );
        writeln!(out, "propagate_with {dt}: {}", e(f)).unwrap();
        outcome(out, "empty after propagate", f.update(&[]));
        outcome(
            out,
            "singular after propagate",
            f.update(&[good[0].clone(), singular.clone()]),
        );
        writeln!(out, "after refusal: {}", e(f)).unwrap();
        if i % 2 == 0 {
            f.inflate_attitude(&(Matrix3::identity() * 1e-6));
            writeln!(out, "inflated: {}", e(f)).unwrap();
        }
        outcome(out, "update", f.update(good));
        writeln!(out, "update: {}", e(f)).unwrap();
        outcome(out, "update again", f.update(&good[..1]));
        writeln!(out, "update again: {}", e(f)).unwrap();
        outcome(
            out,
            "bias",
            f.update_bias(&Vector3::new(1e-6, 0.0, -1e-6), 1e-7 * (i as f64 + 1.0)),
        );
        writeln!(out, "bias: {}", e(f)).unwrap();
        outcome(
            out,
            "bias zero sigma",
            f.update_bias(&Vector3::zeros(), 0.0),
        );
        writeln!(out, "bias zero sigma: {}", e(f)).unwrap();
    }
    writeln!(out, "bias_rad_s: {:?}", f.bias_rad_s()).unwrap();
}

fn run() -> String {
    let mut out = String::new();
    for kind in kinds() {
        for fiducial in [Fiducial::Propagated, Fiducial::Average] {
            for errors in [false, true] {
                for sigma_att in [0.01, 30f64.to_radians(), 100f64.to_radians()] {
                    driven(&mut out, kind, fiducial, errors, sigma_att);
                }
            }
        }
    }
    direct(&mut out);
    out
}

/// FNV-1a, 64 bits.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The golden lines of a record: `digest title` for each section (from a `== ` line to the next).
fn digests(record: &str) -> String {
    let mut out = String::new();
    let mut section: Option<(&str, usize)> = None;
    let close = |out: &mut String, section: Option<(&str, usize)>, end: usize| {
        if let Some((title, start)) = section {
            let d = fnv1a(&record.as_bytes()[start..end]);
            writeln!(out, "{d:016x} {title}").unwrap();
        }
    };
    let mut offset = 0;
    for line in record.split_inclusive('\n') {
        if let Some(title) = line.strip_prefix("== ") {
            close(&mut out, section, offset);
            section = Some((title.trim_end(), offset));
        }
        offset += line.len();
    }
    close(&mut out, section, offset);
    out
}

#[test]
#[cfg_attr(
    not(all(target_os = "linux", target_arch = "x86_64")),
    ignore = "the golden is of glibc's libm on x86-64"
)]
fn sigma_bits_match_the_golden() {
    let now = digests(&run());
    let golden = include_str!("data/sigma_bits.golden");
    if now != golden {
        let old: std::collections::HashSet<&str> = golden.lines().collect();
        let moved: Vec<&str> = now.lines().filter(|l| !old.contains(l)).collect();
        panic!(
            "{} of {} sections differ from the golden record, first {:?}; the new golden:\n{now}",
            moved.len(),
            now.lines().count(),
            moved.first()
        );
    }
}

#[test]
#[ignore = "writes the whole record to $SIGMA_BITS_OUT"]
fn sigma_bits_record() {
    let path = std::env::var("SIGMA_BITS_OUT").expect("SIGMA_BITS_OUT names the output file");
    std::fs::write(path, run()).unwrap();
}
