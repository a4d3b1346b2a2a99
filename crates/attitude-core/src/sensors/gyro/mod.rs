//! The gyro: its noise model, which the simulator samples ([`noise`]), and what a raw IMU sample's
//! rate may hide, which the raw-IMU pipeline adds to the filter's propagation ([`channel`]).

pub mod channel;
pub mod noise;

pub use channel::{Gap, GyroChannel, GyroConfig};
pub use noise::{normal3, GyroNoise, GyroSimulator};
