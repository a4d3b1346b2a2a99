//! `quadrature`: a sparse-grid Gauss–Hermite rule of the core (`filters::sghqf::rule`) printed as
//! JSON, so that an independent implementation can be compared with it point by point
//! (`tests/python/test_sghq_rule.py` runs chaospy against it).

use anyhow::Result;
use attitude_core::filters::sghqf::rule::{smolyak, Growth};
use clap::{Args, ValueEnum};

#[derive(Clone, Copy, ValueEnum)]
enum GrowthArg {
    /// m = l univariate points at level l.
    Linear,
    /// m = 2l − 1 (the filter's).
    Odd,
    /// m = 2^l − 1.
    Doubling,
}

#[derive(Args)]
pub struct QuadratureArgs {
    /// Dimension (the filter's state has 6).
    #[arg(long, default_value_t = 6, value_parser = clap::value_parser!(u8).range(1..=12))]
    dim: u8,
    /// Accuracy level L (exact to degree 2L − 1).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u8).range(1..=6))]
    level: u8,
    /// How many univariate points each level uses.
    #[arg(long, value_enum, default_value = "odd")]
    growth: GrowthArg,
}

/// Prints `{"dim", "level", "growth", "degree", "points": [[…], …], "weights": […]}` (numbers that
/// read back to the same `f64`).
pub fn quadrature(args: QuadratureArgs) -> Result<()> {
    let (growth, name) = match args.growth {
        GrowthArg::Linear => (Growth::Linear, "linear"),
        GrowthArg::Odd => (Growth::Odd, "odd"),
        GrowthArg::Doubling => (Growth::Doubling, "doubling"),
    };
    let r = smolyak(args.dim as usize, args.level as usize, growth)?;
    let points: Vec<&[f64]> = (0..r.len()).map(|i| r.point(i)).collect();
    let out = serde_json::json!({
        "dim": r.dim,
        "level": r.level,
        "growth": name,
        "degree": r.degree(),
        "points": points,
        "weights": r.weights,
    });
    println!("{out}");
    Ok(())
}
