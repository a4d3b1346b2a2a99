//! Error replies and `P/V/rejected` (the codes: [`crate::rejection`]), and the contract's vehicle ids.

pub use crate::rejection::{RejectCode, Rejection};
use serde::{Deserialize, Serialize};

/// The error reply / rejection message of a [`Rejection`] on `key`.
pub trait ToMessage {
    fn to_message(&self, key: &str) -> ErrorMsg;
}

impl ToMessage for Rejection {
    fn to_message(&self, key: &str) -> ErrorMsg {
        ErrorMsg {
            code: self.code.as_str().to_string(),
            message: self.message.clone(),
            key: key.to_string(),
        }
    }
}
/// A vehicle id of the contract: 1–64 characters of `[A-Za-z0-9_-]`.
pub fn validate_vehicle_id(id: &str) -> Result<(), Rejection> {
    let ok = !id.is_empty()
        && id.len() <= 64
        && id
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-');
    if ok {
        Ok(())
    } else {
        Err(Rejection::new(
            RejectCode::InvalidVehicleId,
            format!("vehicle id '{id}' must be 1-64 characters of A-Z, a-z, 0-9, '_' and '-'"),
        ))
    }
}

/// Error replies and `P/V/rejected`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ErrorMsg {
    pub code: String,
    pub message: String,
    pub key: String,
}
