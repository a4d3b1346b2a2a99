//! The JSON wire format of the service (contract v1; prose and schemas in `proto/`).
//!
//! Wire types are their own structs; they are converted into the numeric core's domain types by
//! validating functions that say exactly what is wrong ([`Rejection`]), and built from domain types for
//! output. Quaternions travel as `{"w", "x", "y", "z"}` (the body's orientation in the reference frame,
//! `b = A(q) r`), normalised to `w ≥ 0` in replies; covariances as six rows of six numbers over
//! `[δα (rad, body axes); δβ (rad/s)]`.

mod admin;
mod estimate;
mod estimate_json;
mod input;
mod input_scan;
pub mod keys;
mod rejection;
mod reset;

pub use admin::*;
pub use estimate::*;
pub use estimate_json::write_estimate;
pub use input::*;
pub use input_scan::Scanned;
pub use rejection::*;
pub use reset::*;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::Quaternion;

    fn lim() -> InputLimits {
        InputLimits::default()
    }

    #[test]
    fn a_key_given_twice_is_refused_at_any_depth() {
        let top = decode_batch::<GyroMsg>(br#"{"t": 1.0, "omega": [0, 0, 0], "t": 2.0}"#, &lim());
        assert_eq!(top.unwrap_err().code, RejectCode::BadRequest);
        let nested = decode_batch::<VectorsMsg>(
            br#"{"t": 1.0, "obs": [{"body": [1, 0, 0], "ref": [1, 0, 0], "ref": [0, 1, 0], "sigma": 0.1}]}"#,
            &lim(),
        );
        let e = nested.unwrap_err();
        assert_eq!(e.code, RejectCode::BadRequest);
        assert!(e.message.contains("duplicate field `ref`"), "{}", e.message);
        // Not JSON at all is still invalid_json.
        let broken = decode_batch::<GyroMsg>(br#"{"t": 1.0,"#, &lim());
        assert_eq!(broken.unwrap_err().code, RejectCode::InvalidJson);
    }

    /// serde stops at the first fault; the codes still rank text that is not JSON first, then a batch
    /// over the limit, then the shape.
    #[test]
    fn faults_rank_as_the_contract_says() {
        let gyro = |p: &str, l: &InputLimits| decode_batch::<GyroMsg>(p.as_bytes(), l).unwrap_err();
        let deep = format!("{}{}", "[".repeat(200), "]".repeat(200));
        for p in [
            deep.as_str(),
            r#"{"t": "x", "omega": [0, 0, NaN]}"#,
            r#"{"t": 1, "omega": [0, 0, 0, 1e999]}"#,
        ] {
            assert_eq!(gyro(p, &lim()).code, RejectCode::InvalidJson, "{p}");
        }
        let r = gyro(r#"{"t": 1, "omega": [0, 0, 0, 0]}"#, &lim());
        assert_eq!(r.code, RejectCode::BadRequest);
        let few = InputLimits {
            max_batch: 2,
            ..lim()
        };
        let r = gyro(r#"[{"t": null}, {"t": 1}, {"t": 2}]"#, &few);
        assert_eq!(r.code, RejectCode::BatchTooLarge, "{}", r.message);
        let r = gyro(
            r#"[{"t": 1, "omega": [0, 0, 0]}, {"t": 2, "omega": [0, null, 0]}]"#,
            &few,
        );
        assert_eq!(r.code, RejectCode::NonFinite);
        assert!(r.message.starts_with("batch item 1: "), "{}", r.message);
        let imu = |p: &str| {
            decode_batch::<ImuMsg>(p.as_bytes(), &lim())
                .unwrap_err()
                .code
        };
        let base = r#""t": 1, "gyr": [0, 0, 0], "acc": [0, 0, 9.8]"#;
        assert_eq!(
            imu(&format!("{{{base}, \"mag\": null}}")),
            RejectCode::BadRequest
        );
        assert_eq!(
            imu(&format!("{{{base}, \"mag\": [0, null, 0]}}")),
            RejectCode::NonFinite
        );
        let reset = |p: &str| {
            decode_one::<ResetMsg>(p.as_bytes(), &lim())
                .unwrap_err()
                .code
        };
        for (p, code) in [
            (r#"{"particles": null}"#, RejectCode::NonFinite),
            (r#"{"t": null}"#, RejectCode::NonFinite),
            (r#"{"filter": null}"#, RejectCode::BadRequest),
            (r#"{"q": [1, 0, 0, 0]}"#, RejectCode::BadRequest),
            (
                r#"{"q": {"w": 1, "x": 0, "y": 0, "z": null}}"#,
                RejectCode::NonFinite,
            ),
            // A 1σ is a number (or three): null is a null number (proto/README.md: `non_finite`
            // where a number belongs; the old value-first decoder said bad_request here).
            (r#"{"sigma_deg": null}"#, RejectCode::NonFinite),
            (r#"{"sigma_deg": [1, null, 1]}"#, RejectCode::NonFinite),
            (r#"[{}]"#, RejectCode::BadRequest),
        ] {
            assert_eq!(reset(p), code, "{p}");
        }
    }

    /// Straight into domain values: what is appended is all or nothing, and a refusal of the conversion
    /// ranks after every fault of the text and names its item only in a batch.
    #[test]
    fn decoding_into_domain_values() {
        let gyro = |g: GyroMsg| g.to_domain(&lim());
        let mut out = vec![];
        let two = br#"[{"t": 1, "omega": [0, 0, 0]}, {"t": 2, "omega": [0, 0, 0.5]}]"#;
        assert_eq!(decode_batch_into(two, &lim(), gyro, &mut out), Ok(2));
        assert_eq!(
            decode_batch_into(br#"{"t": 3, "omega": [0, 0, 0]}"#, &lim(), gyro, &mut out),
            Ok(1)
        );
        assert_eq!(
            out.iter().map(|g| g.t_s).collect::<Vec<_>>(),
            [1.0, 2.0, 3.0]
        );
        let fast = br#"[{"t": 4, "omega": [0, 0, 0]}, {"t": 5, "omega": [0, 0, 1e3]}]"#;
        let r = decode_batch_into(fast, &lim(), gyro, &mut out).unwrap_err();
        assert_eq!(r.code, RejectCode::OutOfRange);
        assert!(r.message.starts_with("batch item 1: "), "{}", r.message);
        let r = decode_batch_into(
            br#"[{"t": 5, "omega": [0, 0, 1e3]}]"#,
            &lim(),
            gyro,
            &mut out,
        )
        .unwrap_err();
        assert!(r.message.starts_with("|omega|"), "{}", r.message);
        // A later item of the wrong shape outranks an earlier one the conversion refuses.
        let both = br#"[{"t": 4, "omega": [0, 0, 1e3]}, {"t": 5, "omega": [0, 0]}]"#;
        let r = decode_batch_into(both, &lim(), gyro, &mut out).unwrap_err();
        assert_eq!(r.code, RejectCode::BadRequest, "{}", r.message);
        assert_eq!(out.len(), 3, "a refused payload appends nothing");
    }

    #[test]
    fn one_or_many() {
        let one: Vec<GyroMsg> =
            decode_batch(br#"{"t": 1.0, "omega": [0, 0, 0.1]}"#, &lim()).unwrap();
        assert_eq!(one.len(), 1);
        let two: Vec<GyroMsg> = decode_batch(
            br#"[{"t": 1.0, "omega": [0, 0, 0.1]}, {"t": 2.0, "omega": [0, 0, 0.2]}]"#,
            &lim(),
        )
        .unwrap();
        assert_eq!(two[1].omega[2], 0.2);
    }

    #[test]
    fn every_bad_input_has_its_code() {
        let cases: Vec<(&[u8], RejectCode)> = vec![
            (b"\xff\xfe", RejectCode::InvalidUtf8),
            (b"{not json", RejectCode::InvalidJson),
            (br#"{"t": 1.0}"#, RejectCode::BadRequest),
            (br#"{"t": "x", "omega": [0,0,0]}"#, RejectCode::BadRequest),
            (br#"{"t": 1.0, "omega": [0,0]}"#, RejectCode::BadRequest),
            (
                br#"{"t": 1.0, "omega": [0,0,0], "extra": 1}"#,
                RejectCode::BadRequest,
            ),
            (br#"{"t": null, "omega": [0,0,0]}"#, RejectCode::NonFinite),
            (br#"[]"#, RejectCode::BadRequest),
        ];
        for (payload, code) in cases {
            let r = decode_batch::<GyroMsg>(payload, &lim()).unwrap_err();
            assert_eq!(
                r.code,
                code,
                "{:?}: {}",
                String::from_utf8_lossy(payload),
                r.message
            );
        }
        let small = InputLimits {
            max_payload_bytes: 10,
            ..lim()
        };
        assert_eq!(
            decode_batch::<GyroMsg>(br#"{"t": 1.0, "omega": [0,0,0]}"#, &small)
                .unwrap_err()
                .code,
            RejectCode::PayloadTooLarge
        );
        let few = InputLimits {
            max_batch: 1,
            ..lim()
        };
        assert_eq!(
            decode_batch::<GyroMsg>(
                br#"[{"t": 1, "omega": [0,0,0]}, {"t": 2, "omega": [0,0,0]}]"#,
                &few
            )
            .unwrap_err()
            .code,
            RejectCode::BatchTooLarge
        );
    }

    #[test]
    fn observation_validation() {
        let ok = ObservationMsg {
            body: [1.0, 0.0, 0.0],
            reference: [0.0, 1.0, 0.0],
            sigma: 1e-3,
            sensor: None,
        };
        assert!(ok.to_domain(0).is_ok());
        let code = |o: ObservationMsg| o.to_domain(0).unwrap_err().code;
        assert_eq!(
            code(ObservationMsg {
                sigma: 0.0,
                ..ok.clone()
            }),
            RejectCode::BadSigma
        );
        assert_eq!(
            code(ObservationMsg {
                sigma: -1.0,
                ..ok.clone()
            }),
            RejectCode::BadSigma
        );
        assert_eq!(
            code(ObservationMsg {
                sigma: f64::NAN,
                ..ok.clone()
            }),
            RejectCode::NonFinite
        );
        assert_eq!(
            code(ObservationMsg {
                body: [0.0; 3],
                ..ok.clone()
            }),
            RejectCode::ZeroVector
        );
        assert_eq!(
            code(ObservationMsg {
                reference: [1e-12, 0.0, 0.0],
                ..ok.clone()
            }),
            RejectCode::ZeroVector
        );
        assert_eq!(
            code(ObservationMsg {
                body: [f64::INFINITY, 0.0, 0.0],
                ..ok.clone()
            }),
            RejectCode::NonFinite
        );
        assert_eq!(
            code(ObservationMsg {
                sensor: Some(String::new()),
                ..ok.clone()
            }),
            RejectCode::BadRequest
        );
        let set = VectorsMsg {
            t: 1.0,
            obs: vec![],
        };
        assert_eq!(
            set.to_domain(&lim()).unwrap_err().code,
            RejectCode::BadRequest
        );
        let many = VectorsMsg {
            t: 1.0,
            obs: vec![ok; 65],
        };
        assert_eq!(
            many.to_domain(&lim()).unwrap_err().code,
            RejectCode::BatchTooLarge
        );
    }

    #[test]
    fn vehicle_ids() {
        for ok in ["sc1", "A-b_9", &"x".repeat(64)] {
            assert!(validate_vehicle_id(ok).is_ok(), "{ok}");
        }
        for bad in ["", "a.b", "a b", "é", &"x".repeat(65), "@"] {
            assert_eq!(
                validate_vehicle_id(bad).unwrap_err().code,
                RejectCode::InvalidVehicleId,
                "{bad}"
            );
        }
    }

    #[test]
    fn quaternion_wire_convention() {
        let q = Quaternion::new(0.1, -0.2, 0.3, -0.9).normalized().unwrap();
        let m = QuaternionMsg::from_domain(&q);
        assert!(m.w > 0.0, "replies normalise w ≥ 0");
        assert_eq!(m.x, -q.x);
        let json = serde_json::to_string(&m).unwrap();
        assert!(json.starts_with(r#"{"w":"#), "{json}");
        assert!(QuaternionMsg {
            w: 2.0,
            x: 0.0,
            y: 0.0,
            z: 0.0
        }
        .to_domain()
        .is_err());
    }
}
