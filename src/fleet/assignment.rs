//! Several service instances sharing one fleet of vehicles: who owns which vehicle.
//!
//! Two ways to split a fleet, combinable:
//! * **Static sharding** by a vehicle key expression (`fleet.vehicles`, e.g. `a$*`): the instance
//!   subscribes to and answers for `P/<pattern>/...` only; zenoh never delivers it anything else.
//! * **Dynamic membership** (`fleet.mode = "dynamic"`): every instance of a group declares the
//!   liveliness token `P/@/fleet/<group>/<instance>`; the live tokens are the members. A vehicle
//!   belongs to one of 16 routes ([`route_of`], a hash of its id that clients compute too), and every
//!   route has one owner and up to two standby members ([`Assignment`]), computed by every member from
//!   the same member list, so no coordination is needed. A member subscribes to the routed inputs of
//!   the routes it owns and to the standby batches of the routes it holds, and zenoh delivers it
//!   nothing else.
//!
//! The assignment: each route ranks the members by a rendezvous (highest-random-weight) weight; its
//! top three hold its standby data, and its owner is one of its top two, chosen to balance the routes
//! (every member owns ⌊16/n⌋ or ⌈16/n⌉ of them when the rankings allow it). So the owner after any
//! single join or leave is a member that held the route's data before (or the member that joined,
//! which fetched it before announcing itself): a takeover never starts from nothing while a holder
//! lives.
//!
//! This file is the pure part: the configuration and the assignment. `member.rs` keeps the members,
//! the standby data and the takeovers; `membership.rs` declares the token and watches the others.

use crate::rng::{fnv1a, splitmix64_mix, FNV_OFFSET};
use crate::wire::keys::{route_of, ROUTES};
use std::collections::{BTreeSet, VecDeque};

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
    /// The routes this instance (or its group) serves, a bit per route ([`ALL_ROUTES`]: every one):
    /// static sharding by route, even whatever the vehicle ids.
    pub routes: u16,
    /// How long (wall time, s) the samples of vehicles another member owns are kept, so that a
    /// takeover can replay what the failed owner had not yet published (dynamic mode).
    pub standby_s: f64,
    /// At most this many bytes of standby data (other members' inputs and estimates) are kept; the
    /// oldest go first.
    pub standby_bytes: usize,
    /// How often an owner sends its routes' standby members the last estimate of each vehicle that
    /// published one since, s.
    pub flush_s: f64,
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
            routes: ALL_ROUTES,
            standby_s: 12.0,
            standby_bytes: 256 << 20,
            flush_s: 0.5,
            discovery_timeout_s: 1.0,
        }
    }
}

/// Every route.
pub const ALL_ROUTES: u16 = u16::MAX;

/// Routes from their text: `all`, or hex digits and ranges separated by commas (`0-7`, `89ab`,
/// `0-3,c-f`).
pub fn parse_routes(spec: &str) -> Result<u16, String> {
    let spec = spec.trim();
    if spec == "all" {
        return Ok(ALL_ROUTES);
    }
    let digit = |c: char| {
        crate::wire::keys::parse_route(&c.to_string())
            .ok_or_else(|| format!("'{c}' is not a route (0-9, a-f)"))
    };
    let mut mask = 0u16;
    for part in spec.split(',') {
        let chars: Vec<char> = part.trim().chars().collect();
        match chars.as_slice() {
            [a, '-', b] => {
                let (a, b) = (digit(*a)?, digit(*b)?);
                if a > b {
                    return Err(format!("the range {part} is empty"));
                }
                (a..=b).for_each(|r| mask |= 1 << r);
            }
            [] => return Err("an empty part".into()),
            digits => {
                for c in digits {
                    mask |= 1 << digit(*c)?;
                }
            }
        }
    }
    Ok(mask)
}

/// The routes of `mask` as text (`all`, or ranges: `0-3,c-f`).
pub fn routes_text(mask: u16) -> String {
    if mask == ALL_ROUTES {
        return "all".into();
    }
    let mut parts = Vec::new();
    let mut r = 0;
    while r < ROUTES {
        if mask & (1 << r) == 0 {
            r += 1;
            continue;
        }
        let start = r;
        while r + 1 < ROUTES && mask & (1 << (r + 1)) != 0 {
            r += 1;
        }
        parts.push(if r > start {
            format!("{start:x}-{r:x}")
        } else {
            format!("{start:x}")
        });
        r += 1;
    }
    parts.join(",")
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

/// The rendezvous weight of `(instance, route)` (the route as `@<hex digit>`, never a vehicle id).
pub fn route_weight(instance: &str, route: u8) -> u64 {
    weight(instance, &format!("@{route:x}"))
}

/// Members holding a route's standby data: its top three by weight (fewer in a smaller fleet).
pub const HOLDERS: usize = 3;

/// Every route's owner and holders for one member list (dynamic mode).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Assignment {
    /// The members, sorted.
    members: Vec<String>,
    /// Per route: the owner's index in `members`.
    owner: [usize; ROUTES],
    /// Per route: the holders' indices by decreasing weight (the owner is one of the first two).
    holders: [Vec<usize>; ROUTES],
}

impl Assignment {
    /// The assignment of `members` over every route; `None` without members.
    pub fn new(members: &BTreeSet<String>) -> Option<Self> {
        Self::of_routes(members, ALL_ROUTES)
    }

    /// The assignment of `members` for the routes of `routes` (a bit per route: a static shard's),
    /// balanced over those; the others have an owner too, never used.
    pub fn of_routes(members: &BTreeSet<String>, routes: u16) -> Option<Self> {
        let members: Vec<String> = members.iter().cloned().collect();
        let n = members.len();
        if n == 0 {
            return None;
        }
        let holders: [Vec<usize>; ROUTES] = std::array::from_fn(|r| {
            let mut ranked: Vec<(u64, usize)> = (0..n)
                .map(|i| (route_weight(&members[i], r as u8), i))
                .collect();
            // Highest weight first; ties by name (the index order).
            ranked.sort_by(|a, b| b.0.cmp(&a.0).then(b.1.cmp(&a.1)));
            ranked.iter().take(HOLDERS).map(|&(_, i)| i).collect()
        });
        let mut owner: [usize; ROUTES] = std::array::from_fn(|r| holders[r][0]);
        balance(&mut owner, &holders, n, routes);
        Some(Assignment {
            members,
            owner,
            holders,
        })
    }

    pub fn members(&self) -> &[String] {
        &self.members
    }

    /// The owner of `route`.
    pub fn owner(&self, route: u8) -> &str {
        &self.members[self.owner[route as usize % ROUTES]]
    }

    /// The holders of `route` (its owner among them), by decreasing weight.
    pub fn holders(&self, route: u8) -> impl Iterator<Item = &str> {
        self.holders[route as usize % ROUTES]
            .iter()
            .map(|&i| self.members[i].as_str())
    }

    /// Whether `member` owns `route`.
    pub fn owns(&self, member: &str, route: u8) -> bool {
        self.owner(route) == member
    }

    /// Whether `member` holds `route`'s standby data (the owner does too).
    pub fn holds(&self, member: &str, route: u8) -> bool {
        self.holders(route).any(|m| m == member)
    }

    /// Whether `route` has a holder other than its owner (someone to keep its standby data for).
    pub fn has_standby(&self, route: u8) -> bool {
        self.holders[route as usize % ROUTES].len() > 1
    }

    /// The routes `member` owns.
    pub fn owned_by(&self, member: &str) -> Vec<u8> {
        (0..ROUTES as u8)
            .filter(|&r| self.owns(member, r))
            .collect()
    }

    /// The routes `member` holds (owner or standby).
    pub fn held_by(&self, member: &str) -> Vec<u8> {
        (0..ROUTES as u8)
            .filter(|&r| self.holds(member, r))
            .collect()
    }
}

/// Moves routes between their two candidates (the first two holders) until every member owns at most
/// ⌈16/n⌉ routes, then at least ⌊16/n⌋, as far as the candidates allow: each step shifts one route
/// along a chain of owners (found breadth-first, in a fixed order), so the result is a function of the
/// rankings alone.
fn balance(owner: &mut [usize; ROUTES], holders: &[Vec<usize>; ROUTES], n: usize, routes: u16) {
    let served = |r: usize| routes & (1 << r) != 0;
    let count = (0..ROUTES).filter(|&r| served(r)).count();
    let (lo, hi) = (count / n, count.div_ceil(n));
    let load = |owner: &[usize; ROUTES]| {
        let mut l = vec![0usize; n];
        for (r, &o) in owner.iter().enumerate() {
            if served(r) {
                l[o] += 1;
            }
        }
        l
    };
    // The other candidate of route r, if r has two.
    let other = |r: usize, of: usize| -> Option<usize> {
        let c = &holders[r];
        match c.len() {
            0 | 1 => None,
            _ if c[0] == of => Some(c[1]),
            _ if c[1] == of => Some(c[0]),
            _ => None,
        }
    };
    for (source, target) in [
        (
            Box::new(move |l: usize| l > hi) as Box<dyn Fn(usize) -> bool>,
            Box::new(move |l: usize| l < hi) as Box<dyn Fn(usize) -> bool>,
        ),
        (
            Box::new(move |l: usize| l > lo),
            Box::new(move |l: usize| l < lo),
        ),
    ] {
        for _ in 0..4 * ROUTES {
            let l = load(owner);
            if !l.iter().any(|&x| target(x)) || !l.iter().any(|&x| source(x)) {
                break;
            }
            // Breadth-first from every source; an edge m -> o moves a route of m to o.
            let mut came: Vec<Option<(usize, usize)>> = vec![None; n];
            let mut seen = vec![false; n];
            let mut queue: VecDeque<usize> = (0..n).filter(|&m| source(l[m])).collect();
            queue.iter().for_each(|&m| seen[m] = true);
            let mut found = None;
            'search: while let Some(m) = queue.pop_front() {
                for (r, &owned_by) in owner.iter().enumerate() {
                    if owned_by != m || !served(r) {
                        continue;
                    }
                    let Some(o) = other(r, m) else { continue };
                    if seen[o] {
                        continue;
                    }
                    seen[o] = true;
                    came[o] = Some((m, r));
                    if target(l[o]) {
                        found = Some(o);
                        break 'search;
                    }
                    queue.push_back(o);
                }
            }
            let Some(mut at) = found else { break };
            while let Some((from, r)) = came[at] {
                owner[r] = at;
                at = from;
            }
        }
    }
}

/// The member owning `vehicle`: the owner of its route; `None` without members.
pub fn owner<'a>(vehicle: &str, members: &'a BTreeSet<String>) -> Option<&'a str> {
    let a = Assignment::new(members)?;
    let name = a.owner(route_of(vehicle));
    members.get(name).map(|m| m.as_str())
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

    fn names(rng: &mut u64, n: usize) -> BTreeSet<String> {
        let mut out = BTreeSet::new();
        while out.len() < n {
            *rng = splitmix64_mix(rng.wrapping_add(1));
            out.insert(format!("n{}", *rng % 1_000_000));
        }
        out
    }

    #[test]
    fn routes_balanced_and_moves_safe() {
        // The members of scripts/fleet-cpu.py and the router test: routes as even as they can be.
        for (list, want) in [
            (vec!["m1", "m2"], vec![8, 8]),
            (vec!["m1", "m2", "m3"], vec![6, 5, 5]),
            (vec!["m1", "m2", "m3", "m4"], vec![4, 4, 4, 4]),
            (vec!["i1", "i2", "i3"], vec![6, 5, 5]),
            (vec!["i1", "i2", "i3", "i4"], vec![4, 4, 4, 4]),
        ] {
            let a = Assignment::new(&members(&list)).unwrap();
            let mut got: Vec<usize> = list.iter().map(|m| a.owned_by(m).len()).collect();
            got.sort_unstable_by(|x, y| y.cmp(x));
            assert_eq!(got, want, "{list:?}");
            for r in 0..ROUTES as u8 {
                assert_eq!(a.holders(r).count(), list.len().min(HOLDERS));
                assert!(a.holders(r).take(2).any(|m| m == a.owner(r)));
            }
        }
        // Random fleets of 2..=10: the owner after any leave or join held the route before (or
        // joined); every member owns at most ⌈16/n⌉ routes in more than 90 % of the fleets (the others:
        // the top-two rankings concentrate on a few members, which 16 routes cannot avoid in large
        // fleets; never more than twice that).
        let mut rng = 7u64;
        let (mut over, mut cases, mut moved, mut moves) = (0, 0, 0usize, 0usize);
        for n in 2..=10usize {
            for _ in 0..100 {
                let before = names(&mut rng, n);
                let a = Assignment::new(&before).unwrap();
                cases += 1;
                let most = before.iter().map(|m| a.owned_by(m).len()).max().unwrap();
                assert!(
                    most <= 2 * ROUTES.div_ceil(n),
                    "{before:?}: a member owns {most} routes"
                );
                if most > ROUTES.div_ceil(n) {
                    over += 1;
                }
                let gone = before
                    .iter()
                    .nth((rng % n as u64) as usize)
                    .unwrap()
                    .clone();
                let mut after = before.clone();
                after.remove(&gone);
                let b = Assignment::new(&after).unwrap();
                let mut joined = before.clone();
                joined.insert("joiner".into());
                let c = Assignment::new(&joined).unwrap();
                for r in 0..ROUTES as u8 {
                    assert!(
                        a.holds(b.owner(r), r),
                        "leave: route {r} to a member without its data"
                    );
                    assert!(
                        c.owner(r) == "joiner" || a.holds(c.owner(r), r),
                        "join: route {r} to a member without its data"
                    );
                    moves += 1;
                    if b.owner(r) != a.owner(r) {
                        moved += 1;
                    }
                }
            }
        }
        assert!(over * 10 < cases, "{over} of {cases} fleets unbalanced");
        // Rendezvous alone would move the leaver's share (1/n); balancing moves some more.
        let frac = moved as f64 / moves as f64;
        eprintln!(
            "{over} of {cases} fleets above ⌈16/n⌉; a leave moves {:.0} % of the routes",
            frac * 100.0
        );
        assert!(frac < 0.4, "{frac}");
        assert_eq!(owner("x", &BTreeSet::new()), None);
        assert!(Assignment::new(&BTreeSet::new()).is_none());
        let one = Assignment::new(&members(&["solo"])).unwrap();
        assert_eq!(one.owned_by("solo").len(), ROUTES);
        assert!(!one.has_standby(0));
    }

    #[test]
    fn route_sets_parse_and_print() {
        assert_eq!(parse_routes("all"), Ok(ALL_ROUTES));
        assert_eq!(parse_routes("0-f"), Ok(ALL_ROUTES));
        assert_eq!(parse_routes("0-3,c-f"), Ok(0xf00f));
        assert_eq!(parse_routes("89ab"), Ok(0x0f00));
        assert_eq!(parse_routes(" 1 "), Ok(0x0002));
        for bad in ["", "g", "3-1", "0-", "a,,b", "A"] {
            assert!(parse_routes(bad).is_err(), "{bad}");
        }
        for mask in [ALL_ROUTES, 0xf00f, 0x0f00, 0x0002, 0x5555] {
            assert_eq!(parse_routes(&routes_text(mask)), Ok(mask));
        }
        assert_eq!(routes_text(0xf00f), "0-3,c-f");
        // A static shard of eight routes shared by three members: 3, 3, 2 of them.
        let a = Assignment::of_routes(&members(&["m1", "m2", "m3"]), 0x00ff).unwrap();
        let mut got: Vec<usize> = ["m1", "m2", "m3"]
            .iter()
            .map(|m| a.owned_by(m).iter().filter(|&&r| r < 8).count())
            .collect();
        got.sort_unstable();
        assert_eq!(got, vec![2, 3, 3]);
    }

    #[test]
    fn the_owner_of_a_vehicle_is_its_routes() {
        let all = members(&["i1", "i2", "i3"]);
        let a = Assignment::new(&all).unwrap();
        for v in ["sc1", "load7", "fv03"] {
            assert_eq!(owner(v, &all), Some(a.owner(route_of(v))));
        }
        // Pinned: a change here splits a fleet of mixed versions.
        assert_eq!(route_weight("i1", 3), weight("i1", "@3"));
        let owners: String = (0..ROUTES as u8)
            .map(|r| a.owner(r).chars().last().unwrap())
            .collect();
        assert_eq!(owners, "1112231333323122");
    }
}
