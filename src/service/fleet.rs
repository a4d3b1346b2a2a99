//! Several service instances sharing one fleet of vehicles: who owns which vehicle.
//!
//! Two ways to split a fleet, combinable:
//! * **Static sharding** by a vehicle key expression (`fleet.vehicles`, e.g. `a$*`): the instance
//!   subscribes to and answers for `P/<pattern>/...` only; zenoh never delivers it anything else.
//! * **Dynamic membership** (`fleet.mode = "dynamic"`): every instance of a group declares the
//!   liveliness token `P/@/fleet/<group>/<instance>`; the live tokens are the members, and each vehicle
//!   is owned by exactly one member, chosen by rendezvous (highest-random-weight) hashing of the
//!   vehicle id over the members. Every member computes the same owner from the same member list, so
//!   no coordination is needed; when a member leaves only its vehicles move, spread over the others,
//!   and when one joins it takes about `1/n` of the vehicles, each from its previous owner.
//!
//! This module is the pure part: the configuration and the owner function. The engine keeps the
//! members, the standby buffers and the takeovers; `service::run` declares the token and watches the
//! others.

use crate::rng::{fnv1a, splitmix64_mix, FNV_OFFSET};
use std::collections::BTreeSet;

/// How this instance takes part in a fleet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FleetMode {
    /// Owns every vehicle its key expression matches (the default: one process, or static shards).
    Single,
    /// Owns its rendezvous share of the vehicles among the live members of its group.
    Dynamic,
}

impl FleetMode {
    pub fn as_str(&self) -> &'static str {
        match self {
            FleetMode::Single => "single",
            FleetMode::Dynamic => "dynamic",
        }
    }
}

/// `service.fleet`, validated.
#[derive(Clone, Debug, PartialEq)]
pub struct FleetConfig {
    pub mode: FleetMode,
    /// Instances of one group share its vehicles (dynamic mode).
    pub group: String,
    /// This instance's name: unique within the group (a key chunk).
    pub instance: String,
    /// The vehicle chunk this instance serves, a key expression (`*` = all; `a$*` = ids starting `a`).
    pub vehicles: String,
    /// How long (wall time, s) the samples of vehicles another member owns are kept, so that a
    /// takeover can replay what the failed owner had not yet published (dynamic mode).
    pub standby_s: f64,
    /// How long a starting member waits for the other members and their estimates, s.
    pub discovery_timeout_s: f64,
}

impl FleetConfig {
    /// A single instance serving every vehicle.
    pub fn single(instance: &str) -> Self {
        FleetConfig {
            mode: FleetMode::Single,
            group: "default".into(),
            instance: instance.into(),
            vehicles: "*".into(),
            standby_s: 12.0,
            discovery_timeout_s: 1.0,
        }
    }
}

/// A default instance name: the host name and the process id (unique on a host, readable in logs).
pub fn default_instance_name() -> String {
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_default();
    let host: String = host
        .trim()
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '-'
            }
        })
        .take(40)
        .collect();
    let host = if host.is_empty() {
        "instance".into()
    } else {
        host
    };
    format!("{host}-{}", std::process::id())
}

/// The rendezvous weight of `(instance, vehicle)`: FNV-1a of both, then SplitMix64's finaliser (FNV
/// alone mixes the last bytes poorly). Stable across processes, versions and machines: every member
/// must compute the same owner.
pub fn weight(instance: &str, vehicle: &str) -> u64 {
    let bytes = instance.bytes().chain([0xff]).chain(vehicle.bytes());
    splitmix64_mix(fnv1a(bytes, FNV_OFFSET))
}

/// The member owning `vehicle`: the highest weight (ties broken by name); `None` without members.
pub fn owner<'a>(vehicle: &str, members: &'a BTreeSet<String>) -> Option<&'a str> {
    members
        .iter()
        .max_by_key(|m| (weight(m, vehicle), m.as_str()))
        .map(|m| m.as_str())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn members(names: &[&str]) -> BTreeSet<String> {
        names.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn weights_are_pinned() {
        // Changing the hash would split a fleet of mixed versions: pinned.
        assert_eq!(weight("a", "sc1"), weight("a", "sc1"));
        assert_ne!(weight("a", "sc1"), weight("b", "sc1"));
        assert_ne!(weight("ab", "c"), weight("a", "bc"));
        assert_eq!(weight("i1", "sc1"), 0x76c0_7c5e_3764_3fa5);
    }

    #[test]
    fn one_owner_balanced_and_minimal_moves() {
        let all = members(&["i1", "i2", "i3"]);
        let vehicles: Vec<String> = (0..3000).map(|i| format!("sc{i}")).collect();
        let mut count = std::collections::BTreeMap::new();
        for v in &vehicles {
            *count.entry(owner(v, &all).unwrap()).or_insert(0) += 1;
        }
        for (_, n) in &count {
            assert!((900..=1100).contains(n), "unbalanced: {count:?}");
        }
        // i2 leaves: only its vehicles move.
        let two = members(&["i1", "i3"]);
        for v in &vehicles {
            let before = owner(v, &all).unwrap();
            let after = owner(v, &two).unwrap();
            if before != "i2" {
                assert_eq!(before, after, "{v} moved although its owner stayed");
            }
        }
        // i4 joins: a vehicle either stays or moves to i4.
        let four = members(&["i1", "i2", "i3", "i4"]);
        let moved = vehicles
            .iter()
            .filter(|v| {
                let after = owner(v, &four).unwrap();
                assert!(after == owner(v, &all).unwrap() || after == "i4");
                after == "i4"
            })
            .count();
        assert!(
            (600..=900).contains(&moved),
            "{moved} of 3000 moved to the 4th"
        );
        assert_eq!(owner("x", &BTreeSet::new()), None);
    }
}
