//! The tuning's start (`attitude-lab imu-study --tune`): the descent starts from the values the
//! preset gives, stated or not. Read from the file's text alone, an option the preset leaves to its
//! default (`service.imu.mag.deviation_gain`, 1.0) started at the grid's first candidate (0.5): the
//! record's "start" was then not the preset, and its objective not the preset's.

use crate::common::repo;
use attitude_lab::tools::imu_study::{effective_config, load_config, start_point, TuneSpec};

#[test]
fn the_descent_starts_at_the_values_the_preset_takes() {
    let spec: TuneSpec =
        json5::from_str(&std::fs::read_to_string(repo().join("config/imu-tuning.json5")).unwrap())
            .unwrap();
    let preset = repo().join("config/imu.json5");
    let start = start_point(&spec, &effective_config(&preset).unwrap());
    let parsed = load_config(&preset, &[]).unwrap();
    let at = |path: &str| {
        let i = spec.parameters.iter().position(|p| p.path == path).unwrap();
        spec.parameters[i].values[start[i]]
    };
    // Stated by the preset, left to the default, and a datum of ros2-dds.json5's base: each as parsed.
    assert_eq!(
        at("service.imu.acc.lowpass_s"),
        parsed.policy.imu.acc.lowpass_s
    );
    assert_eq!(
        at("service.imu.mag.deviation_gain"),
        parsed.policy.imu.mag.deviation_gain
    );
    assert_eq!(parsed.policy.imu.mag.deviation_gain, 1.0);
    // A preset that extends this one starts at the same point.
    let dds = repo().join("config/ros2-dds.json5");
    assert_eq!(start_point(&spec, &effective_config(&dds).unwrap()), start);
}
