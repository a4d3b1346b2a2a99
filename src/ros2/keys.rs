//! The ROS 2 edge's key expressions: rmw_zenoh's format or zenoh-bridge-ros2dds' (`service.ros2.format`),
//! the topics of a vehicle's namespace and rmw_zenoh's liveliness tokens (`proto/ros2.md`).

/// How the ROS 2 edge names its topics on zenoh (`service.ros2.format`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ros2Format {
    /// rmw_zenoh's: `<domain>/<topic>/<DDS type>/<type hash>`, with liveliness tokens and attachments.
    RmwZenoh,
    /// zenoh-bridge-ros2dds' (zenoh-plugin-ros2dds): `<topic>`, nothing else.
    Bridge,
}

/// An entity of rmw_zenoh's graph (the liveliness token's `<entity>` chunk).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ros2Entity {
    Node,
    Publisher,
    Subscription,
}

impl Ros2Entity {
    fn as_str(&self) -> &'static str {
        match self {
            Ros2Entity::Node => "NN",
            Ros2Entity::Publisher => "MP",
            Ros2Entity::Subscription => "MS",
        }
    }
}

/// rmw_zenoh's mangling of a name inside one key chunk: every '/' becomes '%'.
pub fn ros2_mangle(name: &str) -> String {
    name.replace('/', "%")
}

/// The ROS 2 edge's key expressions (`proto/ros2.md`). A topic of vehicle `V` is the ROS name
/// `/<namespace>/V/<topic>` (no namespace chunk when it is empty); rmw_zenoh's key strips the leading
/// '/', puts the domain id in front and the DDS type name and the type hash behind.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Ros2Keys {
    pub format: Ros2Format,
    pub domain: u32,
    /// Chunks before the vehicle's (no leading or trailing '/'); may be empty.
    namespace: String,
}

impl Ros2Keys {
    pub fn new(format: Ros2Format, domain: u32, namespace: &str) -> Self {
        Ros2Keys {
            format,
            domain,
            namespace: namespace.trim_matches('/').to_string(),
        }
    }

    /// `/<namespace>/V/<topic>`: the ROS topic name of a vehicle's topic.
    pub fn topic_name(&self, vehicle: &str, topic: &str) -> String {
        format!("/{}", self.base(Some(vehicle), topic))
    }

    /// The namespace of a vehicle's topics, `/<namespace>/V`.
    pub fn vehicle_namespace(&self, vehicle: &str) -> String {
        match self.namespace.as_str() {
            "" => format!("/{vehicle}"),
            ns => format!("/{ns}/{vehicle}"),
        }
    }

    /// `<namespace>/V/<topic>` (`V` = `*` when `None`).
    fn base(&self, vehicle: Option<&str>, topic: &str) -> String {
        let v = vehicle.unwrap_or("*");
        match self.namespace.as_str() {
            "" => format!("{v}/{topic}"),
            ns => format!("{ns}/{v}/{topic}"),
        }
    }

    fn data_key(&self, base: &str, dds_type: &str, hash: &str) -> String {
        match self.format {
            Ros2Format::RmwZenoh => format!("{}/{base}/{dds_type}/{hash}", self.domain),
            Ros2Format::Bridge => base.to_string(),
        }
    }

    /// The key a vehicle's topic is published on.
    pub fn topic(&self, vehicle: &str, topic: &str, dds_type: &str, hash: &str) -> String {
        self.data_key(&self.base(Some(vehicle), topic), dds_type, hash)
    }

    /// The same topic of every vehicle (a publisher's matching listener watches it).
    pub fn topic_all(&self, topic: &str, dds_type: &str, hash: &str) -> String {
        self.data_key(&self.base(None, topic), dds_type, hash)
    }

    /// What the edge subscribes to for an input topic: every vehicle, any type and any hash (a Humble
    /// publisher's is `TypeHashNotSupported`; a wrong type is refused with a reason, not ignored).
    pub fn subscription(&self, topic: &str) -> String {
        self.data_key(&self.base(None, topic), "*", "*")
    }

    /// A topic outside the vehicles' namespaces (`/diagnostics`).
    pub fn global(&self, topic: &str, dds_type: &str, hash: &str) -> String {
        self.data_key(topic.trim_matches('/'), dds_type, hash)
    }

    /// Splits an input's key: the vehicle, which of `topics` it is, and (rmw_zenoh) the DDS type name
    /// and type hash chunks. `None` for keys that are not one of them.
    pub fn split<'a>(
        &self,
        key: &'a str,
        topics: &[&str],
    ) -> Option<(&'a str, usize, &'a str, &'a str)> {
        let mut rest = key;
        if self.format == Ros2Format::RmwZenoh {
            let d = self.domain.to_string();
            rest = rest.strip_prefix(d.as_str())?.strip_prefix('/')?;
        }
        if !self.namespace.is_empty() {
            rest = rest
                .strip_prefix(self.namespace.as_str())?
                .strip_prefix('/')?;
        }
        let (vehicle, rest) = rest.split_once('/')?;
        if vehicle.is_empty() {
            return None;
        }
        let (topic, ty, hash) = match self.format {
            Ros2Format::Bridge => (rest, "", ""),
            Ros2Format::RmwZenoh => {
                let (front, hash) = rest.rsplit_once('/')?;
                let (topic, ty) = front.rsplit_once('/')?;
                (topic, ty, hash)
            }
        };
        let i = topics.iter().position(|t| *t == topic)?;
        Some((vehicle, i, ty, hash))
    }

    /// rmw_zenoh's liveliness token of a node (`@ros2_lv/<domain>/<zid>/<nid>/<nid>/NN/<enclave>/
    /// <namespace>/<name>`; names mangled, the root enclave and namespace `/` become `%`).
    pub fn node_token(&self, zid: &str, nid: u64, namespace: &str, name: &str) -> String {
        format!(
            "@ros2_lv/{}/{zid}/{nid}/{nid}/{}/%/{}/{}",
            self.domain,
            Ros2Entity::Node.as_str(),
            ros2_mangle(namespace),
            ros2_mangle(name)
        )
    }

    /// rmw_zenoh's liveliness token of a publisher or subscription of a node: the node's chunks, then
    /// the mangled topic name, the DDS type name, the type hash and the QoS.
    #[allow(clippy::too_many_arguments)]
    pub fn endpoint_token(
        &self,
        zid: &str,
        nid: u64,
        eid: u64,
        kind: Ros2Entity,
        node: (&str, &str),
        topic_name: &str,
        dds_type: &str,
        hash: &str,
        qos: &str,
    ) -> String {
        format!(
            "@ros2_lv/{}/{zid}/{nid}/{eid}/{}/%/{}/{}/{}/{dds_type}/{hash}/{qos}",
            self.domain,
            kind.as_str(),
            ros2_mangle(node.0),
            ros2_mangle(node.1),
            ros2_mangle(topic_name)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ros2_keys() {
        let k = Ros2Keys::new(Ros2Format::RmwZenoh, 0, "");
        let hash = "RIHS01_ab";
        let imu = "sensor_msgs::msg::dds_::Imu_";
        assert_eq!(
            k.topic("sat1", "imu/data", imu, hash),
            "0/sat1/imu/data/sensor_msgs::msg::dds_::Imu_/RIHS01_ab"
        );
        assert_eq!(k.subscription("imu/data_raw"), "0/*/imu/data_raw/*/*");
        assert_eq!(
            k.split(
                "0/sat1/imu/data_raw/sensor_msgs::msg::dds_::Imu_/TypeHashNotSupported",
                &["imu/data_raw", "imu/mag"]
            ),
            Some(("sat1", 0, imu, "TypeHashNotSupported"))
        );
        assert_eq!(k.split("1/sat1/imu/data_raw/x/y", &["imu/data_raw"]), None);
        assert_eq!(k.topic_name("sat1", "imu/data"), "/sat1/imu/data");
        assert_eq!(
            k.endpoint_token(
                "abc",
                0,
                3,
                Ros2Entity::Publisher,
                ("/", "attitude_service"),
                "/sat1/imu/data",
                imu,
                hash,
                "::,10:,:,:,,"
            ),
            "@ros2_lv/0/abc/0/3/MP/%/%/attitude_service/%sat1%imu%data/sensor_msgs::msg::dds_::Imu_/RIHS01_ab/::,10:,:,:,,"
        );
        let b = Ros2Keys::new(Ros2Format::Bridge, 0, "/robots/");
        assert_eq!(
            b.topic("sat1", "imu/data", imu, hash),
            "robots/sat1/imu/data"
        );
        assert_eq!(b.subscription("imu/data_raw"), "robots/*/imu/data_raw");
        assert_eq!(
            b.split("robots/sat1/imu/mag", &["imu/data_raw", "imu/mag"]),
            Some(("sat1", 1, "", ""))
        );
        assert_eq!(b.global("/diagnostics", "", ""), "diagnostics");
    }
}
