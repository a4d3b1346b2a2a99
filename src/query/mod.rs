//! What the service answers: `reads.rs` (pure reads of the engine's snapshots and counters and of the
//! fleet member: `P/V/state`, attitude, covariance, `P/@/health`, `P/@/vehicles`), `metrics.rs`
//! (`P/@/metrics`, OpenMetrics text from the same counters), `queryables.rs` (their zenoh side: the
//! queryables declared from one table, their replies and error replies, and the reset queryable).
//! Queries read the last published estimate, never a filter.

pub mod metrics;
pub mod queryables;
pub mod reads;

pub use metrics::{metrics_text, METRICS_ENCODING};
pub use reads::{attitude_of, covariance_of, health, state_of, vehicles};
