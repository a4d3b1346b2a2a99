//! Every key expression of the contract, built in one place from the configured prefix `P`.

/// The leaf of a per-vehicle key `P/V/<leaf>`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Leaf {
    Gyro,
    Vectors,
    Imu,
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
            Leaf::Imu => "imu",
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
            "imu" => Leaf::Imu,
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
    /// The vehicle chunk this service subscribes to and answers for (`*`, or a static shard).
    vehicles: String,
}

impl Keys {
    /// `prefix` must already be validated (`config::validate_key_prefix`).
    pub fn new(prefix: &str) -> Self {
        Keys {
            prefix: prefix.trim_end_matches('/').to_string(),
            vehicles: "*".into(),
        }
    }

    /// Serving only the vehicles whose id chunk matches `pattern` (validated, `fleet.vehicles`).
    pub fn with_vehicles(mut self, pattern: &str) -> Self {
        self.vehicles = pattern.to_string();
        self
    }

    /// The vehicle chunk served (`*` unless statically sharded).
    pub fn vehicle_pattern(&self) -> &str {
        &self.vehicles
    }

    pub fn prefix(&self) -> &str {
        &self.prefix
    }

    /// `P/V/<leaf>`.
    pub fn vehicle(&self, vehicle: &str, leaf: Leaf) -> String {
        format!("{}/{}/{}", self.prefix, vehicle, leaf.as_str())
    }

    /// `P/*/<leaf>` (or `P/<shard>/<leaf>`): the subscription or queryable over every vehicle served.
    pub fn all(&self, leaf: Leaf) -> String {
        format!("{}/{}/{}", self.prefix, self.vehicles, leaf.as_str())
    }

    /// `P/@/fleet/<group>/<instance>`: the liveliness token of a fleet member.
    pub fn fleet_member(&self, group: &str, instance: &str) -> String {
        format!("{}/@/fleet/{group}/{instance}", self.prefix)
    }

    /// `P/@/fleet/<group>/*`: every member's token.
    pub fn fleet_members(&self, group: &str) -> String {
        format!("{}/@/fleet/{group}/*", self.prefix)
    }

    /// The instance's name from a member token's key.
    pub fn member_of<'a>(&self, group: &str, key: &'a str) -> Option<&'a str> {
        let rest = key
            .strip_prefix(self.prefix.as_str())?
            .strip_prefix("/@/fleet/")?
            .strip_prefix(group)?
            .strip_prefix('/')?;
        (!rest.is_empty() && !rest.contains('/')).then_some(rest)
    }

    /// `P/@/instance/<instance>/health`: one instance's health (in a fleet every instance answers
    /// `P/@/health` on the same key, so a client sees one reply per instance only here).
    pub fn instance_health(&self, instance: &str) -> String {
        format!("{}/@/instance/{instance}/health", self.prefix)
    }

    /// `P/@/instance/<instance>/vehicles`: the vehicles one instance owns.
    pub fn instance_vehicles(&self, instance: &str) -> String {
        format!("{}/@/instance/{instance}/vehicles", self.prefix)
    }

    /// `P/@/instance/<instance>/metrics`: one instance's metrics (what Prometheus scrapes in a fleet,
    /// where every instance answers `P/@/metrics` on the same key).
    pub fn instance_metrics(&self, instance: &str) -> String {
        format!("{}/@/instance/{instance}/metrics", self.prefix)
    }

    /// `P/@/metrics`: OpenMetrics text.
    pub fn metrics(&self) -> String {
        format!("{}/@/metrics", self.prefix)
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
        let shard = k.clone().with_vehicles("a$*");
        assert_eq!(shard.all(Leaf::Gyro), "mission-a/attitude/a$*/gyro");
        assert_eq!(k.fleet_member("g", "i1"), "mission-a/attitude/@/fleet/g/i1");
        assert_eq!(
            k.member_of("g", "mission-a/attitude/@/fleet/g/i1"),
            Some("i1")
        );
        assert_eq!(k.member_of("g", "mission-a/attitude/@/fleet/h/i1"), None);
        assert_eq!(
            k.instance_health("i1"),
            "mission-a/attitude/@/instance/i1/health"
        );
        assert_eq!(k.metrics(), "mission-a/attitude/@/metrics");
        assert_eq!(
            k.instance_metrics("i1"),
            "mission-a/attitude/@/instance/i1/metrics"
        );
    }
}
