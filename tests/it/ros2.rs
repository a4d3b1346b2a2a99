//! The ROS 2 edge in process (`ros2`, proto/ros2.md): an Imu message feeds exactly the path of
//! `P/V/imu` (the same estimates, bit for bit), the magnetometer is paired with its sample, the Imu out
//! carries the sample's stamp, the bias-corrected rate and the specific force; the preset
//! `config/ros2.json5` is `config/imu.json5` with the edge on. (The codec and the hashes are checked
//! against rosbags, and the network side against an independent rmw_zenoh-style peer, in
//! tests/python/test_ros2.py and the bad-input rows.)

use crate::common::{collecting_engine, repo, service_config, wait_until};
use attitude_service::engine::Inbound;
use attitude_service::ros2::Ros2Config;
use attitude_service::ros2::{Header, RosImu, RosMagneticField, RosType, Stamp};
use attitude_service::service::config::{load, parse};
use attitude_service::wire::EstimateMsg;
use std::time::Duration;

const IMU_HASH: &str = "RIHS01_7d9a00ff131080897a5ec7e26e315954b8eae3353c3f995c55faf71574000b5b";
const MAG_HASH: &str = "RIHS01_e80f32f56a20486c9923008fc1a1db07bbb273cbbf6a5b3bfa00835ee00e4dff";

fn sample(i: usize) -> (f64, [f64; 3], [f64; 3], [f64; 3]) {
    let t = 100.0 + i as f64 * 0.01;
    let s = (i as f64 * 0.05).sin();
    (
        t,
        [0.2 * s, -0.1, 0.05 * s],
        [0.3 * s, 0.2, 9.7],
        [20.0e-6, 5.0e-6 * s, -40.0e-6],
    )
}

#[test]
fn an_imu_message_takes_the_path_of_p_v_imu() {
    let config = service_config(
        r#"{"service": {"key_prefix": "test", "workers": 1, "filter": {"kind": "mekf"}, "ros2": {"enabled": true}}}"#,
    );
    let (node, threads, out) = collecting_engine(config);
    let engine = node.engine.clone();
    let n = 300;
    for i in 0..n {
        let (t, gyr, acc, mag_t) = sample(i);
        let stamp = Stamp::from_seconds(t);
        let t = stamp.seconds();
        let mag = RosMagneticField {
            header: Header {
                stamp,
                frame_id: "imu_link".into(),
            },
            magnetic_field: mag_t,
            magnetic_field_covariance: [0.0; 9],
        };
        let imu = RosImu {
            header: Header {
                stamp,
                frame_id: "imu_link".into(),
            },
            orientation_covariance: [-1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            angular_velocity: gyr,
            angular_velocity_covariance: [1e-6, 0.0, 0.0, 0.0, 1e-6, 0.0, 0.0, 0.0, 1e-6],
            linear_acceleration: acc,
            ..RosImu::default()
        };
        engine.dispatch(Inbound {
            key: format!("0/ros1/imu/mag/sensor_msgs::msg::dds_::MagneticField_/{MAG_HASH}"),
            payload: mag.to_cdr(),
        });
        // (Humble's keys carry no hash: accepted the same.)
        let hash = if i % 2 == 0 {
            IMU_HASH
        } else {
            "TypeHashNotSupported"
        };
        engine.dispatch(Inbound {
            key: format!("0/ros1/imu/data_raw/sensor_msgs::msg::dds_::Imu_/{hash}"),
            payload: imu.to_cdr(),
        });
        // The same sample as JSON, the magnetometer in µT as the edge converts it.
        let ut = mag_t.map(|x| x * 1e6);
        engine.dispatch(Inbound {
            key: "test/json1/imu".into(),
            payload: format!(
                r#"{{"t": {t:?}, "gyr": [{:?}, {:?}, {:?}], "acc": [{:?}, {:?}, {:?}], "mag": [{:?}, {:?}, {:?}]}}"#,
                gyr[0], gyr[1], gyr[2], acc[0], acc[1], acc[2], ut[0], ut[1], ut[2]
            )
            .into_bytes(),
        });
    }
    let estimates = |v: &str| -> Vec<EstimateMsg> {
        out.lock()
            .unwrap()
            .iter()
            .filter(|(k, _)| *k == format!("test/{v}/estimate"))
            .map(|(_, p)| serde_json::from_slice(p).unwrap())
            .collect()
    };
    wait_until("every estimate", Duration::from_secs(30), || {
        estimates("ros1").len() >= n - 11 && estimates("json1").len() >= n - 11
    })
    .unwrap();
    threads.shutdown();
    let rejected: Vec<_> = out
        .lock()
        .unwrap()
        .iter()
        .filter(|(k, _)| k.ends_with("/rejected"))
        .map(|(k, p)| (k.clone(), String::from_utf8_lossy(p).to_string()))
        .collect();
    assert!(rejected.is_empty(), "{rejected:?}");
    let (ros, json) = (estimates("ros1"), estimates("json1"));
    assert_eq!(ros.len(), json.len());
    for (a, b) in ros.iter().zip(&json) {
        let mut b = b.clone();
        b.vehicle = a.vehicle.clone();
        assert_eq!(
            *a, b,
            "the estimates of the two paths differ at t = {}",
            a.t
        );
    }
    // The magnetometer was used (heading updates), as on P/V/imu.
    let imu = ros.last().unwrap().diagnostics.imu.clone().unwrap();
    assert!(imu.heading_updates > 0, "{imu:?}");

    // The Imu out of the last estimate: the sample's own stamp and frame, the rate less the bias, the
    // specific force as it came, the attitude's covariance (body frame) and the rate's plus the bias's.
    let e = ros.last().unwrap();
    let m = node.ros2.as_ref().unwrap().imu_of("ros1", e);
    let (t, gyr, acc, _) = sample(n - 1);
    assert_eq!(m.header.stamp, Stamp::from_seconds(t));
    assert_eq!(m.header.frame_id, "imu_link");
    assert_eq!(m.linear_acceleration, acc);
    for (i, g) in gyr.iter().enumerate() {
        assert_eq!(m.angular_velocity[i], g - e.bias[i]);
        assert_eq!(
            m.angular_velocity_covariance[4 * i],
            1e-6 + e.cov[3 + i][3 + i]
        );
        for j in 0..3 {
            assert_eq!(m.orientation_covariance[3 * i + j], e.cov[i][j]);
        }
    }
    assert_eq!(
        m.orientation,
        [e.q.x, e.q.y, e.q.z, e.q.w],
        "ROS's orientation is our q"
    );
    let back = RosImu::from_cdr(&m.to_cdr()).unwrap();
    assert_eq!(back, m);
}

#[test]
fn the_preset_is_the_imu_preset_with_the_edge_on() {
    // (Through the file, so that `extends` is followed as `serve --config` follows it.)
    let read = |name: &str| load(&repo().join("config").join(name)).unwrap();
    let (imu, ros2) = (read("imu.json5"), read("ros2.json5"));
    assert_eq!(ros2.zenoh_json, imu.zenoh_json);
    assert!(ros2.service.ros2.enabled);
    let mut rest = ros2.service.clone();
    rest.ros2 = Ros2Config::default();
    assert_eq!(
        rest, imu.service,
        "config/ros2.json5 drifted from config/imu.json5"
    );
    // The default configuration documents the edge, off.
    let default = read("default.json5");
    assert_eq!(default.service.ros2, Ros2Config::default());
    assert!(!default.service.ros2.enabled);
    assert_eq!(RosType::Imu.hash(), IMU_HASH);
    assert_eq!(RosType::MagneticField.hash(), MAG_HASH);
}

#[test]
fn the_configuration_is_checked() {
    for (bad, says) in [
        (r#"{"format": "fastdds"}"#, "format"),
        (r#"{"imu_topic": "/imu//raw"}"#, "imu_topic"),
        (r#"{"output_topic": "imu/data_raw"}"#, "output_topic"),
        (
            r#"{"orientation_covariance_frame": "world"}"#,
            "orientation_covariance_frame",
        ),
        (r#"{"mag_max_age_s": 0}"#, "mag_max_age_s"),
        (r#"{"vehicles": ["a.b"]}"#, "vehicles"),
        (r#"{"diagnostics_period_s": -1}"#, "diagnostics_period_s"),
        (r#"{"node_name": "a/b"}"#, "node_name"),
        (r#"{"unknown": 1}"#, "unknown"),
        // The bridge's keys under the service's prefix: `attitude/V/imu` would be read as JSON input.
        (
            r#"{"enabled": true, "format": "bridge", "namespace": "attitude", "imu_topic": "imu"}"#,
            "overlap the service's inputs attitude/*/imu",
        ),
        (
            r#"{"enabled": true, "format": "bridge", "namespace": "attitude", "imu_topic": "imu/raw", "mag_topic": ""}"#,
            "overlap the service's inputs attitude/*/*/*",
        ),
    ] {
        let text = format!(r#"{{"service": {{"ros2": {bad}}}}}"#);
        let e = parse(&text, "test").unwrap_err().to_string();
        assert!(e.contains(says), "{bad}: {e}");
    }
    // The same namespace is fine off, and the default bridge keys (no namespace) stay apart.
    for good in [
        r#"{"enabled": false, "format": "bridge", "namespace": "attitude", "imu_topic": "imu"}"#,
        r#"{"enabled": true, "format": "bridge"}"#,
        r#"{"enabled": true, "format": "bridge", "namespace": "robots"}"#,
        r#"{"enabled": true}"#,
    ] {
        let text = format!(r#"{{"service": {{"ros2": {good}}}}}"#);
        assert!(parse(&text, "test").is_ok(), "{good}");
    }
}
