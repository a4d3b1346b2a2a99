//! Command-line tools around the service: the scenario publisher (`simulate`) and the all-in-one
//! `demo`. They are zenoh clients of the service, not part of it.

pub mod demo;
pub mod simulate;
