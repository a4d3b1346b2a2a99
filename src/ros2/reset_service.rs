//! The reset as a ROS 2 service (`service.ros2.reset_service`, e.g. `/<namespace>/V/imu/reset`; off by
//! default: a Fast DDS client cannot call it through the bridge, which reads the request's id from the
//! payload as CycloneDDS writes it, where Fast DDS does not put it):
//! `std_srvs/srv/Trigger`, the service type ROS 2 drivers and filters use for a reset without
//! arguments. A call is `P/V/reset` with no fields (the vehicle's configured filter starts afresh, its
//! time from the next sample: a bag played again from its start is taken); the response's `success` and
//! `message` say what happened (the new state, or the reason it was refused).
//!
//! In the bridge key format (the plugin in the service's runtime with `format: "dds"`, or a
//! zenoh-bridge-ros2dds): a zenoh queryable on the service's key (`<namespace>/V/imu/reset`), whose
//! query payload is the request's CDR (4-byte encapsulation header, then the fields, without DDS'
//! request id) and whose reply is the response's CDR; the bridge's announcement of the server
//! (`@/<bridge>/@ros2_lv/SS/<key>/<type>`) makes the bridge create the DDS service endpoints, so
//! `ros2 service list` and a client's `wait_for_service` see it before any call.

use super::cdr::{Reader, Writer};
use super::Edge;
use crate::engine::Engine;
use crate::wire::ResetMsg;
use std::sync::Arc;
use std::time::Duration;
use zenoh::query::Query;

/// The service type.
pub const TRIGGER: &str = "std_srvs/srv/Trigger";

/// How long a call waits for the vehicle's worker.
const TIMEOUT: Duration = Duration::from_secs(10);

/// `std_srvs/srv/Trigger`'s request: no field (CDR: one `uint8` placeholder, as rosidl generates for an
/// empty structure). Any well-formed encapsulation is accepted; its content is not used.
pub fn decode_request(cdr: &[u8]) -> Result<(), String> {
    let mut r = Reader::new(cdr).map_err(|e| e.to_string())?;
    // (An empty body is also taken: some implementations send the header alone.)
    let _ = r.u8("structure_needs_at_least_one_field");
    Ok(())
}

/// `std_srvs/srv/Trigger`'s response: `bool success`, `string message`.
pub fn encode_response(success: bool, message: &str) -> Vec<u8> {
    let mut w = Writer::with_capacity(16 + message.len());
    w.u8(success as u8);
    w.string(message);
    w.finish()
}

/// The zenoh-bridge-ros2dds announcement of a service server on `key` (`dds.rs` has the publisher's).
pub fn server_announcement(bridge: &str, key: &str) -> String {
    format!(
        "@/{bridge}/@ros2_lv/SS/{}/{}",
        key.replace('/', "§"),
        TRIGGER.replace('/', "§")
    )
}

/// Answers one call (bridge key format).
pub async fn answer(engine: Arc<Engine>, edge: Arc<Edge>, q: Query) {
    let key = q.key_expr().as_str().to_string();
    let Some(reset) = edge.config.reset_service.clone() else {
        return;
    };
    let Some((vehicle, _, _, _)) = edge.keys.split(&key, &[reset.as_str()]) else {
        return;
    };
    if vehicle.contains(['*', '$']) {
        return;
    }
    // Another member of a fleet owns the vehicle and answers.
    if !engine.owns(vehicle) {
        return;
    }
    let request = q
        .payload()
        .map(|p| p.to_bytes().to_vec())
        .unwrap_or_default();
    let (success, message) = match decode_request(&request) {
        Err(e) => (false, format!("not a std_srvs/srv/Trigger request: {e}")),
        Ok(()) => match engine.request_reset(vehicle, ResetMsg::default()) {
            Err(r) => (false, format!("{}: {}", r.code.as_str(), r.message)),
            Ok(rx) => match tokio::time::timeout(TIMEOUT, rx).await {
                Ok(Ok(Ok(reply))) => (
                    true,
                    format!(
                        "{vehicle}: reset, {} ({}), {}",
                        reply.filter,
                        reply.fiducial.as_deref().unwrap_or("-"),
                        reply.state
                    ),
                ),
                Ok(Ok(Err(r))) => (false, format!("{}: {}", r.code.as_str(), r.message)),
                _ => (
                    false,
                    "the vehicle's worker did not answer the reset".into(),
                ),
            },
        },
    };
    tracing::info!(vehicle, success, message, "ros2: reset service called");
    if let Err(e) = q
        .reply(q.key_expr().clone(), encode_response(success, &message))
        .encoding(zenoh::bytes::Encoding::APPLICATION_CDR)
        .await
    {
        tracing::warn!(key, error = %e, "ros2: reset reply failed");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trigger_codec() {
        assert!(decode_request(&[0, 1, 0, 0, 0]).is_ok());
        assert!(decode_request(&[0, 1, 0, 0]).is_ok());
        assert!(decode_request(&[1]).is_err());
        // success = true, "ok": 1, padding to 4, length 3 (with the NUL), "ok\0".
        assert_eq!(
            encode_response(true, "ok"),
            vec![0, 1, 0, 0, 1, 0, 0, 0, 3, 0, 0, 0, b'o', b'k', 0]
        );
    }

    #[test]
    fn server_announcement_is_the_bridges() {
        assert_eq!(
            server_announcement("b", "r1/imu/reset"),
            "@/b/@ros2_lv/SS/r1§imu§reset/std_srvs§srv§Trigger"
        );
    }
}
