//! Late samples within `time.max_lag_s` are fused: a vehicle fed its samples late, reordered or
//! released early by wall time publishes, per `seq`, the estimates of an in-order arrival bit for bit
//! (MEKF, USQUE, QPF; gyro + vector streams and raw IMU samples). Beyond the lag, or beyond what the
//! history holds, a late sample is refused `out_of_order` and changes nothing; the history's memory
//! stays under its cap; a reset and a restore start a new history.

use super::*;
use crate::ahrs::AhrsConfig;
use crate::filters::FilterConfig;
use crate::rng::Xoshiro256PlusPlus;
use crate::sensors::GyroNoise;
use crate::sim::scenario::{simulate, ScenarioName, ScenarioParams};
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;

fn policy() -> Policy {
    Policy {
        reorder_window_s: 0.2,
        max_lag_s: 2.0,
        history_bytes: 8 << 20,
        max_jump_s: 3600.0,
        gate_threshold: Some(21.1),
        sensor_gate: BTreeMap::new(),
        sensor_models: BTreeMap::new(),
        gate_reinit_after: 10,
        reinit_after_failures: 3,
        reinit_sigma_factor: 10.0,
        max_sensors_per_vehicle: 16,
        max_rate_rad_s: 100.0,
        imu: AhrsConfig::default(),
        imu_estimate_interval_s: 0.0,
    }
}

/// No window, no history: every sample processed on arrival (the oracle, fed in order).
fn in_order_policy() -> Policy {
    Policy {
        reorder_window_s: 0.0,
        max_lag_s: 0.0,
        ..policy()
    }
}

fn config(spec: &str) -> VehicleFilterConfig {
    let mut filter = FilterConfig::new(spec.parse().unwrap(), GyroNoise::standard());
    filter.particles = 300;
    VehicleFilterConfig {
        filter,
        init: InitMode::Vectors,
        init_bias_sigma_rad_s: Vector3::repeat(10.0 * std::f64::consts::PI / 180.0 / 3600.0),
        sensor: Default::default(),
    }
}

/// What must not depend on arrival: everything of an estimate but the window's and the history's own
/// diagnostics (`held`, `replayed`, `late_fused`).
type Fused = (
    Estimate,
    BTreeMap<String, GateCounts>,
    u64,
    BTreeMap<String, u64>,
    Option<ImuDiagnostics>,
);

fn fused(p: &Published) -> Fused {
    (
        p.estimate.clone(),
        p.gate.clone(),
        p.rollbacks,
        p.reinits.clone(),
        p.imu.clone(),
    )
}

/// Feeds `(measurement, wall time of arrival)` in the order given, with the engine's 10 ms ticks in
/// between, then releases everything; returns the last estimate published for each `seq`, the
/// refusals, and how many estimates were published in all.
fn run(
    v: &mut VehicleState,
    arrivals: &[(Measurement, f64)],
    p: &Policy,
) -> (BTreeMap<u64, Fused>, Vec<RejectCode>, usize) {
    let mut out = Vec::new();
    let mut refused = Vec::new();
    let mut tick = 0.0;
    for (m, at) in arrivals {
        while tick + 0.01 <= *at {
            tick += 0.01;
            v.on_tick(tick, p, &mut out);
        }
        if let Err(r) = v.on_measurement(m.clone(), *at, p, &mut out) {
            refused.push(r.code);
        }
    }
    v.on_tick(f64::INFINITY, p, &mut out);
    let mut last = BTreeMap::new();
    let mut published = 0;
    for e in out {
        match e {
            Event::Estimate(p) => {
                published += 1;
                last.insert(p.seq, fused(&p));
            }
            Event::Rejected(_, r) => refused.push(r.code),
            Event::Processed(_) | Event::Gap(..) => {}
        }
    }
    (last, refused, published)
}

/// The oracle: the samples in processing order ([`Key`]), each processed on arrival.
fn in_order(spec: &str, ms: &[Measurement]) -> BTreeMap<u64, Fused> {
    let mut sorted = ms.to_vec();
    sorted.sort_by(|a, b| Key::of(a).partial_cmp(&Key::of(b)).unwrap());
    let arrivals: Vec<_> = sorted.into_iter().map(|m| (m, 0.0)).collect();
    let mut v = VehicleState::new("sc", config(spec));
    let (last, refused, published) = run(&mut v, &arrivals, &in_order_policy());
    assert!(refused.is_empty(), "{refused:?}");
    assert_eq!(published, last.len(), "no estimate twice in order");
    last
}

/// A star-tracker spacecraft: gyro at 10 Hz, star sets at 1 Hz, `duration_s`.
fn spacecraft(duration_s: f64) -> Vec<Measurement> {
    let mut params = ScenarioParams::default_for(ScenarioName::StarTracker);
    params.duration_s = duration_s;
    params.dt_gyro_s = 0.1;
    params.dt_obs_s = 1.0;
    simulate(&params, 11).measurements
}

/// Each vector set arrives `0..max_delay_s` after its time (drawn), the gyro on time; the wall clock
/// runs at `speed` sample seconds per second.
fn delayed(ms: &[Measurement], max_delay_s: f64, speed: f64, seed: u64) -> Vec<(Measurement, f64)> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut a: Vec<(Measurement, f64)> = ms
        .iter()
        .map(|m| {
            let d = match m {
                Measurement::Vectors(_) => rng.random::<f64>() * max_delay_s,
                _ => 0.0,
            };
            (m.clone(), (m.t_s() + d) / speed)
        })
        .collect();
    a.sort_by(|x, y| x.1.partial_cmp(&y.1).unwrap());
    a
}

#[test]
fn late_vector_sets_give_the_in_order_estimates_bit_for_bit() {
    let ms = spacecraft(40.0);
    for spec in ["mekf", "usque", "qpf:average"] {
        let want = in_order(spec, &ms);
        assert!(want.len() >= 40, "{spec}: {}", want.len());
        // Sets up to 1.5 s late (beyond the 0.2 s window, within the 2 s lag), in real time and at 20×
        // (where the window's wall-time limit releases samples long before their partners arrive).
        for (speed, seed) in [(1.0, 1), (20.0, 2), (1.0, 3)] {
            let mut v = VehicleState::new("sc", config(spec));
            let (got, refused, published) = run(&mut v, &delayed(&ms, 1.5, speed, seed), &policy());
            assert!(refused.is_empty(), "{spec}: {refused:?}");
            assert!(
                v.late_fused() > 5,
                "{spec}: the test must fuse late sets ({})",
                v.late_fused()
            );
            assert!(published >= want.len(), "{spec}");
            assert!(
                got == want,
                "{spec} at {speed}×: the late run's estimates differ from the in-order ones"
            );
        }
    }
}

#[test]
fn a_late_gyro_stream_is_fused_too() {
    // The other way round: the gyro's batches arrive up to 1.8 s late, the sets on time.
    let ms = spacecraft(20.0);
    let want = in_order("mekf", &ms);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    let mut a: Vec<(Measurement, f64)> = Vec::new();
    let mut delay = 0.0;
    for (i, m) in ms.iter().enumerate() {
        if matches!(m, Measurement::Gyro(_)) && i % 7 == 0 {
            delay = rng.random::<f64>() * 1.8; // a new batch of the gyro stream
        }
        let d = if matches!(m, Measurement::Gyro(_)) {
            delay
        } else {
            0.0
        };
        a.push((m.clone(), m.t_s() + d));
    }
    // (Stable: a batch keeps its order.)
    a.sort_by(|x, y| x.1.partial_cmp(&y.1).unwrap());
    let mut v = VehicleState::new("sc", config("mekf"));
    let (got, refused, _) = run(&mut v, &a, &policy());
    assert!(refused.is_empty(), "{refused:?}");
    assert!(v.late_fused() > 5);
    assert!(got == want);
}

/// A rotating IMU at 100 Hz (gravity and a magnetic field in an East-North-Up frame, noise drawn).
fn imu_samples(seconds: f64) -> Vec<Measurement> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(9);
    let mut n = |s: f64| Vector3::from_fn(|_, _| s * rng.sample::<f64, _>(StandardNormal));
    let g = Vector3::new(0.0, 0.0, 9.81);
    let b = Vector3::new(0.0, 15.6, -41.7);
    let dt = 0.01;
    let mut q = Quaternion::IDENTITY;
    let mut out = Vec::new();
    for k in 0..(seconds / dt) as usize {
        let t = k as f64 * dt;
        // At rest for 1 s, then turning about a slowly changing axis.
        let w = if t < 1.0 {
            Vector3::zeros()
        } else {
            Vector3::new((0.3 * t).sin(), (0.2 * t).cos(), 0.5) * 0.8
        };
        if k > 0 {
            q = q.propagate(&w, dt);
        }
        let a = q.attitude_matrix();
        out.push(Measurement::Imu(ImuSample {
            t_s: t,
            gyr_rad_s: w + Vector3::new(0.002, -0.001, 0.003) + n(0.004),
            acc_m_s2: a * g + n(0.05),
            mag: Some(a * b + n(0.3)),
        }));
    }
    out
}

#[test]
fn late_imu_batches_give_the_in_order_estimates_bit_for_bit() {
    let ms = imu_samples(15.0);
    for spec in ["mekf", "qpf:average"] {
        let want = in_order(spec, &ms);
        assert!(want.len() > 1400, "{}", want.len());
        // Batches of 20 samples; every fifth arrives 0.3 to 1.5 s late.
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(4);
        let mut a = Vec::new();
        for (i, batch) in ms.chunks(20).enumerate() {
            let late = if i % 5 == 3 {
                0.3 + 1.2 * rng.random::<f64>()
            } else {
                0.0
            };
            let at = batch[batch.len() - 1].t_s() + late;
            a.extend(batch.iter().map(|m| (m.clone(), at)));
        }
        a.sort_by(|x: &(Measurement, f64), y| x.1.partial_cmp(&y.1).unwrap());
        let mut v = VehicleState::new("sc", config(spec));
        let (got, refused, _) = run(&mut v, &a, &policy());
        assert!(refused.is_empty(), "{spec}: {refused:?}");
        assert!(v.late_fused() >= 100, "{spec}: {}", v.late_fused());
        assert!(got == want, "{spec}");
    }
}

#[test]
fn beyond_the_lag_a_late_sample_is_refused_and_changes_nothing() {
    let ms = spacecraft(12.0);
    let p = policy();
    let mut v = VehicleState::new("sc", config("mekf"));
    let arrivals: Vec<_> = ms.iter().map(|m| (m.clone(), m.t_s())).collect();
    run(&mut v, &arrivals, &p);
    let before = v.estimate();
    let (seq, bytes) = (v.seq(), v.history_bytes());
    let last = v.last_t().unwrap();
    let mut out = Vec::new();
    let old = |t: f64| {
        Measurement::Gyro(GyroSample {
            t_s: t,
            omega_body_rad_s: Vector3::new(1e-3, 0.0, 0.0),
        })
    };
    let r = v.on_measurement(old(last - p.max_lag_s - 0.05), 100.0, &p, &mut out);
    assert_eq!(r.map_err(|r| r.code), Err(RejectCode::OutOfOrder));
    // A sample the history holds already, beyond the 16 recent ones the arrival check remembers.
    let dup = ms
        .iter()
        .rev()
        .filter(|m| matches!(m, Measurement::Gyro(_)) && m.t_s() > last - p.max_lag_s + 0.1)
        .nth(RECENT + 1)
        .unwrap()
        .clone();
    let r = v.on_measurement(dup, 100.0, &p, &mut out);
    assert_eq!(r.map_err(|r| r.code), Err(RejectCode::Duplicate));
    assert!(out.is_empty());
    assert_eq!(
        (v.estimate(), v.seq(), v.history_bytes()),
        (before, seq, bytes)
    );
    // Within the lag: fused.
    v.on_measurement(old(last - p.max_lag_s + 0.05), 100.0, &p, &mut out)
        .unwrap();
    assert_eq!(v.late_fused(), 1);
    assert!(out
        .iter()
        .any(|e| matches!(e, Event::Estimate(p) if p.replayed)));
}

#[test]
fn the_history_stays_within_its_lag_and_its_byte_cap() {
    let ms = spacecraft(60.0);
    let arrivals: Vec<_> = ms.iter().map(|m| (m.clone(), m.t_s())).collect();
    for (spec, cap) in [
        ("mekf", 8 << 20),
        ("qpf:average", 8 << 20),
        ("qpf:average", 80_000),
    ] {
        let p = Policy {
            history_bytes: cap,
            ..policy()
        };
        let mut v = VehicleState::new("sc", config(spec));
        let mut most = (0, 0, 0);
        for a in arrivals.chunks(10) {
            run(&mut v, a, &p);
            let (kept, logged) = v.history_len();
            most = (
                most.0.max(v.history_bytes()),
                most.1.max(kept),
                most.2.max(logged),
            );
        }
        let (bytes, kept, logged) = most;
        assert!(bytes <= cap, "{spec}: {bytes} > {cap}");
        assert!(kept <= KEPT_PER_LAG + 2, "{spec}: {kept} states");
        // At most the lag and one interval (≤ the lag) of 10 Hz gyro and 1 Hz sets, and a second.
        assert!(
            logged as f64 <= (2.0 * p.max_lag_s + 1.0) * 11.0,
            "{spec}: {logged} samples logged"
        );
        if cap < 100_000 {
            // 300 particles, about 25 kB a state: three fit, so one per lag (the few states of the
            // initialising vehicle, without a filter, were smaller).
            let (kept, _) = v.history_len();
            assert!(
                (2..=3).contains(&kept),
                "{spec}: {kept} states under a {cap}-byte cap"
            );
        }
        // And the whole lag is covered. (The chunks' final flushes released samples early already:
        // their partners were fused as late.)
        let (last, before) = (v.last_t().unwrap(), v.late_fused());
        let g = Measurement::Gyro(GyroSample {
            t_s: last - p.max_lag_s + 0.01,
            omega_body_rad_s: Vector3::zeros(),
        });
        v.on_measurement(g, 0.0, &p, &mut Vec::new()).unwrap();
        assert_eq!(v.late_fused(), before + 1, "{spec}");
    }
    // A cap below one state keeps none: late samples are refused, as without a history.
    let p = Policy {
        history_bytes: 10_000,
        ..policy()
    };
    let mut v = VehicleState::new("sc", config("qpf:average"));
    let mut late = delayed(&ms[..200], 1.5, 1.0, 7);
    late.retain(|(m, _)| m.t_s() > 2.0);
    let (_, refused, _) = run(&mut v, &late, &p);
    assert_eq!(v.history_bytes(), 0);
    assert!(refused.contains(&RejectCode::OutOfOrder), "{refused:?}");
}

#[test]
fn a_reset_and_a_restore_start_a_new_history() {
    let ms = spacecraft(10.0);
    let p = policy();
    let arrivals: Vec<_> = ms.iter().map(|m| (m.clone(), m.t_s())).collect();
    let mut v = VehicleState::new("sc", config("usque"));
    run(&mut v, &arrivals, &p);
    assert!(v.history_bytes() > 0);
    let last = v.last_t().unwrap();
    let g = |t: f64| {
        Measurement::Gyro(GyroSample {
            t_s: t,
            omega_body_rad_s: Vector3::zeros(),
        })
    };
    // A restored vehicle has no history: older than its state, refused...
    let mut r = VehicleState::restore(v.snapshot()).unwrap();
    assert_eq!(r.history_bytes(), 0);
    let mut out = Vec::new();
    let code = r
        .on_measurement(g(last - 0.55), 0.0, &p, &mut out)
        .map_err(|e| e.code);
    assert_eq!(code, Err(RejectCode::OutOfOrder));
    // ... but it works, and newer late samples are fused once it has a history again.
    let later: Vec<_> = spacecraft(14.0)
        .into_iter()
        .filter(|m| m.t_s() > last)
        .map(|m| {
            let t = m.t_s();
            (m, t)
        })
        .collect();
    run(&mut r, &later, &p);
    let last = r.last_t().unwrap();
    r.on_measurement(g(last - 0.55), 0.0, &p, &mut out).unwrap();
    assert_eq!(r.late_fused(), 1);
    // A reset with a time: nothing before it is replayed after it.
    let req = ResetRequest {
        t_s: Some(last + 1.0),
        ..Default::default()
    };
    r.on_reset(&req, &config("usque"), &p, &mut out).unwrap();
    assert_eq!(r.history_bytes(), 0);
    let code = r
        .on_measurement(g(last + 0.5), 0.0, &p, &mut out)
        .map_err(|e| e.code);
    assert_eq!(code, Err(RejectCode::OutOfOrder));
}

#[test]
fn many_arrival_orders_one_result() {
    // Random delays of both streams (cheap property check over seeds, MEKF): always the in-order
    // estimates.
    let ms = spacecraft(15.0);
    let want = in_order("mekf", &ms);
    for seed in 0..12u64 {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(100 + seed);
        let mut a: Vec<(Measurement, f64)> = ms
            .iter()
            .map(|m| (m.clone(), m.t_s() + rng.random::<f64>() * 1.9))
            .collect();
        a.sort_by(|x, y| x.1.partial_cmp(&y.1).unwrap());
        let mut v = VehicleState::new("sc", config("mekf"));
        let (got, refused, _) = run(&mut v, &a, &policy());
        assert!(refused.is_empty(), "seed {seed}: {refused:?}");
        assert!(got == want, "seed {seed}");
    }
}

/// The figures config/default.json5 and proto/README.md state: a kept state of about 2.6 kB for the Kalman
/// filters (5.3 kB with the IMU pipeline) and 64 bytes per particle more for the QPF, 10 of them at most,
/// so a star-tracker spacecraft's history (10 Hz gyro, 1 Hz sets, 2 s lag) holds under 30 kB with the
/// MEKF or USQUE, about 540 kB with the QPF's default 1000 particles, 5.2 MB with 10⁴; a 100 Hz IMU
/// vehicle's about 78 kB (its 2.2 s of samples). The accounting is the one the cap is applied to.
#[test]
fn the_history_costs_what_the_documentation_says() {
    let ms = spacecraft(30.0);
    let arrivals: Vec<_> = ms.iter().map(|m| (m.clone(), m.t_s())).collect();
    let imu: Vec<_> = imu_samples(15.0)
        .into_iter()
        .map(|m| {
            let t = m.t_s();
            (m, t)
        })
        .collect();
    for (spec, particles, state, total, input) in [
        ("mekf", 0, 2_700, 30_000, &arrivals),
        ("usque", 0, 2_700, 30_000, &arrivals),
        ("qpf:average", 1000, 2_700 + 64_000, 550_000, &arrivals),
        ("qpf:average", 10_000, 2_700 + 640_000, 5_200_000, &arrivals),
        ("mekf", 0, 5_800, 82_000, &imu),
    ] {
        let mut c = config(spec);
        c.filter.particles = particles.max(2);
        let mut v = VehicleState::new("sc", c);
        run(&mut v, input, &policy());
        let (kept, _) = v.history_len();
        assert!(
            v.kept_bytes() <= state && v.kept_bytes() > state * 9 / 10,
            "{spec} ({particles} particles, state bound {state}): {} a state",
            v.kept_bytes()
        );
        assert!(
            v.history_bytes() <= total && v.history_bytes() > total * 3 / 4,
            "{spec}: {} in all",
            v.history_bytes()
        );
        assert!(
            (KEPT_PER_LAG..=KEPT_PER_LAG + 2).contains(&kept),
            "{spec}: {kept} states"
        );
    }
}

/// Feeds `ms` in order and returns the gap events' messages.
fn gap_events(v: &mut VehicleState, ms: &[Measurement]) -> Vec<String> {
    let p = in_order_policy();
    let mut out = Vec::new();
    for m in ms {
        v.on_measurement(m.clone(), 0.0, &p, &mut out).unwrap();
    }
    v.on_tick(f64::INFINITY, &p, &mut out);
    out.iter()
        .filter_map(|e| match e {
            Event::Gap(_, r) => {
                assert_eq!(r.code, RejectCode::Gap);
                Some(r.message.clone())
            }
            Event::Rejected(_, r) => panic!("refused: {r:?}"),
            _ => None,
        })
        .collect()
}

#[test]
fn a_gap_in_the_samples_is_told_once_and_counted() {
    // Raw IMU at 100 Hz with 0.5 s missing after t = 5 s.
    let ms: Vec<_> = imu_samples(10.0)
        .into_iter()
        .filter(|m| !(m.t_s() > 5.0 && m.t_s() < 5.5 - 1e-9))
        .collect();
    let mut v = VehicleState::new("imu", config("mekf"));
    let told = gap_events(&mut v, &ms);
    assert_eq!(told.len(), 1, "{told:?}");
    assert!(told[0].contains("t = 5.5"), "{}", told[0]);
    let t = v.totals();
    assert_eq!(t.gaps, 1);
    assert!((t.blind_s - 0.49).abs() < 0.02, "{}", t.blind_s);

    // A gyro feed at 10 Hz with 1 s missing: one gap, and none in the same feed without it.
    let all = spacecraft(30.0);
    let cut: Vec<_> = all
        .iter()
        .filter(|m| !(matches!(m, Measurement::Gyro(_)) && m.t_s() > 10.05 && m.t_s() < 11.05))
        .cloned()
        .collect();
    let mut v = VehicleState::new("sc", config("mekf"));
    let told = gap_events(&mut v, &cut);
    assert_eq!(told.len(), 1, "{told:?}");
    assert_eq!(v.totals().gaps, 1);
    let mut v = VehicleState::new("sc", config("mekf"));
    assert!(gap_events(&mut v, &all).is_empty());
    assert_eq!(v.totals().gaps, 0);
}

/// One in-order stream goes straight through the reorder window once its first window is over
/// (nothing held, no wait for the window's time); the arrival check still refuses a repeat of its
/// newest sample and a second sample of that instant, changing nothing, and a sample older than the
/// newest but new to the vehicle (within the lag) is still fused.
#[test]
fn an_in_order_stream_passes_the_window_and_repeats_are_still_refused() {
    let ms = imu_samples(3.0);
    let p = policy();
    let mut v = VehicleState::new("sc", config("mekf"));
    let mut out = Vec::new();
    for m in &ms {
        // Arriving at its own time: the window (0.2 s) never elapses for it.
        v.on_measurement(m.clone(), m.t_s(), &p, &mut out).unwrap();
        // (During the vehicle's first window another stream could still start earlier: held.)
        if m.t_s() >= p.reorder_window_s {
            assert_eq!(v.held.len(), 0, "t = {}", m.t_s());
        }
    }
    let published = out
        .iter()
        .filter(|e| matches!(e, Event::Estimate(p) if p.held == 0 && !p.replayed))
        .count();
    assert!(published > 150, "{published}");
    let before = (v.estimate(), v.seq(), v.history_bytes());
    let newest = ms.last().unwrap().clone();
    let Measurement::Imu(mut other) = newest.clone() else {
        unreachable!()
    };
    other.acc_m_s2.x += 0.1;
    for m in [newest, Measurement::Imu(other)] {
        let mut out = Vec::new();
        let r = v.on_measurement(m, 10.0, &p, &mut out);
        assert_eq!(r.map_err(|r| r.code), Err(RejectCode::Duplicate));
        assert!(out.is_empty());
    }
    assert_eq!((v.estimate(), v.seq(), v.history_bytes()), before);
    // Between two samples of half a second ago: no duplicate, replayed into its place.
    let Measurement::Imu(mut late) = ms[ms.len() - 51].clone() else {
        unreachable!()
    };
    late.t_s += 0.005;
    let mut out = Vec::new();
    v.on_measurement(Measurement::Imu(late), 10.0, &p, &mut out)
        .unwrap();
    assert_eq!(v.late_fused(), 1);
    assert!(out
        .iter()
        .any(|e| matches!(e, Event::Estimate(p) if p.replayed)));
}

/// A sample's fingerprint is FNV-1a over its bytes as checkpoints have always stored it (each vector's
/// three numbers, then `sigma`, then the sensor name and a 0, per observation; a rate's or an IMU
/// sample's vectors): a restored vehicle compares new samples with the fingerprints of its checkpoint.
#[test]
fn fingerprints_are_fnv1a_of_the_samples_bytes() {
    let bytes = |v: &[f64]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let obs = |body: [f64; 3], sigma: f64, sensor: Option<&str>| VectorObservation {
        body: Vector3::from(body),
        reference: Vector3::new(0.0, -0.6, 0.8),
        sigma,
        sensor: sensor.map(str::to_string),
        aspect: Default::default(),
    };
    let set = Measurement::Vectors(ObservationSet {
        t_s: 3.0,
        observations: vec![
            obs([1.0, 0.0, -0.0], 1e-4, Some("star")),
            obs([0.6, 0.8, 0.0], 0.25, None),
        ],
    });
    let mut expected = Vec::new();
    if let Measurement::Vectors(s) = &set {
        for o in &s.observations {
            expected.extend(bytes(o.body.as_slice()));
            expected.extend(bytes(o.reference.as_slice()));
            expected.extend(o.sigma.to_le_bytes());
            expected.extend(o.sensor.as_deref().unwrap_or("").bytes());
            expected.push(0);
        }
    }
    assert_eq!(fingerprint(&set), fnv(expected, FNV_OFFSET));
    let w = Vector3::new(0.1, -2.5e-3, 7.0);
    let gyro = Measurement::Gyro(GyroSample {
        t_s: 3.0,
        omega_body_rad_s: w,
    });
    assert_eq!(fingerprint(&gyro), fnv(bytes(w.as_slice()), FNV_OFFSET));
    assert_eq!(Seen::of(&gyro).fingerprint(), fingerprint(&gyro));
    let imu = ImuSample {
        t_s: 3.0,
        gyr_rad_s: w,
        acc_m_s2: Vector3::new(0.0, 0.0, 9.81),
        mag: Some(Vector3::new(20.0, 0.0, -40.0)),
    };
    let all = [w.as_slice(), &[0.0, 0.0, 9.81], &[20.0, 0.0, -40.0]].concat();
    assert_eq!(imu_fingerprint(&imu), fnv(bytes(&all), FNV_OFFSET));
}
