//! The checks of the sensor models' settings, one wording for every model on both paths (the vector
//! sensors of `service.sensors.NAME`, the raw-IMU pipeline's `service.imu`): each message names the
//! setting by its path in the configuration.

/// `v > 0` and finite.
pub fn positive(v: f64, name: &str) -> Result<(), String> {
    if v > 0.0 && v.is_finite() {
        Ok(())
    } else {
        Err(format!("{name} must be positive and finite, got {v}"))
    }
}

/// `v ≥ 0` and finite.
pub fn non_negative(v: f64, name: &str) -> Result<(), String> {
    if v >= 0.0 && v.is_finite() {
        Ok(())
    } else {
        Err(format!("{name} must be non-negative and finite, got {v}"))
    }
}

/// A limit: `v ≥ 0`, infinity allowed (no limit).
pub fn limit(v: f64, name: &str) -> Result<(), String> {
    if v >= 0.0 {
        Ok(())
    } else {
        Err(format!(
            "{name} must be non-negative (infinite: no limit), got {v}"
        ))
    }
}

/// A factor of at least 1, finite.
pub fn at_least_one(v: f64, name: &str) -> Result<(), String> {
    if v >= 1.0 && v.is_finite() {
        Ok(())
    } else {
        Err(format!("{name} must be at least 1, got {v}"))
    }
}

/// A fraction: `0 ≤ v ≤ 1`.
pub fn fraction(v: f64, name: &str) -> Result<(), String> {
    if (0.0..=1.0).contains(&v) {
        Ok(())
    } else {
        Err(format!("{name} must be in [0, 1], got {v}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_check_refuses_nan_and_names_the_setting() {
        for check in [positive, non_negative, limit, at_least_one, fraction] {
            let e = check(f64::NAN, "mag.norm_limit").unwrap_err();
            assert!(e.starts_with("mag.norm_limit must be"), "{e}");
        }
        assert!(limit(f64::INFINITY, "x").is_ok());
        assert!(non_negative(f64::INFINITY, "x").is_err());
        assert!(positive(0.0, "x").is_err() && non_negative(0.0, "x").is_ok());
        assert!(at_least_one(0.99, "x").is_err() && fraction(1.01, "x").is_err());
    }
}
