//! attitude-service: networked multi-vehicle attitude estimation.
//!
//! Layout (see `ARCHITECTURE.md`):
//! * [`attitude`], [`sensors`], [`filters`], [`bounds`], [`sim`]: the numeric core. No I/O, no async,
//!   no JSON; typed errors instead of panics.
//! * [`study`]: Monte-Carlo accuracy studies of the filters against the Cramér–Rao bound, and their
//!   reports (the only part here that writes files).

pub mod attitude;
pub mod bounds;
pub mod filters;
pub mod sensors;
pub mod sim;
pub mod study;
