//! Every key expression of the contract, built in one place from the configured prefix `P`.
//!
//! Routed inputs (a dynamic fleet's, `proto/README.md` "Routed inputs"): `P/V/<leaf>/<r>` carries the
//! vehicle's route `r` (one hex digit, [`route_of`]), so a fleet member can subscribe to the routes it
//! owns and receive nothing else; `P/@/standby/<r>/inputs` carries the same inputs batched by their
//! sender for the route's standby members, and `P/@/standby/<r>/estimates/<G>` the owner's estimates
//! batched for them.

use crate::rng::{fnv1a, splitmix64_mix, FNV_OFFSET};

/// Routes of the vehicles: a routed key's last chunk is one of `0`..`f`.
pub const ROUTES: usize = 16;

/// The route of `vehicle`: SplitMix64's finaliser of the 64-bit FNV-1a of its id's bytes, mod 16.
/// Part of the contract (clients compute it: `proto/README.md` has test vectors), never to change.
pub fn route_of(vehicle: &str) -> u8 {
    (splitmix64_mix(fnv1a(vehicle.bytes(), FNV_OFFSET)) % ROUTES as u64) as u8
}

/// A route as its key chunk (one lowercase hex digit).
fn route_chunk(route: u8) -> char {
    char::from_digit(u32::from(route) % ROUTES as u32, 16).unwrap_or('0')
}

/// A route chunk read back: exactly one of `0`..`9`, `a`..`f`.
pub fn parse_route(chunk: &str) -> Option<u8> {
    let mut c = chunk.chars();
    match (c.next(), c.next()) {
        (Some(d @ ('0'..='9' | 'a'..='f')), None) => d.to_digit(16).map(|d| d as u8),
        _ => None,
    }
}

/// What a key the service receives is (see [`Keys::classify`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Received<'a> {
    /// `P/V/<leaf>`, or the routed `P/V/<leaf>/<r>` with its route chunk as received.
    Vehicle {
        vehicle: &'a str,
        leaf: Leaf,
        route: Option<&'a str>,
    },
    /// `P/@/standby/<r>/inputs`: a batch of route `r`'s inputs from their sender.
    StandbyInputs(u8),
    /// `P/@/standby/<r>/estimates/<G>`: a batch of route `r`'s estimates from its owner in group `G`.
    StandbyEstimates(u8, &'a str),
}

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

    /// `P/V/<leaf>/<r>`: a routed input (`r` = [`route_of`]`(V)`).
    pub fn routed(&self, vehicle: &str, leaf: Leaf) -> String {
        format!(
            "{}/{}/{}/{}",
            self.prefix,
            vehicle,
            leaf.as_str(),
            route_chunk(route_of(vehicle))
        )
    }

    /// `P/*/*/<r>` (or `P/<shard>/*/<r>`): the routed inputs of route `r`; `None`: of every route.
    pub fn routed_inputs(&self, route: Option<u8>) -> String {
        match route {
            Some(r) => format!("{}/{}/*/{}", self.prefix, self.vehicles, route_chunk(r)),
            None => format!("{}/{}/*/*", self.prefix, self.vehicles),
        }
    }

    /// `P/*/<leaf>/*` (or `P/<shard>/<leaf>/*`): every routed input of one leaf.
    pub fn routed_all(&self, leaf: Leaf) -> String {
        format!("{}/{}/{}/*", self.prefix, self.vehicles, leaf.as_str())
    }

    /// `P/@/standby/<r>/**`: what a standby member of route `r` receives (the senders' batches of its
    /// inputs and the owner's batches of its estimates); `None`: of every route.
    pub fn standby(&self, route: Option<u8>) -> String {
        match route {
            Some(r) => format!("{}/@/standby/{}/**", self.prefix, route_chunk(r)),
            None => format!("{}/@/standby/*/**", self.prefix),
        }
    }

    /// `P/@/standby/<r>/inputs`: where a sender puts its batches of route `r`'s inputs.
    pub fn standby_inputs(&self, route: u8) -> String {
        format!("{}/@/standby/{}/inputs", self.prefix, route_chunk(route))
    }

    /// `P/@/standby/<r>/estimates/<group>`: where the owner of route `r` in `group` puts its batches
    /// of estimates.
    pub fn standby_estimates(&self, route: u8, group: &str) -> String {
        format!(
            "{}/@/standby/{}/estimates/{group}",
            self.prefix,
            route_chunk(route)
        )
    }

    /// Whether `key` is a standby batch (a binary payload, not JSON).
    pub fn is_standby(&self, key: &str) -> bool {
        key.strip_prefix(self.prefix.as_str())
            .is_some_and(|rest| rest.starts_with("/@/standby/"))
    }

    /// `P/*/state?routes=<digits>`: the estimates of the vehicles of these routes (a joining fleet
    /// member's get).
    pub fn states_of_routes(&self, routes: &[u8]) -> String {
        let digits: String = routes.iter().map(|&r| route_chunk(r)).collect();
        format!("{}?routes={digits}", self.all(Leaf::State))
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

    /// What a received key is: a vehicle's key (plain or routed) or a standby batch; `None` for
    /// anything else.
    pub fn classify<'a>(&self, key: &'a str) -> Option<Received<'a>> {
        let rest = key.strip_prefix(self.prefix.as_str())?.strip_prefix('/')?;
        if let Some(standby) = rest.strip_prefix("@/standby/") {
            let (route, what) = standby.split_once('/')?;
            let route = parse_route(route)?;
            return match what.split_once('/') {
                None if what == "inputs" => Some(Received::StandbyInputs(route)),
                Some(("estimates", group)) if !group.is_empty() && !group.contains('/') => {
                    Some(Received::StandbyEstimates(route, group))
                }
                _ => None,
            };
        }
        let (vehicle, rest) = rest.split_once('/')?;
        if vehicle.is_empty() {
            return None;
        }
        let (leaf, route) = match rest.split_once('/') {
            None => (rest, None),
            Some((leaf, route)) if !route.contains('/') => (leaf, Some(route)),
            Some(_) => return None,
        };
        Some(Received::Vehicle {
            vehicle,
            leaf: Leaf::parse(leaf)?,
            route,
        })
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

    #[test]
    fn routes_are_pinned() {
        // The contract's test vectors (proto/README.md, Routed inputs): clients compute the same.
        let vectors = [
            ("sc1", 0x7),
            ("load1", 0x9),
            ("fv00", 0x7),
            ("a", 0x8),
            ("", 0xb),
        ];
        let got: Vec<(&str, u8)> = vectors.iter().map(|(v, _)| (*v, route_of(v))).collect();
        assert_eq!(got, vectors.to_vec());
        // Spread: 16 000 ids, every route within 10 % of 1000.
        let mut count = [0usize; ROUTES];
        for i in 0..16_000 {
            count[route_of(&format!("load{i}")) as usize] += 1;
        }
        assert!(count.iter().all(|n| (900..=1100).contains(n)), "{count:?}");
    }

    #[test]
    fn routed_keys_build_and_classify() {
        let k = Keys::new("p");
        let r = route_of("sc1");
        let key = k.routed("sc1", Leaf::Gyro);
        assert_eq!(key, format!("p/sc1/gyro/{r:x}"));
        assert_eq!(
            k.classify(&key),
            Some(Received::Vehicle {
                vehicle: "sc1",
                leaf: Leaf::Gyro,
                route: Some(&key[key.len() - 1..]),
            })
        );
        assert_eq!(
            k.classify("p/sc1/vectors"),
            Some(Received::Vehicle {
                vehicle: "sc1",
                leaf: Leaf::Vectors,
                route: None
            })
        );
        assert_eq!(k.classify("p/sc1/vectors/3/x"), None);
        assert_eq!(k.classify("p/sc1/other/3"), None);
        assert_eq!(k.standby_inputs(10), "p/@/standby/a/inputs");
        assert_eq!(
            k.classify("p/@/standby/a/inputs"),
            Some(Received::StandbyInputs(10))
        );
        assert_eq!(k.standby_estimates(15, "g"), "p/@/standby/f/estimates/g");
        assert_eq!(
            k.classify("p/@/standby/f/estimates/g"),
            Some(Received::StandbyEstimates(15, "g"))
        );
        assert_eq!(k.classify("p/@/standby/g/inputs"), None);
        assert_eq!(k.classify("p/@/standby/F/inputs"), None);
        assert_eq!(k.classify("p/@/standby/1/estimates"), None);
        assert!(k.is_standby("p/@/standby/1/inputs") && !k.is_standby("p/sc1/gyro"));
        assert_eq!(k.routed_inputs(Some(3)), "p/*/*/3");
        assert_eq!(k.routed_inputs(None), "p/*/*/*");
        assert_eq!(
            k.clone().with_vehicles("a$*").routed_inputs(Some(3)),
            "p/a$*/*/3"
        );
        assert_eq!(k.standby(Some(12)), "p/@/standby/c/**");
        assert_eq!(k.standby(None), "p/@/standby/*/**");
        assert_eq!(
            (parse_route("0"), parse_route("f"), parse_route("10")),
            (Some(0), Some(15), None)
        );
    }
}
