//! attitude-service: networked multi-vehicle attitude estimation.
//!
//! Layout (see `ARCHITECTURE.md`):
//! * [`attitude`], [`sensors`], [`filters`], [`bounds`], [`sim`]: the numeric core. No I/O, no async,
//!   no JSON; typed errors instead of panics.
//! * [`study`]: Monte-Carlo accuracy studies of the filters against the Cramér–Rao bound, and their
//!   reports (the only part here that writes files).

// `!(x > 0.0)` is used on purpose throughout: unlike `x <= 0.0` it also refuses NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod attitude;
pub mod bounds;
pub mod filters;
pub mod sensors;
pub mod sim;
pub mod study;
