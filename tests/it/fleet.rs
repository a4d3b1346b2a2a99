//! The fleet without the network: a filter started from a full covariance has that covariance (the
//! particle filter's cloud too); a vehicle taken over from a published estimate continues from it; and
//! two engines of a dynamic fleet fed the same inputs (as zenoh would) split the vehicles, and when one
//! member goes the other takes its vehicles over with no vector set left without an estimate.

use crate::common::{collecting_engine, repo, service_config, wait_until, Outputs};
use attitude_service::attitude::Quaternion;
use attitude_service::engine::{EngineThreads, Inbound};
use attitude_service::filters::{build_filter, FilterConfig, InitialState};
use attitude_service::fleet::owner;
use attitude_service::query;
use attitude_service::sensors::GyroNoise;
use attitude_service::service::config::{override_fleet, parse, ServiceConfig};
use attitude_service::service::Node;
use attitude_service::vehicle::{TakeoverSeed, VehicleState};
use attitude_service::wire::EstimateMsg;
use nalgebra::{Matrix6, Vector3};
use std::collections::{BTreeMap, BTreeSet};
use std::time::Duration;

/// A correlated, positive-definite covariance of `[δα; δβ]`.
fn correlated() -> Matrix6<f64> {
    let s = [2e-3, 1e-3, 3e-3, 1e-5, 2e-5, 1e-5];
    let mut p = Matrix6::from_fn(|i, j| s[i] * s[j] * if i == j { 1.0 } else { 0.3 });
    p[(0, 4)] *= -1.0;
    p[(4, 0)] *= -1.0;
    p
}

fn initial(p: Matrix6<f64>) -> InitialState {
    InitialState {
        t_s: Some(0.0),
        q: Quaternion::new(0.1, -0.2, 0.3, 0.9).normalized().unwrap(),
        sigma_att_rad: Vector3::new(p[(0, 0)].sqrt(), p[(1, 1)].sqrt(), p[(2, 2)].sqrt()),
        bias_rad_s: Vector3::new(1e-5, -2e-5, 3e-6),
        bias_sigma_rad_s: Vector3::new(p[(3, 3)].sqrt(), p[(4, 4)].sqrt(), p[(5, 5)].sqrt()),
        uniform_attitude: false,
        covariance: Some(p),
    }
}

#[test]
fn filters_start_with_the_full_covariance() {
    let p = correlated();
    let init = initial(p);
    let gyro = GyroNoise {
        sigma_v: 1e-6,
        sigma_u: 1e-9,
    };
    // The particle filter's covariance is the sample covariance of N = 20000 draws: entry (i, j) has a
    // standard deviation of √((1 + ρᵢⱼ²)/N) ≤ √(2/N) = 1% of √(Pᵢᵢ Pⱼⱼ), so the 21 distinct entries lie
    // within 4.07% of it at 0.999 (|z| ≤ 4.07 each); σ 1.5× too small or too large moves the diagonal
    // by −56% or +125%. Measured: 2.6% at most. Its mean's offset δ from the start has covariance P/N:
    // `N δᵀ P_att⁻¹ δ` is χ²(3), below χ²₃(0.999) = 16.27 (measured 0.97).
    for (spec, particles, tol) in [
        ("mekf", 0, 1e-12),
        ("usque", 0, 1e-6),
        ("qpf", 20_000, 0.0407),
    ] {
        let mut config = FilterConfig::new(spec.parse().unwrap(), gyro);
        if particles > 0 {
            config.particles = particles;
        }
        let f = build_filter(&config, &init, 7).unwrap();
        let e = f.estimate();
        let mut worst: f64 = 0.0;
        for i in 0..6 {
            for j in 0..6 {
                let scale = (p[(i, i)] * p[(j, j)]).sqrt();
                let d = (e.covariance[(i, j)] - p[(i, j)]).abs() / scale;
                worst = worst.max(d);
                assert!(
                    d < tol,
                    "{spec}: P[{i},{j}] {} vs {} ({d})",
                    e.covariance[(i, j)],
                    p[(i, j)]
                );
            }
        }
        let err = e.q.compose(&init.q.inverse()).angle();
        let delta = init.q.small_angle_error(&e.q);
        let p_att = p.fixed_view::<3, 3>(0, 0).into_owned();
        let stat = particles.max(1) as f64 * delta.dot(&p_att.cholesky().unwrap().solve(&delta));
        eprintln!("{spec}: covariance off by {worst:.2e} of the scale at most, mean off by {err:e} rad (N δᵀP⁻¹δ {stat:.2})");
        if particles > 0 {
            assert!(
                stat <= 16.27,
                "{spec}: mean off by {err} rad, N δᵀP⁻¹δ {stat}"
            );
        } else {
            assert!(err < 1e-9, "{spec}: mean off by {err} rad");
        }
    }
    // Not positive definite: refused.
    let mut bad = correlated();
    bad[(0, 0)] = -1e-6;
    let config = FilterConfig::new("mekf".parse().unwrap(), gyro);
    assert!(build_filter(&config, &initial(bad), 7).is_err());
}

#[test]
fn a_vehicle_taken_over_continues_from_the_estimate() {
    let base = ServiceConfig::default().default_filter;
    let mut e: EstimateMsg = serde_json::from_str(include_str!(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/proto/examples/estimate-qpf.json"
    )))
    .unwrap();
    e.diagnostics.particles = Some(500);
    let seed = TakeoverSeed::try_from(&e).unwrap();
    let state = VehicleState::take_over("sc1", &base, &seed, None).unwrap();
    assert_eq!(state.seq(), e.seq);
    assert_eq!(state.last_t(), Some(e.t));
    assert_eq!(state.particles(), Some(500));
    let now = EstimateMsg::from(&state.estimate().unwrap());
    assert_eq!(now.filter, e.filter);
    assert_eq!(now.diagnostics.reinits.get("takeover"), Some(&1));
    // The 500 particles are drawn from the estimate's covariance P: the cloud's mean is off by δ with
    // covariance P/500, so `500 δᵀ P_att⁻¹ δ` is χ²(3), below χ²₃(0.999) = 16.27 (a cloud drawn about
    // another attitude is far above). Measured: 5.11.
    let drawn = Quaternion::new(now.q.x, now.q.y, now.q.z, now.q.w);
    let delta = Quaternion::new(e.q.x, e.q.y, e.q.z, e.q.w).small_angle_error(&drawn);
    let p_att = nalgebra::Matrix3::from_fn(|i, j| e.cov[i][j]);
    let stat = 500.0 * delta.dot(&p_att.cholesky().unwrap().solve(&delta));
    eprintln!(
        "takeover: the drawn cloud's mean is {:?} rad from the estimate, 500 δᵀP⁻¹δ {stat:.2}",
        delta.as_slice()
    );
    assert!(
        stat <= 16.27,
        "the drawn cloud's mean is {delta} rad from the estimate (500 δᵀP⁻¹δ {stat})"
    );
    // A broken estimate is refused, not trusted.
    let mut broken = e.clone();
    broken.cov[0][0] = f64::NAN;
    assert!(TakeoverSeed::try_from(&broken).is_err());
}

fn member(name: &str) -> (Node, EngineThreads, Outputs) {
    let mut config = service_config(
        r#"{ service: { key_prefix: "t", filter: { kind: "mekf" }, time: { reorder_window_s: 0.0 }, fleet: { flush_s: 0.02 } } }"#,
    );
    override_fleet(&mut config, true, None, Some(name.into()), None).unwrap();
    collecting_engine(config)
}

fn star_set(t: f64, q: &Quaternion) -> String {
    let a = q.attitude_matrix();
    let obs: Vec<String> = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        .iter()
        .map(|r| {
            let b = a * Vector3::new(r[0], r[1], r[2]);
            format!(
                r#"{{"body":[{},{},{}],"ref":[{},{},{}],"sigma":1e-4}}"#,
                b[0], b[1], b[2], r[0], r[1], r[2]
            )
        })
        .collect();
    format!(r#"{{"t":{t},"obs":[{}]}}"#, obs.join(","))
}

/// Estimate times published per vehicle.
fn published(out: &Outputs) -> BTreeMap<String, Vec<f64>> {
    let mut m: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for (k, p) in out.lock().unwrap().iter() {
        if k.ends_with("/estimate") {
            let e: EstimateMsg = serde_json::from_slice(p).unwrap();
            m.entry(e.vehicle).or_default().push(e.t);
        }
    }
    m
}

#[test]
fn a_member_takes_over_without_losing_a_set() {
    let (a, ta, out_a) = member("a");
    let (b, tb, out_b) = member("b");
    let both: BTreeSet<String> = ["a".to_string(), "b".to_string()].into();
    a.set_members(&ta, both.clone());
    b.set_members(&tb, both.clone());
    let vehicles: Vec<String> = (0..8).map(|i| format!("v{i}")).collect();
    let of_a: Vec<&String> = vehicles
        .iter()
        .filter(|v| owner(v, &both) == Some("a"))
        .collect();
    assert!(!of_a.is_empty() && of_a.len() < vehicles.len());
    let truth = Quaternion::new(0.2, 0.1, -0.3, 0.9).normalized().unwrap();
    // Both members receive every input (zenoh delivers to every subscriber); b also receives a's
    // estimates. `upto` sets per vehicle, 1 s apart.
    let feed = |from: usize, upto: usize, to_a: bool| {
        for k in from..upto {
            for v in &vehicles {
                for (leaf, payload) in [
                    ("gyro", format!(r#"{{"t":{k},"omega":[0,0,0]}}"#)),
                    ("vectors", star_set(k as f64, &truth)),
                ] {
                    let inbound = Inbound {
                        key: format!("t/{v}/{leaf}"),
                        payload: payload.into_bytes(),
                    };
                    if to_a {
                        ta.ingest.send(Some(inbound.clone().into())).unwrap();
                    }
                    tb.ingest.send(Some(inbound.into())).unwrap();
                }
            }
        }
    };
    let relay = |seen: &mut usize| {
        let new: Vec<(String, Vec<u8>)> = out_a.lock().unwrap()[*seen..].to_vec();
        *seen += new.len();
        for (key, payload) in new {
            tb.ingest
                .send(Some(Inbound { key, payload }.into()))
                .unwrap();
        }
    };
    let mut relayed = 0;
    feed(0, 10, true);
    wait_until(
        "both members to publish 10 sets per vehicle",
        Duration::from_secs(20),
        || {
            relay(&mut relayed);
            let (pa, pb) = (published(&out_a), published(&out_b));
            vehicles
                .iter()
                .all(|v| pa.get(v).map_or(0, |t| t.len()) + pb.get(v).map_or(0, |t| t.len()) == 10)
        },
    )
    .unwrap();
    // a's last estimates may have come after the last relay of the wait, and a sends its routes'
    // standby members their last estimates every fleet.flush_s (20 ms here): b must have them all.
    std::thread::sleep(Duration::from_millis(100));
    relay(&mut relayed);
    // Each vehicle was processed by its owner only.
    let pa = published(&out_a);
    for v in &vehicles {
        assert_eq!(pa.contains_key(v), of_a.contains(&v), "{v}");
    }
    assert_eq!(a.engine.vehicles().len(), of_a.len());
    assert_eq!(b.engine.vehicles().len(), vehicles.len() - of_a.len());
    // a stops publishing: its last estimates reached b for sets 0..10; sets 10..13 reach only b (a
    // died before processing them); then b learns that a is gone.
    feed(10, 13, false);
    std::thread::sleep(Duration::from_millis(100));
    b.set_members(&tb, ["b".to_string()].into());
    feed(13, 15, false);
    wait_until(
        "b to publish every set of every vehicle",
        Duration::from_secs(20),
        || {
            let pb = published(&out_b);
            of_a.iter().all(|v| pb.get(*v).map_or(0, |t| t.len()) == 5)
                && vehicles
                    .iter()
                    .all(|v| pb.get(v).is_some_and(|t| t.last() == Some(&14.0)))
        },
    )
    .unwrap();
    let pb = published(&out_b);
    for v in &of_a {
        // Sets 10..15 published by b, after a's 0..10: none lost, none repeated.
        assert_eq!(pb[*v], vec![10.0, 11.0, 12.0, 13.0, 14.0], "{v}");
        let e = query::state_of(&b.engine, v).unwrap();
        assert_eq!(e.seq, 15, "{v}: seq continues across the takeover");
        assert_eq!(e.diagnostics.reinits.get("takeover"), Some(&1));
        let q = Quaternion::new(e.q.x, e.q.y, e.q.z, e.q.w);
        assert!(q.compose(&truth.inverse()).angle() < 1e-3);
    }
    assert_eq!(b.engine.vehicles().len(), vehicles.len());
    let h = b.health().fleet.unwrap();
    assert_eq!(
        (h.takeovers, h.members.clone()),
        (of_a.len() as u64, vec!["b".to_string()])
    );
    drop(a);
    ta.shutdown();
    tb.shutdown();
}

#[test]
fn the_shipped_fleet_instance_configuration_is_valid() {
    let path = repo().join("config/fleet/instance.json5");
    let file = attitude_service::service::config::load(&path).unwrap();
    let f = &file.service.fleet;
    assert_eq!(f.mode, attitude_service::fleet::FleetMode::Dynamic);
    assert!(f.standby_s > 3.0, "standby must cover the 3 s lease");
    // Bad fleet settings are refused with the option's name.
    for (bad, what) in [
        (r#"{service:{fleet:{mode:"cluster"}}}"#, "fleet.mode"),
        (r#"{service:{fleet:{instance:"a/b"}}}"#, "fleet.instance"),
        (r#"{service:{fleet:{vehicles:"a/b"}}}"#, "fleet.vehicles"),
        (r#"{service:{fleet:{standby_s:-1}}}"#, "fleet.standby_s"),
        (r#"{service:{fleet:{routes:"g"}}}"#, "fleet.routes"),
        (r#"{service:{fleet:{flush_s:0}}}"#, "fleet.flush_s"),
    ] {
        let e = parse(bad, "test").err().expect(bad).to_string();
        assert!(e.contains(what), "{bad}: {e}");
    }
}

/// Four engines of a dynamic fleet, their inputs delivered as zenoh would deliver a routed sender's:
/// each input on its routed key to the members subscribed to its route (its owner), the sender's
/// batches of a route to its standby members, an owner's batches of estimates to them too. Every route
/// has one owner and at most two standby members; a vehicle is processed by its owner only. Then a
/// member fails: the owners of its routes after the change held them before, and take its vehicles over
/// from the batches with no vector set lost or answered twice, each input used once even when it
/// arrives both on its own and in a batch.
#[test]
fn routed_inputs_reach_owners_and_standbys_only() {
    use attitude_service::fleet::batch::{records, BatchWriter};
    use attitude_service::fleet::Assignment;
    use attitude_service::wire::keys::{route_of, Keys, Leaf, ROUTES};

    let names = ["a", "b", "c", "d"];
    let members: Vec<_> = names.iter().map(|n| member(n)).collect();
    let everyone: BTreeSet<String> = names.iter().map(|s| s.to_string()).collect();
    for (e, t, _) in &members {
        e.set_members(t, everyone.clone());
    }
    let plans = || -> Vec<_> {
        members
            .iter()
            .map(|(e, _, _)| e.member.route_plan().unwrap().borrow().clone())
            .collect()
    };
    wait_until("every member's plan", Duration::from_secs(10), || {
        plans().iter().all(|p| !p.owned.is_empty())
    })
    .unwrap();
    // One owner per route, its standby members the route's other holders.
    let assignment = Assignment::new(&everyone).unwrap();
    let p = plans();
    for r in 0..ROUTES as u8 {
        let owners: Vec<&str> = (0..4)
            .filter(|&i| p[i].owned.contains(&r))
            .map(|i| names[i])
            .collect();
        assert_eq!(owners, vec![assignment.owner(r)], "route {r}");
        // (A route just taken over keeps its batches coming for a while, to its owner too.)
        let standby: BTreeSet<&str> = (0..4)
            .filter(|&i| p[i].standby.contains(&r) && !p[i].owned.contains(&r))
            .map(|i| names[i])
            .collect();
        let others: BTreeSet<&str> = assignment
            .holders(r)
            .filter(|m| *m != assignment.owner(r))
            .collect();
        assert_eq!(standby, others, "route {r}");
        assert_eq!(standby.len(), 2);
    }
    let keys = Keys::new("t");
    let vehicles: Vec<String> = (0..24).map(|i| format!("v{i}")).collect();
    let truth = Quaternion::new(0.2, 0.1, -0.3, 0.9).normalized().unwrap();
    let alive = std::cell::RefCell::new([true; 4]);
    // Delivers to the members whose current plan subscribes (owned: routed inputs; standby: batches).
    let deliver = |key: &str, payload: &[u8], route: u8, to_standby: bool| {
        let p = plans();
        for (i, (_, t, _)) in members.iter().enumerate() {
            let subscribed = if to_standby {
                &p[i].standby
            } else {
                &p[i].owned
            };
            if alive.borrow()[i] && subscribed.contains(&route) {
                t.ingest
                    .send(Some(
                        Inbound {
                            key: key.to_string(),
                            payload: payload.to_vec(),
                        }
                        .into(),
                    ))
                    .unwrap();
            }
        }
    };
    let mut held: Vec<BatchWriter> = (0..ROUTES).map(|_| BatchWriter::default()).collect();
    // The sender: each set and gyro sample on its routed key, and into its route's batch.
    let send = |k: usize, held: &mut Vec<BatchWriter>| {
        for v in &vehicles {
            let r = route_of(v);
            for (leaf, payload) in [
                (Leaf::Gyro, format!(r#"{{"t":{k},"omega":[0,0,0]}}"#)),
                (Leaf::Vectors, star_set(k as f64, &truth)),
            ] {
                deliver(&keys.routed(v, leaf), payload.as_bytes(), r, false);
                held[r as usize].push(v, leaf.as_str(), payload.as_bytes());
            }
        }
    };
    let flush = |held: &mut Vec<BatchWriter>| {
        for (r, w) in held.iter_mut().enumerate() {
            if !w.is_empty() {
                let b = w.take();
                deliver(&keys.standby_inputs(r as u8), &b, r as u8, true);
            }
        }
    };
    // The owners' batches of estimates, relayed to the standby members as they appear.
    let mut relayed = [0usize; 4];
    let relay = |relayed: &mut [usize; 4]| {
        for (i, (_, _, out)) in members.iter().enumerate() {
            let new: Vec<(String, Vec<u8>)> = out.lock().unwrap()[relayed[i]..].to_vec();
            relayed[i] += new.len();
            if !alive.borrow()[i] {
                continue;
            }
            for (key, payload) in new {
                if let Some(r) = key
                    .strip_prefix("t/@/standby/")
                    .and_then(|rest| rest.split('/').next())
                    .and_then(|c| u8::from_str_radix(c, 16).ok())
                {
                    assert!(key.ends_with("/estimates/default"), "{key}");
                    assert!(records(&payload)
                        .all(|rec| rec.is_ok_and(|rec| route_of(rec.vehicle) == r)));
                    deliver(&key, &payload, r, true);
                }
            }
        }
    };
    let published_by = |i: usize| published(&members[i].2);
    for k in 0..10 {
        send(k, &mut held);
        flush(&mut held);
        relay(&mut relayed);
    }
    wait_until(
        "every set of every vehicle answered",
        Duration::from_secs(20),
        || {
            relay(&mut relayed);
            vehicles.iter().all(|v| {
                (0..4)
                    .map(|i| published_by(i).get(v).map_or(0, |t| t.len()))
                    .sum::<usize>()
                    == 10
            })
        },
    )
    .unwrap();
    // Each vehicle by its route's owner only; the others received none of its inputs one by one.
    for v in &vehicles {
        let owner = assignment.owner(route_of(v));
        for (i, name) in names.iter().enumerate() {
            let n = published_by(i).get(v).map_or(0, |t| t.len());
            assert_eq!(n, if *name == owner { 10 } else { 0 }, "{v} at {name}");
        }
    }
    for (i, (e, _, _)) in members.iter().enumerate() {
        let h = e.health();
        let f = h.fleet.unwrap();
        assert_eq!(f.routes_owned, p[i].owned, "{}", names[i]);
        let standby: Vec<u8> = p[i]
            .standby
            .iter()
            .filter(|r| !p[i].owned.contains(r))
            .copied()
            .collect();
        assert_eq!(f.routes_standby, standby, "{}", names[i]);
        let owned = vehicles
            .iter()
            .filter(|v| assignment.owner(route_of(v)) == names[i])
            .count() as u64;
        assert_eq!(
            h.received,
            owned * 20,
            "{}: inputs received one by one",
            names[i]
        );
        assert!(f.standby_bytes > 0 && f.standby_malformed == 0);
    }
    // a fails: its last estimates reach its standby members (it batches them every fleet.flush_s),
    // then nothing more. Sets 10..12 go to a, and their batches are late (the sender's flush comes
    // after the others notice); set 13 reaches the new owners on its own and in a batch (a new owner
    // keeps its new routes' batches coming for a while: `RoutePlan`).
    std::thread::sleep(Duration::from_millis(100));
    relay(&mut relayed);
    let of_a: Vec<&String> = vehicles
        .iter()
        .filter(|v| assignment.owner(route_of(v)) == "a")
        .collect();
    assert!(!of_a.is_empty());
    for k in 10..13 {
        send(k, &mut held);
    }
    alive.borrow_mut()[0] = false;
    let rest: BTreeSet<String> = ["b", "c", "d"].iter().map(|s| s.to_string()).collect();
    for (e, t, _) in &members[1..] {
        e.set_members(t, rest.clone());
    }
    let after = Assignment::new(&rest).unwrap();
    for r in 0..ROUTES as u8 {
        assert!(
            assignment.holds(after.owner(r), r),
            "route {r} moved to a member without its data"
        );
    }
    wait_until("the new plans", Duration::from_secs(10), || {
        let p = plans();
        (0..ROUTES as u8).all(|r| (1..4).filter(|&i| p[i].owned.contains(&r)).count() == 1)
    })
    .unwrap();
    flush(&mut held);
    send(13, &mut held);
    flush(&mut held);
    send(14, &mut held);
    flush(&mut held);
    wait_until(
        "the new owners to answer every set",
        Duration::from_secs(20),
        || {
            relay(&mut relayed);
            of_a.iter().all(|v| {
                (1..4)
                    .filter_map(|i| published_by(i).get(*v).cloned())
                    .flatten()
                    .filter(|t| *t >= 10.0)
                    .count()
                    >= 5
            })
        },
    )
    .unwrap_or_else(|e| {
        for v in &of_a {
            let got: Vec<_> = (1..4)
                .map(|i| (names[i], published_by(i).get(*v).cloned()))
                .collect();
            eprintln!("{v}: {got:?}");
        }
        panic!("{e}")
    });
    std::thread::sleep(Duration::from_millis(200));
    for v in &of_a {
        let new_owner = after.owner(route_of(v));
        let i = names.iter().position(|n| *n == new_owner).unwrap();
        assert_eq!(
            published_by(i)[*v],
            vec![10.0, 11.0, 12.0, 13.0, 14.0],
            "{v} at {new_owner}"
        );
        for j in (1..4).filter(|&j| j != i) {
            assert!(
                !published_by(j).contains_key(*v),
                "{v} also at {}",
                names[j]
            );
        }
        let e = query::state_of(&members[i].0.engine, v).unwrap();
        assert_eq!(e.seq, 15, "{v}: seq continues across the takeover");
        assert_eq!(e.diagnostics.reinits.get("takeover"), Some(&1));
    }
    for (_, t, _) in members {
        t.shutdown();
    }
}
