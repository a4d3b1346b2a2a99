//! The synthetic inputs the load tools send (the lab's `loadgen` and `soak`) and the tests that
//! measure the service's work per message (`tests/it/load.rs`): one definition, so that a test
//! measures the messages the load tools send.

use crate::wire::{ImuMsg, ObservationMsg, VectorsMsg};
use attitude_core::attitude::Quaternion;
use nalgebra::Vector3;

/// Vehicle `i`'s vector set at `t`: three exact star directions at a fixed attitude.
pub fn star_set(t: f64, i: usize) -> VectorsMsg {
    // A fixed attitude per vehicle (a rotation about z by i·0.01 rad): A = R3(a).
    let a = i as f64 * 0.01;
    let (c, s) = (a.cos(), a.sin());
    let refs = [[1.0, 0.0, 0.0], [0.0, 0.6, 0.8], [0.0, -0.8, 0.6]];
    VectorsMsg {
        t,
        obs: refs
            .iter()
            .map(|r| ObservationMsg {
                body: [c * r[0] + s * r[1], -s * r[0] + c * r[1], r[2]],
                reference: *r,
                sigma: 1e-4,
                sensor: None,
            })
            .collect(),
    }
}

/// A raw IMU sample of vehicle `i` at `t`: turning slowly about a tilted axis, gravity and a field seen
/// from that attitude (the pipeline has real work: tilt, heading, no rest).
pub fn imu_sample(t: f64, i: usize) -> ImuMsg {
    let w = Vector3::new(0.1, -0.05, 0.2 + 0.01 * (i % 7) as f64);
    let q = Quaternion::from_rotation_vector(&(w * t));
    let a = q.attitude_matrix();
    let g = a * Vector3::new(0.0, 0.0, 9.81);
    let m = a * Vector3::new(0.0, 15.6, -41.7);
    ImuMsg {
        t,
        gyr: [w[0], w[1], w[2]],
        acc: [g[0], g[1], g[2]],
        mag: Some([m[0], m[1], m[2]]),
    }
}
