//! `format: "dds"`: the ROS 2 edge on DDS directly. zenoh-plugin-ros2dds (the plugin of
//! zenoh-bridge-ros2dds, linked in with the cargo feature `dds`) runs in the service's own zenoh
//! runtime (`service::session`, as the REST plugin does): it joins the DDS domain as a ROS 2 node
//! (CycloneDDS, which speaks RTPS with Fast DDS and every other DDS), maps each ROS topic `/a/b` onto
//! the zenoh key `a/b` (the edge's `bridge` key format), and creates the DDS readers and writers the
//! routes need: a reader for every topic a DDS node publishes and the service subscribes to, a writer
//! for every topic the service announces (`net.rs`: the bridge's announcement tokens) or a DDS node
//! subscribes to.
//!
//! This file builds and checks the plugin's configuration: `service.ros2.dds` as the plugin reads it
//! (its options: `ros_automatic_discovery_range`, `ros_static_peers`, `ros_localhost_only`,
//! `allow`/`deny`, `pub_max_frequencies`, `reliable_routes_blocking`, ...) with the domain and the node
//! name, which the service owns, filled in.

use serde_json::{Map, Value};

/// The plugin's name (its section in the zenoh configuration: `plugins/ros2dds`).
pub const PLUGIN: &str = "ros2dds";

/// The highest DDS domain id (RTPS' port arithmetic: 7400 + 250 · domain must stay below 65536).
pub const MAX_DOMAIN: u32 = 232;

/// Options the service sets from its own (`domain_id`, `node_name`), or keeps fixed (the plugin's
/// `namespace` would prefix every key and break the bridge key format the edge uses).
const OWNED: [(&str, &str); 3] = [
    ("domain", "service.ros2.domain_id (or ROS_DOMAIN_ID)"),
    ("nodename", "service.ros2.node_name"),
    (
        "namespace",
        "service.ros2.namespace (the topics' namespace)",
    ),
];

/// The plugin's configuration from `service.ros2.dds`.
pub fn plugin_config(
    mut dds: Map<String, Value>,
    domain: u32,
    node_name: &str,
    node_namespace: &str,
) -> Result<Value, String> {
    for (key, instead) in OWNED {
        if dds.contains_key(key) {
            return Err(format!(
                "service.ros2.dds.{key}: set by the service; use {instead}"
            ));
        }
    }
    if domain > MAX_DOMAIN {
        return Err(format!(
            "service.ros2.domain_id = {domain}: a DDS domain is 0..={MAX_DOMAIN}"
        ));
    }
    if node_namespace.trim_matches('/') != "" {
        return Err(format!(
            "service.ros2.node_namespace = {node_namespace:?}: on DDS the node is in \"/\" (the bridge \
             would put the namespace in front of every key)"
        ));
    }
    check_types(&dds)?;
    dds.insert("domain".into(), Value::from(domain));
    dds.insert("nodename".into(), Value::from(node_name));
    dds.insert("namespace".into(), Value::from("/"));
    let config = Value::Object(dds);
    check_with_plugin(&config)?;
    Ok(config)
}

/// The plugin's own deserialisers unwrap some values' types (a panic, not an error): those are
/// checked here first.
fn check_types(dds: &Map<String, Value>) -> Result<(), String> {
    let strings = |v: &Value| v.as_array().is_some_and(|a| a.iter().all(Value::is_string));
    for (key, value) in dds {
        let ok = match key.as_str() {
            "ros_automatic_discovery_range" => value
                .as_str()
                .is_some_and(|s| ["SUBNET", "LOCALHOST", "OFF", "SYSTEM_DEFAULT"].contains(&s)),
            "ros_static_peers" => value.is_string(),
            "ros_localhost_only" | "reliable_routes_blocking" => value.is_boolean(),
            "pub_max_frequencies" | "pub_priorities" => strings(value),
            "queries_timeout" => value.as_object().is_some_and(|q| {
                q.iter().all(|(k, v)| match k.as_str() {
                    "default" => v.is_number(),
                    "actions" => v.as_object().is_some_and(|a| a.values().all(strings)),
                    _ => strings(v),
                })
            }),
            "allow" | "deny" => value
                .as_object()
                .is_some_and(|a| a.values().all(|v| v.is_string() || strings(v))),
            "transient_local_cache_multiplier" | "work_thread_num" | "max_block_thread_num" => {
                value.as_u64().is_some_and(|n| n > 0)
            }
            _ => {
                return Err(format!(
                    "service.ros2.dds.{key}: not an option of the DDS plugin (docs/ros2.md, \"DDS \
                     options\")"
                ))
            }
        };
        if !ok {
            return Err(format!(
                "service.ros2.dds.{key} = {value}: not of its type (docs/ros2.md, \"DDS options\")"
            ));
        }
    }
    Ok(())
}

/// CycloneDDS' loopback interface, for discovery on this machine only.
const LOOPBACK: &str =
    "<CycloneDDS><Domain><General><Interfaces><NetworkInterface address=\"127.0.0.1\" \
                        multicast=\"false\"/></Interfaces></General></Domain></CycloneDDS>";

/// Whether the plugin's discovery stays on this machine: `ros_automatic_discovery_range` LOCALHOST, or
/// `ros_localhost_only`, in the configuration or (when it says nothing) the environment, as the plugin
/// reads them.
pub fn localhost_only(plugin: &Value, env: &dyn Fn(&str) -> Option<String>) -> bool {
    let range = match plugin.get("ros_automatic_discovery_range") {
        Some(v) => v.as_str().map(str::to_string),
        None => env("ROS_AUTOMATIC_DISCOVERY_RANGE"),
    };
    let only = match plugin.get("ros_localhost_only") {
        Some(v) => v.as_bool().unwrap_or(false),
        None => env("ROS_LOCALHOST_ONLY").as_deref() == Some("1"),
    };
    only || range.as_deref() == Some("LOCALHOST")
}

/// The `CYCLONEDDS_URI` the plugin's CycloneDDS is to read (the plugin puts its own discovery settings in
/// front of it), or `None` to leave it as it is. On LOCALHOST discovery the plugin turns multicast off and
/// sends to localhost, but CycloneDDS would still advertise the machine's first network interface, which
/// ROS 2 nodes in LOCALHOST mode (Fast DDS: only 127.0.0.1) never answer: the loopback interface is
/// chosen, before the user's own `CYCLONEDDS_URI` (whose settings then win).
pub fn cyclonedds_uri(plugin: &Value, env: &dyn Fn(&str) -> Option<String>) -> Option<String> {
    if !localhost_only(plugin, env) {
        return None;
    }
    Some(
        match env("CYCLONEDDS_URI").filter(|u| !u.trim().is_empty()) {
            Some(user) => format!("{LOOPBACK},{user}"),
            None => LOOPBACK.to_string(),
        },
    )
}

/// The zenoh-bridge-ros2dds announcement of a publisher on `key` (the bridge's key of the topic):
/// `@/<bridge>/@ros2_lv/MP/<key>/<type>/<qos>`, '/' written '§' inside a chunk (zenoh-plugin-ros2dds'
/// `liveliness_mgt.rs`). On it, a bridge (or the plugin in this service's runtime, which ignores its
/// own zenoh id: `bridge` is another) makes a DDS writer of the topic, so ROS 2 nodes see the topic
/// and its publisher (the bridge's node) before any sample, and receive the samples put on `key`.
/// The QoS chunk is `<keyless>:<reliability>:<durability>:<history>,<depth>:<user data>` in DDS'
/// numbers: reliable (1), volatile (0), keep-last (0) `depth`, the type hash in the user data as ROS
/// 2's DDS layers put it (`typehash=RIHS01_...;`).
pub fn publisher_announcement(
    bridge: &str,
    key: &str,
    ros_type: &str,
    hash: &str,
    depth: u32,
) -> String {
    format!(
        "@/{bridge}/@ros2_lv/MP/{}/{}/:1:0:0,{depth}:typehash={hash};",
        key.replace('/', "§"),
        ros_type.replace('/', "§")
    )
}

/// The history of a vehicle's orientation writer on DDS. A reliable keep-last writer (Cyclone DDS'
/// included) drops a sample its reader has not acknowledged once `depth` newer ones are written, so a
/// subscriber whose socket overflowed while its process was starved of CPU (a burst of estimates
/// after a batch of samples) cannot have again what is older than that (with the plugin's writer of
/// depth 1, runs of up to 19 lost: vendor/README.md). 64 is six times ROS' default of 10, while the
/// unacknowledged bytes (64 × ~330 B of sensor_msgs/Imu) stay under Cyclone's initial high-water mark
/// (30 kB), above which a write would block the service's put. History depth is not matched between
/// writer and reader: every subscriber still matches. The plugin's writer for a Fast DDS subscriber
/// that came first has the same depth (vendor/README.md).
pub const ORIENTATION_DEPTH: u32 = 64;

/// The history of the /diagnostics writer: ROS' default. One DiagnosticArray holds a status per
/// vehicle (large for a fleet) and the next one supersedes it.
pub const DIAGNOSTICS_DEPTH: u32 = 10;

/// The bridge id of the service's announcements: its zenoh id with a suffix (the plugin in the same
/// runtime ignores announcements under its own zenoh id, which is the service's).
pub fn bridge_id(zid: &str) -> String {
    format!("{zid}_attitude_service")
}

#[cfg(feature = "dds")]
fn check_with_plugin(config: &Value) -> Result<(), String> {
    let config = config.clone();
    // (check_types keeps the plugin's unwrapping deserialisers from panicking; this is the net.)
    let parsed = std::panic::catch_unwind(move || {
        serde_json::from_value::<zenoh_plugin_ros2dds::config::Config>(config)
    })
    .map_err(|_| "service.ros2.dds: a value of the wrong type".to_string())?;
    parsed
        .map(|_| ())
        .map_err(|e| format!("service.ros2.dds: {e}"))
}

#[cfg(not(feature = "dds"))]
fn check_with_plugin(_config: &Value) -> Result<(), String> {
    // Checked by the plugin when the service starts (a build without the feature refuses to start).
    Ok(())
}

/// Whether this build can run the DDS plugin (the cargo feature `dds`).
pub const AVAILABLE: bool = cfg!(feature = "dds");

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn map(v: Value) -> Map<String, Value> {
        v.as_object().unwrap().clone()
    }

    #[test]
    fn the_service_fills_in_domain_node_and_namespace() {
        let c = plugin_config(
            map(json!({"ros_automatic_discovery_range": "LOCALHOST"})),
            7,
            "attitude_service",
            "/",
        )
        .unwrap();
        assert_eq!(
            c,
            json!({"ros_automatic_discovery_range": "LOCALHOST", "domain": 7,
                   "nodename": "attitude_service", "namespace": "/"})
        );
    }

    #[test]
    fn owned_keys_wrong_types_domains_and_namespaces_are_refused() {
        for (dds, domain, ns, says) in [
            (json!({"domain": 3}), 0, "/", "service.ros2.domain_id"),
            (json!({"nodename": "x"}), 0, "/", "service.ros2.node_name"),
            (json!({"namespace": "/x"}), 0, "/", "service.ros2.namespace"),
            (json!({}), 233, "/", "0..=232"),
            (json!({}), 0, "/robots", "node_namespace"),
            (
                json!({"ros_automatic_discovery_range": "NEAR"}),
                0,
                "/",
                "ros_automatic_discovery_range",
            ),
            (
                json!({"ros_static_peers": ["a"]}),
                0,
                "/",
                "ros_static_peers",
            ),
            (
                json!({"pub_max_frequencies": 3}),
                0,
                "/",
                "pub_max_frequencies",
            ),
            (
                json!({"ros_localhost_only": "yes"}),
                0,
                "/",
                "ros_localhost_only",
            ),
        ] {
            let e = plugin_config(map(dds.clone()), domain, "n", ns).unwrap_err();
            assert!(e.contains(says), "{dds} {domain} {ns}: {e}");
        }
    }

    #[test]
    fn loopback_on_localhost_discovery_before_the_users_settings() {
        let none = |_: &str| None;
        let env = |k: &str| match k {
            "ROS_AUTOMATIC_DISCOVERY_RANGE" => Some("LOCALHOST".to_string()),
            "CYCLONEDDS_URI" => Some("<CycloneDDS/>".to_string()),
            _ => None,
        };
        assert_eq!(cyclonedds_uri(&json!({}), &none), None);
        assert_eq!(
            cyclonedds_uri(&json!({}), &env),
            Some(format!("{LOOPBACK},<CycloneDDS/>"))
        );
        // The file's range wins over the environment's.
        let subnet = json!({"ros_automatic_discovery_range": "SUBNET"});
        assert_eq!(cyclonedds_uri(&subnet, &env), None);
        let local = json!({"ros_localhost_only": true});
        assert_eq!(cyclonedds_uri(&local, &none), Some(LOOPBACK.to_string()));
    }

    #[test]
    fn announcements_are_the_bridges_tokens() {
        assert_eq!(
            publisher_announcement(
                "z1",
                "robots/r1/imu/data",
                "sensor_msgs/msg/Imu",
                "RIHS01_ab",
                ORIENTATION_DEPTH
            ),
            "@/z1/@ros2_lv/MP/robots§r1§imu§data/sensor_msgs§msg§Imu/:1:0:0,64:typehash=RIHS01_ab;"
        );
    }

    #[test]
    fn unknown_options_are_refused() {
        let e = plugin_config(map(json!({"domian": 3})), 0, "n", "/").unwrap_err();
        assert!(e.contains("domian"), "{e}");
    }
}
