//! Tools around the service, run by the commands of [`crate::cli`]: the scenario publisher
//! (`simulate`) and the all-in-one `demo`; `publish`, how those that send inputs put them (advanced
//! publishers: lost puts recovered; to a fleet through `fleet::sender`; the lab's `loadgen` and `soak`
//! put through the same two); `synthetic`, the messages the load tools send.
//! Library code: typed errors, no command-line parsing; a long run stops on a `CancellationToken`.

pub mod demo;
pub mod publish;
pub mod simulate;
pub mod synthetic;
