//! The ROS 2 edge on DDS, as configured: `config/ros2-dds.json5` is `config/imu.json5` with the edge on
//! DDS by `extends` (no value copied), `extends` resolves relative to the extending file, and the
//! plugin's configuration is the `dds` section with the domain and node filled in. (The edge with real
//! ROS 2 nodes on DDS: tests/python/test_ros2_dds.py.)

use crate::common::repo;
use attitude_service::ros2::Ros2Format;
use attitude_service::service::config::{load, parse};

#[test]
fn the_dds_preset_is_the_imu_preset_with_the_edge_on_dds() {
    let imu = load(&repo().join("config/imu.json5")).unwrap();
    let dds = load(&repo().join("config/ros2-dds.json5")).unwrap();
    assert_eq!(dds.zenoh_json, imu.zenoh_json);
    let r = &dds.service.ros2;
    assert!(r.enabled && r.format == Ros2Format::Bridge, "{r:?}");
    let plugin = r.dds.as_ref().expect("the plugin's configuration");
    assert_eq!(plugin["nodename"], "attitude_service");
    assert_eq!(plugin["namespace"], "/");
    assert_eq!(plugin["domain"], r.domain_id);
    // Everything else is the IMU preset's.
    let mut service = dds.service.clone();
    service.ros2 = imu.service.ros2.clone();
    assert_eq!(service, imu.service);
    // ...by composition: the file states the edge and nothing of the IMU preset.
    let text = std::fs::read_to_string(repo().join("config/ros2-dds.json5")).unwrap();
    let v: serde_json::Value = json5::from_str(&text).unwrap();
    let top: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    assert_eq!(top, ["extends", "service"]);
    let service: Vec<&str> = v["service"]
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    assert_eq!(service, ["ros2"]);
}

#[test]
fn extends_is_relative_to_the_extending_file_and_errors_name_it() {
    let dir = std::env::temp_dir().join(format!("attitude-extends-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("site")).unwrap();
    std::fs::write(
        dir.join("base.json5"),
        r#"{service: {key_prefix: "base", workers: 2, filter: {kind: "qpf", particles: 300}}}"#,
    )
    .unwrap();
    std::fs::write(
        dir.join("site/robot.json5"),
        r#"{extends: "../base.json5", service: {key_prefix: "robot", filter: {particles: 200}}}"#,
    )
    .unwrap();
    std::fs::write(
        dir.join("site/broken.json5"),
        r#"{extends: "nowhere.json5"}"#,
    )
    .unwrap();
    let c = load(&dir.join("site/robot.json5")).unwrap().service;
    assert_eq!(c.key_prefix, "robot");
    assert_eq!(c.workers, 2);
    let base = load(&dir.join("base.json5")).unwrap().service;
    assert_eq!(c.default_filter.init, base.default_filter.init);
    assert_ne!(
        c.default_filter, base.default_filter,
        "the particles differ"
    );
    let mut same = c.default_filter.clone();
    same.filter = base.default_filter.filter.clone();
    assert_eq!(same, base.default_filter);
    let e = load(&dir.join("site/broken.json5"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("broken.json5") && e.contains("nowhere.json5"),
        "{e}"
    );
    // A text with no file behind it resolves from the working directory.
    let e = parse(r#"{extends: "no/such/file.json5"}"#, "text")
        .unwrap_err()
        .to_string();
    assert!(e.contains("no/such/file.json5"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_dds_section_is_checked_at_load() {
    for (ros2, says) in [
        (
            r#"{enabled: true, format: "dds", dds: {domain: 3}}"#,
            "domain_id",
        ),
        (
            r#"{enabled: true, format: "dds", dds: {ros_static_peers: ["a"]}}"#,
            "ros_static_peers",
        ),
        (
            r#"{enabled: true, format: "dds", domain_id: 300}"#,
            "0..=232",
        ),
        (
            r#"{enabled: true, format: "rmw_zenoh", dds: {ros_localhost_only: true}}"#,
            "is for format",
        ),
        (
            r#"{enabled: true, format: "dds", dds: {allowed: {}}}"#,
            "not an option",
        ),
    ] {
        let text = format!("{{service: {{ros2: {ros2}}}}}");
        let e = parse(&text, "test").unwrap_err().to_string();
        assert!(e.contains(says), "{ros2}: {e}");
    }
}
