//! Every key expression of the contract, built in one place from the configured prefix `P`.

/// The leaf of a per-vehicle key `P/V/<leaf>`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Leaf {
    Gyro,
    Vectors,
    Estimate,
    Rejected,
    Truth,
    Attitude,
    Covariance,
    State,
    Reset,
}

impl Leaf {
    pub fn as_str(&self) -> &'static str {
        match self {
            Leaf::Gyro => "gyro",
            Leaf::Vectors => "vectors",
            Leaf::Estimate => "estimate",
            Leaf::Rejected => "rejected",
            Leaf::Truth => "truth",
            Leaf::Attitude => "attitude",
            Leaf::Covariance => "covariance",
            Leaf::State => "state",
            Leaf::Reset => "reset",
        }
    }

    fn parse(s: &str) -> Option<Leaf> {
        Some(match s {
            "gyro" => Leaf::Gyro,
            "vectors" => Leaf::Vectors,
            "estimate" => Leaf::Estimate,
            "rejected" => Leaf::Rejected,
            "truth" => Leaf::Truth,
            "attitude" => Leaf::Attitude,
            "covariance" => Leaf::Covariance,
            "state" => Leaf::State,
            "reset" => Leaf::Reset,
            _ => return None,
        })
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Keys {
    prefix: String,
}

impl Keys {
    /// `prefix` must already be validated (`config::validate_key_prefix`).
    pub fn new(prefix: &str) -> Self {
        Keys {
            prefix: prefix.trim_end_matches('/').to_string(),
        }
    }

    pub fn prefix(&self) -> &str {
        &self.prefix
    }

    /// `P/V/<leaf>`.
    pub fn vehicle(&self, vehicle: &str, leaf: Leaf) -> String {
        format!("{}/{}/{}", self.prefix, vehicle, leaf.as_str())
    }

    /// `P/*/<leaf>`: the subscription or queryable over every vehicle.
    pub fn all(&self, leaf: Leaf) -> String {
        format!("{}/*/{}", self.prefix, leaf.as_str())
    }

    /// `P/@/vehicles`.
    pub fn vehicles(&self) -> String {
        format!("{}/@/vehicles", self.prefix)
    }

    /// `P/@/rejected`: where rejections of inputs whose vehicle chunk is a wildcard go (on their own
    /// key they would reach every vehicle's rejection subscribers).
    pub fn rejected_wildcard(&self) -> String {
        format!("{}/@/rejected", self.prefix)
    }

    /// `P/@/health`.
    pub fn health(&self) -> String {
        format!("{}/@/health", self.prefix)
    }

    /// Splits a concrete key `P/V/<leaf>` into the vehicle chunk and the leaf; `None` for other keys.
    pub fn split<'a>(&self, key: &'a str) -> Option<(&'a str, Leaf)> {
        let rest = key.strip_prefix(self.prefix.as_str())?.strip_prefix('/')?;
        let (vehicle, leaf) = rest.split_once('/')?;
        if vehicle.is_empty() || leaf.contains('/') {
            return None;
        }
        Some((vehicle, Leaf::parse(leaf)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn build_and_split() {
        let k = Keys::new("mission-a/attitude");
        assert_eq!(k.vehicle("sc1", Leaf::Gyro), "mission-a/attitude/sc1/gyro");
        assert_eq!(k.all(Leaf::Attitude), "mission-a/attitude/*/attitude");
        assert_eq!(k.health(), "mission-a/attitude/@/health");
        assert_eq!(
            k.split("mission-a/attitude/sc1/vectors"),
            Some(("sc1", Leaf::Vectors))
        );
        assert_eq!(k.split("mission-a/attitude/sc1/other"), None);
        assert_eq!(k.split("mission-b/attitude/sc1/gyro"), None);
        assert_eq!(k.split("mission-a/attitude/sc1/gyro/x"), None);
    }
}
