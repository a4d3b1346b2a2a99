//! The simulator: truth trajectories, environment models (orbit, geomagnetic field, sun) and the
//! standard scenarios (docs/montecarlo.md, "Scenarios"), producing the measurement streams the filters
//! consume.
//!
//! Numeric core: no I/O, no printing, no panics on any input. Every run is a pure function of its
//! parameters and a seed (bit-identical for the same `(params, seed)`).

pub mod orbit;
pub mod scenario;

pub use orbit::{
    default_sun_direction_eci, lvlh_attitude, sun_direction_eci, CircularOrbit, DipoleField,
    EARTH_MU_M3_S2, EARTH_RADIUS_M, EARTH_RATE_RAD_S,
};
pub use scenario::{
    simulate, try_simulate, BiasSpec, InitialError, InitialEstimate, ScenarioError, ScenarioName,
    ScenarioParams, ScenarioSensors, SimulatedRun, TruthMotion, TruthSample, UnknownScenario,
};

/// One degree, rad.
pub const DEG: f64 = std::f64::consts::PI / 180.0;
/// One arcsecond, rad: `π/(180·3600)`.
pub const ARCSEC: f64 = DEG / 3600.0;
/// One degree per hour, rad/s: `π/180/3600`.
pub const DEG_PER_HR: f64 = DEG / 3600.0;
