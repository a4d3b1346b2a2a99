//! The ROS 2 messages of the ROS 2 edge (`service.ros2`, `proto/ros2.md`): `sensor_msgs/msg/Imu` and
//! `sensor_msgs/msg/MagneticField` in, `sensor_msgs/msg/Imu` and `diagnostic_msgs/msg/DiagnosticArray`
//! out, as CDR; their REP-2016 type hashes (RIHS01); and the conversion of an incoming Imu into the
//! same [`ImuMsg`] that `P/V/imu` carries, so that it passes the same checks into the same domain
//! sample.

use super::cdr::{CdrError, Reader, Writer};
use crate::sensors::ImuSample;
use crate::wire::{ImuMsg, InputLimits, RejectCode, Rejection};
use sha2::{Digest, Sha256};

/// `builtin_interfaces/msg/Time`: the header stamp.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stamp {
    pub sec: i32,
    pub nanosec: u32,
}

impl Stamp {
    /// Seconds, as the service's sample time `t`.
    pub fn seconds(&self) -> f64 {
        self.sec as f64 + self.nanosec as f64 * 1e-9
    }

    /// The stamp nearest `t` s (for an estimate with no sample of its own to take the stamp from).
    pub fn from_seconds(t: f64) -> Stamp {
        let sec = t.floor();
        let mut nanosec = ((t - sec) * 1e9).round();
        let mut sec = sec;
        if nanosec >= 1e9 {
            nanosec -= 1e9;
            sec += 1.0;
        }
        Stamp {
            sec: sec.clamp(i32::MIN as f64, i32::MAX as f64) as i32,
            nanosec: nanosec.max(0.0) as u32,
        }
    }
}

/// `std_msgs/msg/Header`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Header {
    pub stamp: Stamp,
    pub frame_id: String,
}

/// `sensor_msgs/msg/Imu` (covariances row-major, 3×3; element 0 = −1: the field is absent, REP-145).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RosImu {
    pub header: Header,
    /// `[x, y, z, w]`.
    pub orientation: [f64; 4],
    pub orientation_covariance: [f64; 9],
    pub angular_velocity: [f64; 3],
    pub angular_velocity_covariance: [f64; 9],
    pub linear_acceleration: [f64; 3],
    pub linear_acceleration_covariance: [f64; 9],
}

/// `sensor_msgs/msg/MagneticField` (tesla).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RosMagneticField {
    pub header: Header,
    pub magnetic_field: [f64; 3],
    pub magnetic_field_covariance: [f64; 9],
}

/// `diagnostic_msgs/msg/KeyValue`.
#[derive(Clone, Debug, PartialEq)]
pub struct KeyValue {
    pub key: String,
    pub value: String,
}

/// `diagnostic_msgs/msg/DiagnosticStatus` (`level`: 0 OK, 1 WARN, 2 ERROR, 3 STALE).
#[derive(Clone, Debug, PartialEq)]
pub struct DiagnosticStatus {
    pub level: u8,
    pub name: String,
    pub message: String,
    pub hardware_id: String,
    pub values: Vec<KeyValue>,
}

/// `diagnostic_msgs/msg/DiagnosticArray`.
#[derive(Clone, Debug, PartialEq)]
pub struct DiagnosticArray {
    pub header: Header,
    pub status: Vec<DiagnosticStatus>,
}

fn read_header(r: &mut Reader) -> Result<Header, CdrError> {
    let sec = r.i32("header.stamp.sec")?;
    let nanosec = r.u32("header.stamp.nanosec")?;
    let frame_id = r.string("header.frame_id")?;
    Ok(Header {
        stamp: Stamp { sec, nanosec },
        frame_id,
    })
}

fn write_header(w: &mut Writer, h: &Header) {
    w.i32(h.stamp.sec);
    w.u32(h.stamp.nanosec);
    w.string(&h.frame_id);
}

impl RosImu {
    pub fn from_cdr(b: &[u8]) -> Result<RosImu, CdrError> {
        let mut r = Reader::new(b)?;
        let m = RosImu {
            header: read_header(&mut r)?,
            orientation: r.f64s("orientation")?,
            orientation_covariance: r.f64s("orientation_covariance")?,
            angular_velocity: r.f64s("angular_velocity")?,
            angular_velocity_covariance: r.f64s("angular_velocity_covariance")?,
            linear_acceleration: r.f64s("linear_acceleration")?,
            linear_acceleration_covariance: r.f64s("linear_acceleration_covariance")?,
        };
        r.finish()?;
        Ok(m)
    }

    pub fn to_cdr(&self) -> Vec<u8> {
        let mut w = Writer::with_capacity(320 + self.header.frame_id.len());
        write_header(&mut w, &self.header);
        w.f64s(&self.orientation);
        w.f64s(&self.orientation_covariance);
        w.f64s(&self.angular_velocity);
        w.f64s(&self.angular_velocity_covariance);
        w.f64s(&self.linear_acceleration);
        w.f64s(&self.linear_acceleration_covariance);
        w.finish()
    }

    /// The sample `P/V/imu` would carry, checked the same way ([`ImuMsg::to_domain`]), with the
    /// magnetometer reading paired with it (µT) if any. REP-145: a covariance whose element 0 is −1
    /// says the field is absent; the service needs both the rate and the specific force.
    pub fn to_domain(
        &self,
        mag_ut: Option<[f64; 3]>,
        limits: &InputLimits,
    ) -> Result<ImuSample, Rejection> {
        if self.header.stamp.nanosec >= 1_000_000_000 {
            return Err(Rejection::new(
                RejectCode::OutOfRange,
                format!(
                    "ros2: header.stamp.nanosec = {} is not below 1e9",
                    self.header.stamp.nanosec
                ),
            ));
        }
        for (cov, what) in [
            (&self.angular_velocity_covariance, "angular_velocity"),
            (&self.linear_acceleration_covariance, "linear_acceleration"),
        ] {
            if cov[0] == -1.0 {
                return Err(Rejection::new(
                    RejectCode::BadRequest,
                    format!(
                        "ros2: {what}_covariance[0] = -1: the message says it has no {what} \
                         (REP-145), and the service needs it"
                    ),
                ));
            }
            if cov.iter().any(|x| !x.is_finite()) {
                return Err(Rejection::new(
                    RejectCode::NonFinite,
                    format!("ros2: {what}_covariance must be finite"),
                ));
            }
        }
        ImuMsg {
            t: self.header.stamp.seconds(),
            gyr: self.angular_velocity,
            acc: self.linear_acceleration,
            mag: mag_ut,
        }
        .to_domain(limits)
    }
}

impl RosMagneticField {
    pub fn from_cdr(b: &[u8]) -> Result<RosMagneticField, CdrError> {
        let mut r = Reader::new(b)?;
        let m = RosMagneticField {
            header: read_header(&mut r)?,
            magnetic_field: r.f64s("magnetic_field")?,
            magnetic_field_covariance: r.f64s("magnetic_field_covariance")?,
        };
        r.finish()?;
        Ok(m)
    }

    pub fn to_cdr(&self) -> Vec<u8> {
        let mut w = Writer::with_capacity(128);
        write_header(&mut w, &self.header);
        w.f64s(&self.magnetic_field);
        w.f64s(&self.magnetic_field_covariance);
        w.finish()
    }

    /// The reading in µT (the unit of the service's tests and tuning; the pipeline itself is
    /// unit-free), checked: finite, a stamp with nanoseconds below 1e9, not marked absent.
    pub fn to_domain(&self) -> Result<(f64, [f64; 3]), Rejection> {
        if self.header.stamp.nanosec >= 1_000_000_000 {
            return Err(Rejection::new(
                RejectCode::OutOfRange,
                format!(
                    "ros2: header.stamp.nanosec = {} is not below 1e9",
                    self.header.stamp.nanosec
                ),
            ));
        }
        if self.magnetic_field_covariance[0] == -1.0 {
            return Err(Rejection::new(
                RejectCode::BadRequest,
                "ros2: magnetic_field_covariance[0] = -1: the message says it has no field",
            ));
        }
        if self
            .magnetic_field
            .iter()
            .chain(&self.magnetic_field_covariance)
            .any(|x| !x.is_finite())
        {
            return Err(Rejection::new(
                RejectCode::NonFinite,
                "ros2: magnetic_field and its covariance must be finite",
            ));
        }
        let m = self.magnetic_field.map(|x| x * 1e6);
        if m.iter().any(|x| x.abs() > crate::wire::MAX_MAGNITUDE) {
            return Err(Rejection::new(
                RejectCode::OutOfRange,
                "ros2: magnetic_field is beyond 1e94 T",
            ));
        }
        Ok((self.header.stamp.seconds(), m))
    }
}

impl DiagnosticArray {
    pub fn to_cdr(&self) -> Vec<u8> {
        let mut w = Writer::with_capacity(256 * (1 + self.status.len()));
        write_header(&mut w, &self.header);
        w.u32(self.status.len() as u32);
        for s in &self.status {
            w.u8(s.level);
            w.string(&s.name);
            w.string(&s.message);
            w.string(&s.hardware_id);
            w.u32(s.values.len() as u32);
            for kv in &s.values {
                w.string(&kv.key);
                w.string(&kv.value);
            }
        }
        w.finish()
    }
}

/// A CDR fault as the rejection of an input.
pub fn cdr_rejection(what: &str, e: CdrError) -> Rejection {
    Rejection::new(
        RejectCode::BadRequest,
        format!("ros2: not the CDR of {what}: {e}"),
    )
}

// ------------------------------------------------------------------------------------------------
// Type descriptions and their hashes (REP-2016).

/// A field's type, as `type_description_interfaces/msg/FieldType` numbers it.
#[derive(Clone, Copy, Debug)]
enum Field {
    Nested(&'static str),
    NestedSequence(&'static str),
    Int32,
    Uint32,
    Double,
    DoubleArray(u64),
    Byte,
    String,
}

impl Field {
    /// `(type_id, capacity, nested_type_name)`.
    fn parts(&self) -> (u8, u64, &'static str) {
        // FieldType: NESTED_TYPE 1, INT32 6, UINT32 7, DOUBLE 11, BYTE 16, STRING 17; a fixed array
        // adds 48, an unbounded sequence 144.
        match *self {
            Field::Nested(n) => (1, 0, n),
            Field::NestedSequence(n) => (1 + 144, 0, n),
            Field::Int32 => (6, 0, ""),
            Field::Uint32 => (7, 0, ""),
            Field::Double => (11, 0, ""),
            Field::DoubleArray(n) => (11 + 48, n, ""),
            Field::Byte => (16, 0, ""),
            Field::String => (17, 0, ""),
        }
    }
}

type Description = (&'static str, &'static [(&'static str, Field)]);

const TIME: Description = (
    "builtin_interfaces/msg/Time",
    &[("sec", Field::Int32), ("nanosec", Field::Uint32)],
);
const HEADER: Description = (
    "std_msgs/msg/Header",
    &[
        ("stamp", Field::Nested("builtin_interfaces/msg/Time")),
        ("frame_id", Field::String),
    ],
);
const QUATERNION: Description = (
    "geometry_msgs/msg/Quaternion",
    &[
        ("x", Field::Double),
        ("y", Field::Double),
        ("z", Field::Double),
        ("w", Field::Double),
    ],
);
const VECTOR3: Description = (
    "geometry_msgs/msg/Vector3",
    &[
        ("x", Field::Double),
        ("y", Field::Double),
        ("z", Field::Double),
    ],
);
const IMU: Description = (
    "sensor_msgs/msg/Imu",
    &[
        ("header", Field::Nested("std_msgs/msg/Header")),
        ("orientation", Field::Nested("geometry_msgs/msg/Quaternion")),
        ("orientation_covariance", Field::DoubleArray(9)),
        (
            "angular_velocity",
            Field::Nested("geometry_msgs/msg/Vector3"),
        ),
        ("angular_velocity_covariance", Field::DoubleArray(9)),
        (
            "linear_acceleration",
            Field::Nested("geometry_msgs/msg/Vector3"),
        ),
        ("linear_acceleration_covariance", Field::DoubleArray(9)),
    ],
);
const MAGNETIC_FIELD: Description = (
    "sensor_msgs/msg/MagneticField",
    &[
        ("header", Field::Nested("std_msgs/msg/Header")),
        ("magnetic_field", Field::Nested("geometry_msgs/msg/Vector3")),
        ("magnetic_field_covariance", Field::DoubleArray(9)),
    ],
);
const KEY_VALUE: Description = (
    "diagnostic_msgs/msg/KeyValue",
    &[("key", Field::String), ("value", Field::String)],
);
const DIAGNOSTIC_STATUS: Description = (
    "diagnostic_msgs/msg/DiagnosticStatus",
    &[
        ("level", Field::Byte),
        ("name", Field::String),
        ("message", Field::String),
        ("hardware_id", Field::String),
        (
            "values",
            Field::NestedSequence("diagnostic_msgs/msg/KeyValue"),
        ),
    ],
);
const DIAGNOSTIC_ARRAY: Description = (
    "diagnostic_msgs/msg/DiagnosticArray",
    &[
        ("header", Field::Nested("std_msgs/msg/Header")),
        (
            "status",
            Field::NestedSequence("diagnostic_msgs/msg/DiagnosticStatus"),
        ),
    ],
);
const ALL: [Description; 9] = [
    TIME,
    HEADER,
    QUATERNION,
    VECTOR3,
    IMU,
    MAGNETIC_FIELD,
    KEY_VALUE,
    DIAGNOSTIC_STATUS,
    DIAGNOSTIC_ARRAY,
];

/// A ROS 2 message type of the edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RosType {
    Imu,
    MagneticField,
    DiagnosticArray,
}

impl RosType {
    /// `sensor_msgs/msg/Imu`.
    pub fn name(&self) -> &'static str {
        self.description().0
    }

    fn description(&self) -> Description {
        match self {
            RosType::Imu => IMU,
            RosType::MagneticField => MAGNETIC_FIELD,
            RosType::DiagnosticArray => DIAGNOSTIC_ARRAY,
        }
    }

    /// The DDS type name rmw_zenoh puts in keys: `sensor_msgs::msg::dds_::Imu_`.
    pub fn dds_name(&self) -> String {
        let name = self.name();
        let mut parts = name.split('/');
        let (pkg, sub, ty) = (
            parts.next().unwrap_or(""),
            parts.next().unwrap_or(""),
            parts.next().unwrap_or(""),
        );
        format!("{pkg}::{sub}::dds_::{ty}_")
    }

    /// The REP-2016 type hash, `RIHS01_<sha256 hex>`.
    pub fn hash(&self) -> String {
        rihs01(self.name())
    }
}

fn describe(name: &str) -> Option<Description> {
    ALL.iter().copied().find(|d| d.0 == name)
}

/// The JSON of one type description, keys in rosidl's order.
fn description_json(d: Description, out: &mut String) {
    out.push_str(&format!("{{\"type_name\": \"{}\", \"fields\": [", d.0));
    for (i, (name, f)) in d.1.iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        let (id, capacity, nested) = f.parts();
        out.push_str(&format!(
            "{{\"name\": \"{name}\", \"type\": {{\"type_id\": {id}, \"capacity\": {capacity}, \
             \"string_capacity\": 0, \"nested_type_name\": \"{nested}\"}}}}"
        ));
    }
    out.push_str("]}");
}

/// Every type a description refers to, directly or not, sorted by name.
fn referenced(d: Description, into: &mut std::collections::BTreeMap<&'static str, Description>) {
    for (_, f) in d.1 {
        if let Field::Nested(n) | Field::NestedSequence(n) = f {
            if let Some(r) = describe(n) {
                if into.insert(r.0, r).is_none() {
                    referenced(r, into);
                }
            }
        }
    }
}

/// The hashed representation of a type (rosidl_generator_type_description: the type description and
/// its referenced descriptions without default values, as Python's `json.dumps` writes them with
/// separators `", "` and `": "`).
pub fn hashed_representation(name: &str) -> Option<String> {
    let d = describe(name)?;
    let mut refs = std::collections::BTreeMap::new();
    referenced(d, &mut refs);
    let mut s = String::from("{\"type_description\": ");
    description_json(d, &mut s);
    s.push_str(", \"referenced_type_descriptions\": [");
    for (i, r) in refs.values().enumerate() {
        if i > 0 {
            s.push_str(", ");
        }
        description_json(*r, &mut s);
    }
    s.push_str("]}");
    Some(s)
}

/// `RIHS01_` and the SHA-256 of the hashed representation, in hex (REP-2016, version 1). Empty for a
/// type the edge does not know.
pub fn rihs01(name: &str) -> String {
    let Some(repr) = hashed_representation(name) else {
        return String::new();
    };
    let digest = Sha256::digest(repr.as_bytes());
    let mut s = String::with_capacity(7 + 64);
    s.push_str("RIHS01_");
    for b in digest {
        s.push_str(&format!("{b:02x}"));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hashes of ROS 2 Jazzy's interfaces (as `ros2 topic info -v` prints them; the Python suite
    /// checks them against rosbags' own computation).
    #[test]
    fn type_hashes() {
        assert_eq!(
            RosType::Imu.hash(),
            "RIHS01_7d9a00ff131080897a5ec7e26e315954b8eae3353c3f995c55faf71574000b5b"
        );
        assert_eq!(
            RosType::MagneticField.hash(),
            "RIHS01_e80f32f56a20486c9923008fc1a1db07bbb273cbbf6a5b3bfa00835ee00e4dff"
        );
        assert_eq!(
            RosType::DiagnosticArray.hash(),
            "RIHS01_5a8a36efb05fb25070fa0fb3810290c0e6cd4862b54a8fb975a1ee8dc55a333e"
        );
        assert_eq!(
            rihs01("std_msgs/msg/Header"),
            "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01"
        );
        assert_eq!(RosType::Imu.dds_name(), "sensor_msgs::msg::dds_::Imu_");
    }

    #[test]
    fn imu_round_trip_and_layout() {
        let m = RosImu {
            header: Header {
                stamp: Stamp {
                    sec: 12,
                    nanosec: 500_000_000,
                },
                frame_id: "imu_link".into(),
            },
            orientation: [0.0, 0.0, 0.0, 1.0],
            orientation_covariance: [-1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            angular_velocity: [0.1, 0.2, 0.3],
            angular_velocity_covariance: [0.0; 9],
            linear_acceleration: [0.0, 0.0, 9.81],
            linear_acceleration_covariance: [0.0; 9],
        };
        let b = m.to_cdr();
        // header 4 + stamp 8 + string 4+9 → 25, padded to 28 (8-aligned after the header) + 37 doubles.
        assert_eq!(b.len(), 4 + 24 + 37 * 8);
        assert_eq!(RosImu::from_cdr(&b).unwrap(), m);
        assert!(RosImu::from_cdr(&b[..b.len() - 1]).is_err());
        let mut longer = b.clone();
        longer.extend_from_slice(&[1, 2, 3, 4, 5, 6, 7, 8]);
        assert!(RosImu::from_cdr(&longer).is_err());
        let s = m.to_domain(None, &InputLimits::default()).unwrap();
        assert_eq!(s.t_s, 12.5);
    }

    #[test]
    fn stamps() {
        let s = Stamp::from_seconds(1.999_999_999_9);
        assert_eq!((s.sec, s.nanosec), (2, 0));
        let s = Stamp::from_seconds(1_700_000_000.25);
        assert_eq!((s.sec, s.nanosec), (1_700_000_000, 250_000_000));
    }
}
