//! Filter names: which estimator ([`FilterKind`]), which fiducial ([`Fiducial`]), and the one parser
//! of the two as the wire and the configuration give them ([`FilterSpec::from_parts`]).

use std::fmt;
use std::str::FromStr;
use thiserror::Error;

/// Which estimator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FilterKind {
    /// Multiplicative extended Kalman filter (the baseline).
    Mekf,
    /// UnScented QUaternion Estimator.
    Usque,
    /// Quaternion particle filter with MRP local errors.
    Qpf,
    /// Sparse-grid Gauss–Hermite quadrature filter (its level in [`super::FilterConfig::level`]).
    Sghqf,
}

/// How the fiducial quaternion that links the global quaternion and the local error space is chosen
/// (Chang 2014; docs/algorithms.md §3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Fiducial {
    /// The previous estimate propagated like an EKF (Chang 2014, Eq. 1; original USQUE and QPF).
    Propagated,
    /// The MMSE weighted quaternion average of the sigma points or particles (Chang 2014, Eqs. 3–6).
    Average,
}

/// A filter and, for the sampling filters, its fiducial: `mekf`, `usque:propagated`, `qpf:average`,
/// `sghqf:average`, …
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FilterSpec {
    pub kind: FilterKind,
    /// `None` for the MEKF, which has no fiducial.
    pub fiducial: Option<Fiducial>,
}

impl FilterKind {
    pub fn as_str(&self) -> &'static str {
        match self {
            FilterKind::Mekf => "mekf",
            FilterKind::Usque => "usque",
            FilterKind::Qpf => "qpf",
            FilterKind::Sghqf => "sghqf",
        }
    }
}

impl Fiducial {
    pub fn as_str(&self) -> &'static str {
        match self {
            Fiducial::Propagated => "propagated",
            Fiducial::Average => "average",
        }
    }
}

impl fmt::Display for FilterSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.fiducial {
            None => write!(f, "{}", self.kind.as_str()),
            Some(fid) => write!(f, "{}:{}", self.kind.as_str(), fid.as_str()),
        }
    }
}

#[derive(Clone, Debug, Error, PartialEq)]
#[error(
    "unknown filter '{0}': expected mekf, usque[:propagated|:average], qpf[:propagated|:average] or sghqf[:propagated|:average]"
)]
pub struct ParseFilterSpecError(pub String);

impl FromStr for FilterKind {
    type Err = ParseFilterSpecError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "mekf" => Ok(FilterKind::Mekf),
            "usque" => Ok(FilterKind::Usque),
            "qpf" => Ok(FilterKind::Qpf),
            "sghqf" => Ok(FilterKind::Sghqf),
            _ => Err(ParseFilterSpecError(s.to_string())),
        }
    }
}

impl FromStr for Fiducial {
    type Err = ParseFilterSpecError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "average" => Ok(Fiducial::Average),
            "propagated" => Ok(Fiducial::Propagated),
            _ => Err(ParseFilterSpecError(s.to_string())),
        }
    }
}

impl FilterSpec {
    /// The one parser of filter names (a `kind` and an optional `fiducial`, as the wire and the
    /// configuration give them): `usque`, `qpf` and `sghqf` without a fiducial mean the averaged fiducial,
    /// this project's default; the MEKF takes none.
    pub fn from_parts(kind: &str, fiducial: Option<&str>) -> Result<Self, ParseFilterSpecError> {
        let whole = || {
            ParseFilterSpecError(match fiducial {
                Some(f) => format!("{kind}:{f}"),
                None => kind.to_string(),
            })
        };
        let kind: FilterKind = kind.parse().map_err(|_| whole())?;
        let fiducial = match (kind, fiducial) {
            (FilterKind::Mekf, None) => None,
            (FilterKind::Mekf, Some(_)) => return Err(whole()),
            (_, None) => Some(Fiducial::Average),
            (_, Some(f)) => Some(f.parse().map_err(|_| whole())?),
        };
        Ok(FilterSpec { kind, fiducial })
    }
}

impl FromStr for FilterSpec {
    type Err = ParseFilterSpecError;

    /// `kind[:fiducial]`, see [`FilterSpec::from_parts`].
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.split_once(':') {
            Some((k, f)) => FilterSpec::from_parts(k, Some(f)),
            None => FilterSpec::from_parts(s, None),
        }
    }
}
