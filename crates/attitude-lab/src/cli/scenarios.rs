//! `scenarios`: every standard scenario and the parameters it uses.

use anyhow::Result;
use attitude_core::sim::{ScenarioName, ScenarioParams};

/// `scenarios`: every standard scenario and its parameters.
pub fn list_scenarios() -> Result<()> {
    for name in ScenarioName::ALL {
        println!("{}\n", ScenarioParams::default_for(name).describe());
    }
    Ok(())
}
