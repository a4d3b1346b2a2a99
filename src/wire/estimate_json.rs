//! `P/V/estimate` written by hand: the bytes `serde_json::to_writer` writes for an [`EstimateMsg`],
//! byte for byte (the tests below hold it against serde_json on every shape), in 60% of the
//! instructions (9 500 against 15 400 per estimate). Every estimate a subscriber takes is serialised,
//! and through serde the field names were each scanned for characters to escape and written through a
//! map's machinery, and the covariance's 15 mirrored entries formatted twice (BENCHMARKS.md, "The
//! engine alone"). Here a name
//! is a constant, a mirrored entry equal to its twin (bit for bit) is the twin's text copied, and
//! numbers and strings still go through serde_json, so their text is serde_json's.
//!
//! Every struct is taken apart by name: a field added to a message does not compile until it is
//! written here too (and the tests compare with serde_json's output for it).

use super::estimate::{
    DiagnosticsMsg, EstimateMsg, GateCountsMsg, ImuDiagnosticsMsg, MeasuredNoiseMsg, QuaternionMsg,
};
use serde::Serialize;
use std::collections::BTreeMap;

/// A number, string, bool or `null` as serde_json writes it.
fn scalar<T: Serialize + ?Sized>(out: &mut Vec<u8>, v: &T) {
    // (Writing to a Vec cannot fail, and these types always serialise.)
    let _ = serde_json::to_writer(&mut *out, v);
}

/// `"name":` after the object's opening brace (`first`) or a comma.
fn key(out: &mut Vec<u8>, first: bool, name: &[u8]) {
    if !first {
        out.push(b',');
    }
    out.push(b'"');
    out.extend_from_slice(name);
    out.extend_from_slice(b"\":");
}

fn floats(out: &mut Vec<u8>, v: &[f64]) {
    out.push(b'[');
    for (i, x) in v.iter().enumerate() {
        if i > 0 {
            out.push(b',');
        }
        scalar(out, x);
    }
    out.push(b']');
}

/// A map with string keys (a JSON object in key order, as a `BTreeMap` serialises).
fn map<V>(out: &mut Vec<u8>, m: &BTreeMap<String, V>, mut value: impl FnMut(&mut Vec<u8>, &V)) {
    out.push(b'{');
    for (i, (k, v)) in m.iter().enumerate() {
        if i > 0 {
            out.push(b',');
        }
        scalar(out, k.as_str());
        out.push(b':');
        value(out, v);
    }
    out.push(b'}');
}

/// The covariance's rows; an entry below the diagonal whose bits equal its mirror's is that text.
fn covariance(out: &mut Vec<u8>, cov: &[[f64; 6]; 6]) {
    let mut text = [[(0usize, 0usize); 6]; 6];
    out.push(b'[');
    for i in 0..6 {
        if i > 0 {
            out.push(b',');
        }
        out.push(b'[');
        for j in 0..6 {
            if j > 0 {
                out.push(b',');
            }
            let start = out.len();
            if j < i && cov[i][j].to_bits() == cov[j][i].to_bits() {
                let (a, b) = text[j][i];
                out.extend_from_within(a..b);
            } else {
                scalar(out, &cov[i][j]);
            }
            text[i][j] = (start, out.len());
        }
        out.push(b']');
    }
    out.push(b']');
}

fn quaternion(out: &mut Vec<u8>, q: &QuaternionMsg) {
    let QuaternionMsg { w, x, y, z } = q;
    out.push(b'{');
    for (i, (name, v)) in [(&b"w"[..], w), (b"x", x), (b"y", y), (b"z", z)]
        .into_iter()
        .enumerate()
    {
        key(out, i == 0, name);
        scalar(out, v);
    }
    out.push(b'}');
}

fn gate_counts(out: &mut Vec<u8>, c: &GateCountsMsg) {
    let GateCountsMsg {
        accepted,
        gated,
        norm_gated,
        disturbed,
    } = c;
    out.push(b'{');
    key(out, true, b"accepted");
    scalar(out, accepted);
    key(out, false, b"gated");
    scalar(out, gated);
    key(out, false, b"norm_gated");
    scalar(out, norm_gated);
    key(out, false, b"disturbed");
    scalar(out, disturbed);
    out.push(b'}');
}

fn measured(out: &mut Vec<u8>, m: &MeasuredNoiseMsg) {
    let MeasuredNoiseMsg {
        gyro_noise_density_deg_s_sqrt_hz,
        acc_noise_density_ug_sqrt_hz,
        mag_noise,
        rest_s,
    } = m;
    out.push(b'{');
    key(out, true, b"gyro_noise_density_deg_s_sqrt_hz");
    scalar(out, gyro_noise_density_deg_s_sqrt_hz);
    key(out, false, b"acc_noise_density_ug_sqrt_hz");
    scalar(out, acc_noise_density_ug_sqrt_hz);
    key(out, false, b"mag_noise");
    scalar(out, mag_noise);
    key(out, false, b"rest_s");
    scalar(out, rest_s);
    out.push(b'}');
}

fn imu(out: &mut Vec<u8>, d: &ImuDiagnosticsMsg) {
    let ImuDiagnosticsMsg {
        samples,
        at_rest,
        rest_samples,
        bias_updates,
        tilt_updates,
        tilt_gated,
        heading_updates,
        mag_rejected,
        mag_disturbed,
        mag_new_fields,
        mag_hard_iron_changes,
        tilt_reacquisitions,
        heading_reacquisitions,
        tilt_sigma_lp_deg,
        mag_norm,
        mag_dip_deg,
        mag_offset,
        mag_reference,
        gyro_saturated,
        acc_saturated,
        heading_aided,
        heading_unaided_s,
        gaps,
        blind_s,
        measured: noise,
    } = d;
    out.push(b'{');
    key(out, true, b"samples");
    scalar(out, samples);
    key(out, false, b"at_rest");
    scalar(out, at_rest);
    for (name, v) in [
        (&b"rest_samples"[..], rest_samples),
        (b"bias_updates", bias_updates),
        (b"tilt_updates", tilt_updates),
        (b"tilt_gated", tilt_gated),
        (b"heading_updates", heading_updates),
        (b"mag_rejected", mag_rejected),
    ] {
        key(out, false, name);
        scalar(out, v);
    }
    key(out, false, b"mag_disturbed");
    scalar(out, mag_disturbed);
    for (name, v) in [
        (&b"mag_new_fields"[..], mag_new_fields),
        (b"mag_hard_iron_changes", mag_hard_iron_changes),
        (b"tilt_reacquisitions", tilt_reacquisitions),
        (b"heading_reacquisitions", heading_reacquisitions),
    ] {
        key(out, false, name);
        scalar(out, v);
    }
    key(out, false, b"tilt_sigma_lp_deg");
    scalar(out, tilt_sigma_lp_deg);
    if let Some(v) = mag_norm {
        key(out, false, b"mag_norm");
        scalar(out, v);
    }
    if let Some(v) = mag_dip_deg {
        key(out, false, b"mag_dip_deg");
        scalar(out, v);
    }
    if let Some(v) = mag_offset {
        key(out, false, b"mag_offset");
        floats(out, v);
    }
    if let Some(v) = mag_reference {
        key(out, false, b"mag_reference");
        scalar(out, v.as_str());
    }
    key(out, false, b"gyro_saturated");
    scalar(out, gyro_saturated);
    key(out, false, b"acc_saturated");
    scalar(out, acc_saturated);
    key(out, false, b"heading_aided");
    scalar(out, heading_aided);
    key(out, false, b"heading_unaided_s");
    scalar(out, heading_unaided_s);
    key(out, false, b"gaps");
    scalar(out, gaps);
    key(out, false, b"blind_s");
    scalar(out, blind_s);
    key(out, false, b"measured");
    measured(out, noise);
    out.push(b'}');
}

fn diagnostics(out: &mut Vec<u8>, d: &DiagnosticsMsg) {
    let DiagnosticsMsg {
        propagations,
        updates,
        nis,
        nis_dof,
        ess,
        particles,
        level,
        concentration,
        eigen_gap,
        pc_stages,
        resamples,
        fiducial_fallbacks,
        rejected,
        gyro_gap_s,
        gyro_gaps,
        gate,
        consecutive_gated,
        rollbacks,
        reinits,
        held,
        replayed,
        late_fused,
        missed,
        imu: imu_diagnostics,
    } = d;
    out.push(b'{');
    key(out, true, b"propagations");
    scalar(out, propagations);
    key(out, false, b"updates");
    scalar(out, updates);
    if let Some(v) = nis {
        key(out, false, b"nis");
        scalar(out, v);
    }
    if let Some(v) = nis_dof {
        key(out, false, b"nis_dof");
        scalar(out, v);
    }
    if let Some(v) = ess {
        key(out, false, b"ess");
        scalar(out, v);
    }
    if let Some(v) = particles {
        key(out, false, b"particles");
        scalar(out, v);
    }
    if let Some(v) = level {
        key(out, false, b"level");
        scalar(out, v);
    }
    if let Some(v) = concentration {
        key(out, false, b"concentration");
        scalar(out, v);
    }
    if let Some(v) = eigen_gap {
        key(out, false, b"eigen_gap");
        scalar(out, v);
    }
    if let Some(v) = pc_stages {
        key(out, false, b"pc_stages");
        scalar(out, v);
    }
    if let Some(v) = resamples {
        key(out, false, b"resamples");
        scalar(out, v);
    }
    if let Some(v) = fiducial_fallbacks {
        key(out, false, b"fiducial_fallbacks");
        scalar(out, v);
    }
    if !rejected.is_empty() {
        key(out, false, b"rejected");
        map(out, rejected, |out, v| scalar(out, v));
    }
    if let Some(v) = gyro_gap_s {
        key(out, false, b"gyro_gap_s");
        scalar(out, v);
    }
    key(out, false, b"gyro_gaps");
    scalar(out, gyro_gaps);
    if !gate.is_empty() {
        key(out, false, b"gate");
        map(out, gate, gate_counts);
    }
    key(out, false, b"consecutive_gated");
    scalar(out, consecutive_gated);
    key(out, false, b"rollbacks");
    scalar(out, rollbacks);
    if !reinits.is_empty() {
        key(out, false, b"reinits");
        map(out, reinits, |out, v| scalar(out, v));
    }
    key(out, false, b"held");
    scalar(out, held);
    if *replayed {
        key(out, false, b"replayed");
        scalar(out, replayed);
    }
    if *late_fused != 0 {
        key(out, false, b"late_fused");
        scalar(out, late_fused);
    }
    if *missed != 0 {
        key(out, false, b"missed");
        scalar(out, missed);
    }
    if let Some(d) = imu_diagnostics {
        key(out, false, b"imu");
        imu(out, d);
    }
    out.push(b'}');
}

/// Appends `e` as JSON to `out`: exactly `serde_json::to_writer(out, e)`'s bytes.
pub fn write_estimate(out: &mut Vec<u8>, e: &EstimateMsg) {
    let EstimateMsg {
        vehicle,
        t,
        q,
        bias,
        cov,
        sigma_deg,
        filter,
        fiducial,
        seq,
        diagnostics: d,
    } = e;
    out.push(b'{');
    key(out, true, b"vehicle");
    scalar(out, vehicle.as_str());
    key(out, false, b"t");
    scalar(out, t);
    key(out, false, b"q");
    quaternion(out, q);
    key(out, false, b"bias");
    floats(out, bias);
    key(out, false, b"cov");
    covariance(out, cov);
    key(out, false, b"sigma_deg");
    floats(out, sigma_deg);
    key(out, false, b"filter");
    scalar(out, filter.as_str());
    key(out, false, b"fiducial");
    scalar(out, fiducial);
    key(out, false, b"seq");
    scalar(out, seq);
    key(out, false, b"diagnostics");
    diagnostics(out, d);
    out.push(b'}');
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn serde(e: &EstimateMsg) -> String {
        String::from_utf8(serde_json::to_vec(e).unwrap()).unwrap()
    }

    fn ours(e: &EstimateMsg) -> String {
        let mut out = b"prefix".to_vec();
        write_estimate(&mut out, e);
        String::from_utf8(out[6..].to_vec()).unwrap()
    }

    fn minimal() -> EstimateMsg {
        EstimateMsg {
            vehicle: "v1".into(),
            t: 0.0,
            q: QuaternionMsg {
                w: 1.0,
                x: 0.0,
                y: 0.0,
                z: 0.0,
            },
            bias: [0.0; 3],
            cov: [[0.0; 6]; 6],
            sigma_deg: [0.0; 3],
            filter: "mekf".into(),
            fiducial: None,
            seq: 1,
            diagnostics: DiagnosticsMsg::default(),
        }
    }

    /// Every optional field present, every map filled, names that need escaping, a covariance that is
    /// not quite symmetric, numbers JSON cannot hold.
    fn full() -> EstimateMsg {
        let mut e = minimal();
        e.vehicle = "sat\"7\\é\u{1}".into();
        e.t = 1e300;
        e.q = QuaternionMsg {
            w: 0.5,
            x: -0.5,
            y: f64::MIN_POSITIVE,
            z: -0.0,
        };
        e.bias = [1e-7, -3.25e-5, f64::NAN];
        for i in 0..6 {
            for j in 0..6 {
                e.cov[i][j] = 1.0 / (1.0 + (j.min(i) * 7 + j.max(i)) as f64);
            }
        }
        e.cov[4][1] = f64::from_bits(e.cov[1][4].to_bits() + 1);
        e.cov[5][0] = -0.0;
        e.cov[0][5] = 0.0;
        e.sigma_deg = [f64::INFINITY, 0.1, 3.0];
        e.filter = "qpf".into();
        e.fiducial = Some("average".into());
        e.seq = u64::MAX;
        let d = &mut e.diagnostics;
        d.propagations = 10;
        d.updates = 3;
        d.nis = Some(2.5);
        d.nis_dof = Some(3);
        d.ess = Some(812.25);
        d.particles = Some(1000);
        d.level = Some(3);
        d.concentration = Some(0.999);
        d.eigen_gap = Some(f64::NEG_INFINITY);
        d.pc_stages = Some(2);
        d.resamples = Some(7);
        d.fiducial_fallbacks = Some(1);
        d.rejected = [("duplicate".to_string(), 2), ("late\n".to_string(), 1)].into();
        d.gyro_gap_s = Some(0.25);
        d.gyro_gaps = 4;
        d.gate = [
            (
                "star".to_string(),
                GateCountsMsg {
                    accepted: 5,
                    gated: 1,
                    norm_gated: 2,
                    disturbed: 3,
                },
            ),
            (String::new(), GateCountsMsg::default()),
        ]
        .into();
        d.consecutive_gated = 2;
        d.rollbacks = 9;
        d.reinits = [("gate".to_string(), 1)].into();
        d.held = 12;
        d.replayed = true;
        d.late_fused = 5;
        d.missed = 6;
        d.imu = Some(ImuDiagnosticsMsg {
            samples: 100,
            at_rest: true,
            rest_samples: 40,
            bias_updates: 1,
            tilt_updates: 2,
            tilt_gated: 3,
            heading_updates: 4,
            mag_rejected: 5,
            mag_disturbed: true,
            mag_new_fields: 6,
            mag_hard_iron_changes: 7,
            tilt_reacquisitions: 8,
            heading_reacquisitions: 9,
            tilt_sigma_lp_deg: 0.75,
            mag_norm: Some(48.5),
            mag_dip_deg: Some(-61.0),
            mag_offset: Some([1.0, -2.0, f64::NAN]),
            mag_reference: Some("confirmed".into()),
            gyro_saturated: 10,
            acc_saturated: 11,
            heading_aided: false,
            heading_unaided_s: 12.5,
            gaps: 13,
            blind_s: 0.125,
            measured: MeasuredNoiseMsg {
                gyro_noise_density_deg_s_sqrt_hz: 0.01,
                acc_noise_density_ug_sqrt_hz: 120.0,
                mag_noise: 0.3,
                rest_s: 30.0,
            },
        });
        e
    }

    #[test]
    fn the_bytes_are_serde_jsons() {
        for e in [minimal(), full()] {
            assert_eq!(ours(&e), serde(&e));
        }
        // Each optional part alone.
        let f = full();
        let mut e = minimal();
        e.diagnostics.imu = f.diagnostics.imu.clone();
        if let Some(imu) = &mut e.diagnostics.imu {
            imu.mag_norm = None;
            imu.mag_offset = None;
        }
        assert_eq!(ours(&e), serde(&e));
        let mut e = minimal();
        e.diagnostics.gate = f.diagnostics.gate.clone();
        e.diagnostics.late_fused = 1;
        assert_eq!(ours(&e), serde(&e));
    }

    /// The mirrored entries: copied where the bits are equal, written where they differ (here
    /// `-0.0` against `0.0` and a last-bit difference).
    #[test]
    fn a_mirrored_entry_is_copied_only_when_it_is_the_same_number() {
        let text = ours(&full());
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        let cov = &v["cov"];
        assert_eq!(cov[5][0].to_string(), "-0.0");
        assert_eq!(cov[0][5].to_string(), "0.0");
        assert_ne!(cov[4][1], cov[1][4]);
        assert_eq!(cov[3][2], cov[2][3]);
    }

    fn number() -> impl Strategy<Value = f64> {
        prop_oneof![
            any::<f64>(),
            Just(0.0),
            Just(-0.0),
            Just(f64::NAN),
            Just(f64::INFINITY),
            -1e3..1e3f64,
        ]
    }

    fn name() -> impl Strategy<Value = String> {
        prop_oneof![Just(String::new()), "[a-z_]{1,8}", any::<String>()]
    }

    prop_compose! {
        fn estimate()(
            vehicle in name(),
            numbers in proptest::collection::vec(number(), 60),
            mirror in proptest::collection::vec(any::<bool>(), 15),
            counts in proptest::collection::vec(any::<u64>(), 16),
            present in proptest::collection::vec(any::<bool>(), 24),
            keys in proptest::collection::vec(name(), 0..4),
            fiducial in proptest::option::of(name()),
        ) -> EstimateMsg {
            let mut e = minimal();
            let mut n = numbers.into_iter();
            let mut next = || n.next().unwrap_or(0.5);
            e.vehicle = vehicle;
            e.t = next();
            e.q = QuaternionMsg { w: next(), x: next(), y: next(), z: next() };
            e.bias = [next(), next(), next()];
            let mut k = 0;
            for i in 0..6 {
                for j in 0..=i {
                    e.cov[i][j] = next();
                    e.cov[j][i] = if j < i && !mirror[k] { next() } else { e.cov[i][j] };
                    if j < i {
                        k += 1;
                    }
                }
            }
            e.sigma_deg = [next(), next(), next()];
            e.fiducial = fiducial;
            e.seq = counts[0];
            let p = |i: usize| present[i];
            let d = &mut e.diagnostics;
            d.propagations = counts[1];
            d.updates = counts[2];
            d.nis = p(0).then(&mut next);
            d.nis_dof = p(1).then_some(counts[3] as usize);
            d.ess = p(2).then(&mut next);
            d.particles = p(3).then_some(counts[4] as usize);
            d.level = p(4).then_some(counts[5] as u8);
            d.concentration = p(5).then(&mut next);
            d.eigen_gap = p(6).then(&mut next);
            d.pc_stages = p(7).then_some(counts[6] as u32);
            d.resamples = p(8).then_some(counts[7]);
            d.fiducial_fallbacks = p(9).then_some(counts[8]);
            d.gyro_gap_s = p(10).then(&mut next);
            d.gyro_gaps = counts[9];
            for (i, key) in keys.iter().enumerate() {
                if p(11) {
                    d.rejected.insert(key.clone(), counts[10] >> i);
                }
                if p(12) {
                    d.gate.insert(key.clone(), GateCountsMsg {
                        accepted: counts[11] >> i,
                        gated: counts[12],
                        norm_gated: i as u64,
                        disturbed: counts[13] & 7,
                    });
                }
                if p(13) {
                    d.reinits.insert(key.clone(), i as u64);
                }
            }
            d.consecutive_gated = counts[14] as u32;
            d.rollbacks = counts[15];
            d.held = counts[3] as usize & 0xff;
            d.replayed = p(14);
            d.late_fused = if p(15) { counts[4] } else { 0 };
            d.missed = if p(16) { counts[5] } else { 0 };
            if p(17) {
                let mut imu = full().diagnostics.imu.unwrap_or_default();
                imu.tilt_sigma_lp_deg = next();
                imu.heading_unaided_s = next();
                imu.mag_norm = p(18).then(&mut next);
                imu.mag_dip_deg = p(19).then(&mut next);
                imu.mag_offset = p(20).then(|| [next(), next(), next()]);
                imu.mag_reference = p(21).then(|| keys.first().cloned().unwrap_or_default());
                imu.at_rest = p(22);
                imu.heading_aided = p(23);
                imu.measured.rest_s = next();
                d.imu = Some(imu);
            }
            e
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        /// Any estimate: the same bytes as serde_json's.
        #[test]
        fn any_estimate_is_written_as_serde_json_writes_it(e in estimate()) {
            prop_assert_eq!(ours(&e), serde(&e));
        }
    }
}
