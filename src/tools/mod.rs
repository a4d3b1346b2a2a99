//! Tools around the service, run by the commands of [`crate::cli`]: the scenario publisher
//! (`simulate`), the all-in-one `demo`, `loadgen` and `soak` (zenoh clients of the service, not part of
//! it), `bench`, and `imu_study` and `imu_bench` (recorded IMU trials through the vehicle pipeline);
//! `publish`, how those that send inputs put them (advanced publishers: lost puts recovered; to a
//! fleet they go through `fleet::sender`).
//! Library code: typed errors, no command-line parsing; a long run stops on a `CancellationToken`.

pub mod bench;
pub mod demo;
pub mod imu_bench;
pub mod imu_study;
pub mod loadgen;
pub mod publish;
pub mod simulate;
pub mod soak;
