//! The vectorised passes: every instruction set and thread count gives the same bits, and the
//! likelihood in the fiducial's chart is the direct one.

use super::update::Evidence;
use super::*;
use crate::filters::{FilterConfig, FilterSpec};
use crate::sensors::Aspect;

fn config(spec: &str, n: usize, kernel: Kernel) -> FilterConfig {
    let spec: FilterSpec = spec.parse().expect("a filter name");
    let mut c = FilterConfig::new(spec, GyroNoise::standard());
    c.particles = n;
    c.qpf.kernel = kernel;
    c
}

fn truth(t: f64) -> Quaternion {
    Quaternion::from_rotation_vector(&Vector3::new(0.2 * t.sin(), 0.1 * t, -0.3))
}

fn full(q: &Quaternion, r: Vector3<f64>, sigma: f64) -> VectorObservation {
    VectorObservation {
        body: q.attitude_matrix() * r,
        reference: r,
        sigma,
        sensor: None,
        aspect: Aspect::Full,
    }
}

/// A run that takes every path: a start 0.3 rad off (progressive correction, resampling), a long step
/// (the trigonometric branch), full, tilt-only, heading-only and bias evidence, and a cloud whose
/// length is not a multiple of 8. Returns the cloud and the estimate.
fn run(spec: &str, n: usize, kernel: Kernel, isa: Isa, threads: usize) -> (Cloud, Estimate) {
    let init = InitialState {
        t_s: None,
        q: truth(0.0),
        sigma_att_rad: Vector3::repeat(0.3),
        bias_rad_s: Vector3::zeros(),
        bias_sigma_rad_s: Vector3::repeat(1e-5),
        uniform_attitude: false,
        covariance: None,
    };
    let mut f = Qpf::new(&config(spec, n, kernel), &init, QpfOptions::default(), 5).unwrap();
    f.set_isa(Some(isa));
    f.set_threads(threads);
    let up = Vector3::z();
    for k in 0..12 {
        let t = k as f64;
        let dt = if k == 6 { 10.0 } else { 1.0 };
        f.propagate(&Vector3::new(0.05, -0.02, 0.1), dt).unwrap();
        let q = truth(t);
        let mut obs = vec![
            full(&q, Vector3::x(), 1e-3),
            full(&q, Vector3::new(0.0, 0.6, 0.8), 2e-3),
        ];
        if k % 3 == 1 {
            let mut g = full(&q, up * 9.81, 0.05);
            g.aspect = Aspect::Tilt(up);
            let mut m = full(&q, Vector3::new(0.0, 20.0, -40.0), 0.5);
            m.aspect = Aspect::Heading(up);
            obs = vec![g, m];
        }
        f.update(&obs).unwrap();
        if k % 4 == 3 {
            f.update_bias(&Vector3::new(1e-5, 0.0, -2e-5), 1e-4)
                .unwrap();
        }
    }
    (f.cloud.clone(), f.estimate())
}

fn bits(c: &Cloud) -> Vec<u64> {
    [&c.qx, &c.qy, &c.qz, &c.qw, &c.bx, &c.by, &c.bz, &c.w]
        .iter()
        .flat_map(|v| v.iter().map(|x| x.to_bits()))
        .collect()
}

#[test]
fn every_instruction_set_and_thread_count_gives_the_same_bits() {
    for (spec, n, kernel) in [
        ("qpf:average", 1003, Kernel::Gaussian),
        ("qpf:propagated", 2500, Kernel::Epanechnikov),
        ("qpf:average", 2500, Kernel::Gaussian),
    ] {
        let (c0, e0) = run(spec, n, kernel, Isa::Portable, 1);
        assert!(e0.diagnostics.resamples.unwrap() > 0, "{spec}: resampled");
        assert!(e0.diagnostics.pc_stages.is_some());
        for isa in Isa::ALL.into_iter().filter(|i| i.supported()) {
            for threads in [1, 2, 3] {
                let (c, e) = run(spec, n, kernel, isa, threads);
                assert!(
                    bits(&c) == bits(&c0),
                    "{spec} {n} {kernel:?}: {isa:?} on {threads} threads differs"
                );
                assert_eq!(e, e0, "{spec} {n}: {isa:?} on {threads} threads");
            }
        }
    }
}

#[test]
fn the_same_seed_gives_the_same_cloud() {
    let a = run("qpf:average", 300, Kernel::Gaussian, Isa::active(), 0).0;
    let b = run("qpf:average", 300, Kernel::Gaussian, Isa::active(), 0).0;
    assert!(bits(&a) == bits(&b));
}

/// `−½ Σ σ⁻² ‖b − A(q) r‖²` and the heading term, as the scalar code before the vectorised passes
/// computed them.
fn direct(q: &Quaternion, obs: &[VectorObservation]) -> f64 {
    let a = q.attitude_matrix();
    obs.iter()
        .map(|o| match o.aspect.heading_axis() {
            None => -0.5 * (o.body - a * o.reference).norm_squared() / (o.sigma * o.sigma),
            Some(up) => {
                let (e1, e2, h) = heading::heading_basis(&o.reference, up).unwrap();
                let psi = heading::heading_residual(&a, &o.body, &e1, &e2);
                let s = heading::heading_sigma_rad(o.sigma, h);
                -0.5 * psi * psi / (s * s)
            }
        })
        .sum()
}

/// The chart form against the direct one: a converged cloud (σ = 1e-4 rad star-tracker vectors, a
/// 1e-4 rad cloud), where the differences between particles are what weighs them, to 1e-9; a
/// diffuse cloud (uniform attitudes, a magnetometer in nT), relative to the largest term, to 1e-14
/// (measured: 8e-12 and 2e-11 converged, 6e-16 relative diffuse).
#[test]
fn the_likelihood_in_the_fiducials_chart_is_the_direct_one() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
    let q0 = truth(0.7);
    let stars = [
        full(&q0, Vector3::x(), 1e-4),
        full(&q0, Vector3::new(0.0, 0.6, 0.8), 1e-4),
        full(&q0, Vector3::new(0.0, -0.8, 0.6), 1e-4),
    ];
    let mut tilt = full(&q0, Vector3::z() * 9.81, 0.05);
    tilt.aspect = Aspect::Tilt(Vector3::z());
    let mut heading = full(&q0, Vector3::new(3.0, 20.0, -40.0), 0.5);
    heading.aspect = Aspect::Heading(Vector3::z());
    let mag = full(&q0, Vector3::new(3.0, 20.0, -40.0) * 1e3, 3.0);
    for (obs, spread, tol) in [
        (stars.to_vec(), Some(1e-4), 1e-9),
        (
            vec![stars[0].clone(), tilt.clone(), heading.clone()],
            Some(1e-3),
            1e-9,
        ),
        (vec![mag.clone()], None, 1e-14),
        (vec![mag, heading], None, 1e-14),
    ] {
        let particles: Vec<_> = (0..203)
            .map(|_| {
                let q = match spread {
                    Some(s) => {
                        Quaternion::from_rotation_vector(&(normal3(&mut rng) * s)).compose(&q0)
                    }
                    None => loop {
                        let v = normal3(&mut rng);
                        let w: f64 = rng.sample(StandardNormal);
                        if let Some(q) = Quaternion::new(v[0], v[1], v[2], w).normalized() {
                            break q;
                        }
                    },
                };
                (q, Vector3::zeros(), 1.0)
            })
            .collect();
        let cfg = config("qpf:average", 2, Kernel::Gaussian);
        let mut f = Qpf::from_particles(&cfg, QpfOptions::default(), &particles, 1).unwrap();
        // The chart of an estimate a little off the truth.
        let fid = Quaternion::from_rotation_vector(&Vector3::new(2e-5, -1e-5, 3e-5)).compose(&q0);
        let terms = f.prepare(&obs);
        f.log_likelihoods(&Evidence::Vectors(&obs), terms.as_ref(), &fid);
        let d: Vec<f64> = particles.iter().map(|p| direct(&p.0, &obs)).collect();
        let scale = d.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        let tol = if spread.is_some() { tol } else { tol * scale };
        let mut worst: f64 = 0.0;
        for i in 1..particles.len() {
            worst = worst.max(((f.log_lik[i] - f.log_lik[0]) - (d[i] - d[0])).abs());
            let (ours, theirs) = (f.log_lik[i] - f.log_lik[0], d[i] - d[0]);
            assert!(
                (ours - theirs).abs() <= tol,
                "particle {i}: {ours} against {theirs} (tolerance {tol:e})"
            );
        }
        assert!(worst <= tol);
    }
}

/// A tilt reading far sharper than the cloud (the IMU pipeline at 25 Hz in fast rotation: the cloud's
/// tilt spread grows by up to 16° a sample, the reading is ~50–80× sharper) tilts the cloud as the
/// MEKF's tilt update would and leaves the heading's spread alone. Weighting it instead (progressive
/// correction in many stages, a resampling and regularisation in each) widened the heading's 1σ by a
/// fifth per update: 28° → 110° in half a second on BROAD 07 at 25 Hz (docs/broad.md).
#[test]
fn a_sharp_tilt_reading_leaves_the_heading_spread_alone() {
    let up = Vector3::z();
    // Heading 0.7 rad: the body's z axis is the vertical, so body-axis sigmas are tilt and heading.
    let q0 = Quaternion::from_rotation_vector(&Vector3::new(0.0, 0.0, 0.7));
    let truth = Quaternion::from_rotation_vector(&Vector3::new(0.15, -0.10, 0.0)).compose(&q0);
    for seed in [1, 2, 3] {
        let init = InitialState {
            t_s: None,
            q: q0,
            sigma_att_rad: Vector3::new(0.25, 0.25, 0.5),
            bias_rad_s: Vector3::zeros(),
            bias_sigma_rad_s: Vector3::repeat(0.01),
            uniform_attitude: false,
            covariance: None,
        };
        let mut f = Qpf::new(
            &config("qpf:average", 2000, Kernel::Gaussian),
            &init,
            QpfOptions::default(),
            seed,
        )
        .unwrap();
        let before = f.estimate();
        let heading_sigma = |e: &Estimate| {
            let a = e.q.attitude_matrix();
            let p: Matrix3<f64> = e.covariance.fixed_view::<3, 3>(0, 0).into_owned();
            (a.transpose() * p * a)[(2, 2)].sqrt()
        };
        // 9.81 m/s² with 0.05 m/s²: a 0.29° reading against a 14° cloud.
        let mut g = full(&truth, up * 9.81, 0.05);
        g.aspect = Aspect::Tilt(up);
        f.update(&[g.clone()]).unwrap();
        let after = f.estimate();
        let ratio = heading_sigma(&after) / heading_sigma(&before);
        assert!(
            (0.9..1.05).contains(&ratio),
            "seed {seed}: heading 1σ {:.1}° → {:.1}°",
            heading_sigma(&before).to_degrees(),
            heading_sigma(&after).to_degrees()
        );
        // The tilt: on the reading, and as sure as the reading.
        let tilt_err = (after.q.attitude_matrix().transpose() * g.body).angle(&up);
        let s = after.sigma_att_rad();
        assert!(
            tilt_err < 0.02 && s[0] < 0.01 && s[1] < 0.01,
            "seed {seed}: tilt error {:.2}°, 1σ {:.2}° {:.2}°",
            tilt_err.to_degrees(),
            s[0].to_degrees(),
            s[1].to_degrees()
        );
    }
}

/// The propagation's noise comes in antithetic pairs (particles `i` and `i + 32` of a group of 64):
/// from a cloud of one point, one step leaves the bias's mean where the model puts it (the pairs'
/// draws cancel) while its spread is the model's. With independent draws the mean is off by
/// `σ/√N` (0.03 σ at 1024 particles, above the bound here), and the half drawn are still normals of
/// the model's variance.
#[test]
fn the_propagations_noise_cancels_in_the_clouds_mean() {
    let n = 1024;
    let q0 = truth(0.0);
    let b0 = Vector3::new(1e-4, -2e-4, 5e-5);
    let particles: Vec<_> = (0..n).map(|_| (q0, b0, 1.0)).collect();
    let cfg = config("qpf:average", n, Kernel::Gaussian);
    let mut f = Qpf::from_particles(&cfg, QpfOptions::default(), &particles, 7).unwrap();
    let dt = 100.0;
    let omega = Vector3::new(0.01, -0.02, 0.005);
    f.propagate(&omega, dt).unwrap();
    let su = f.gyro.sigma_u * dt.sqrt();
    let c = &f.cloud;
    for (k, col) in [&c.bx, &c.by, &c.bz].into_iter().enumerate() {
        let mean = col.iter().sum::<f64>() / n as f64;
        let var = col.iter().map(|b| (b - mean).powi(2)).sum::<f64>() / n as f64;
        // The model's mean (a random walk: φ = 1) to rounding, not to the draw's σ/√N.
        assert!(
            (mean - b0[k]).abs() <= 1e-9 * su,
            "axis {k}: mean {mean:e} against {:e} (σ_u √Δt {su:e})",
            b0[k]
        );
        // The spread of the model: the variance of 512 independent draws, within ±25% (4σ).
        let ratio = var / (su * su);
        assert!(
            (0.75..1.25).contains(&ratio),
            "axis {k}: variance / model {ratio}"
        );
    }
    // And the attitude's mean: the step's rotation vectors cancel too, to second order (the
    // quaternions compose the noise nonlinearly): the cloud's average is the noise-free step's
    // within a small fraction of its spread.
    let exact = q0.propagate(&(omega - b0), dt);
    let avg = f.cloud.average(&exact, Isa::active(), 1);
    let (q_avg, _, _) = Qpf::average_or(avg, &exact);
    let off = q_avg.compose(&exact.inverse()).to_rotation_vector().norm();
    let spread = (f.gyro.discrete_rate_sigma(dt) * dt).max(su * dt);
    assert!(
        off < 0.01 * spread,
        "average off by {off:e} rad, spread {spread:e} rad"
    );
}
