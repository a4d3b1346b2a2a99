//! Standby batches (`P/@/standby/<r>/inputs` from senders, `P/@/standby/<r>/estimates/<G>` from a
//! route's owner): many messages of one route in one zenoh message, so that a fleet's standby members
//! receive a route's inputs and estimates at the cost of a few messages, not one per input.
//!
//! The format (`proto/README.md`, "Routed inputs"): records one after another, each
//!
//! ```text
//! u16 little-endian: n, the length of the record's key; n bytes: the key, UTF-8, `V/<leaf>`
//! u32 little-endian: m, the length of its payload;      m bytes: the payload, exactly as put
//! ```
//!
//! The key is relative to the prefix (`sc1/gyro`, `sc1/estimate`); the payload is the message's own
//! bytes (a JSON input or estimate), so a record is the message its sender put on `P/V/<leaf>/<r>` (or
//! `P/V/estimate`). Nothing else: no header, no padding.

use std::fmt;

/// A record's key is at most this long (a 64-character id, a slash and a leaf, with room to spare).
pub const MAX_RECORD_KEY: usize = 256;

/// A batch being written.
#[derive(Clone, Debug, Default)]
pub struct BatchWriter {
    buf: Vec<u8>,
    records: usize,
}

impl BatchWriter {
    /// Appends the record `(vehicle/leaf, payload)`.
    pub fn push(&mut self, vehicle: &str, leaf: &str, payload: &[u8]) {
        let key_len = vehicle.len() + 1 + leaf.len();
        debug_assert!(key_len <= MAX_RECORD_KEY && payload.len() <= u32::MAX as usize);
        self.buf.reserve(2 + key_len + 4 + payload.len());
        self.buf.extend_from_slice(&(key_len as u16).to_le_bytes());
        self.buf.extend_from_slice(vehicle.as_bytes());
        self.buf.push(b'/');
        self.buf.extend_from_slice(leaf.as_bytes());
        self.buf
            .extend_from_slice(&(payload.len() as u32).to_le_bytes());
        self.buf.extend_from_slice(payload);
        self.records += 1;
    }

    pub fn is_empty(&self) -> bool {
        self.records == 0
    }

    /// Bytes written so far.
    pub fn len(&self) -> usize {
        self.buf.len()
    }

    pub fn records(&self) -> usize {
        self.records
    }

    /// The batch, leaving this writer empty (its buffer's capacity kept for the next batch).
    pub fn take(&mut self) -> Vec<u8> {
        self.records = 0;
        let cap = self.buf.capacity();
        std::mem::replace(&mut self.buf, Vec::with_capacity(cap))
    }
}

/// Why a batch cannot be read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BatchError {
    /// The byte offset of the record that is wrong.
    pub at: usize,
    pub reason: &'static str,
}

impl fmt::Display for BatchError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "standby batch: {} (record at byte {})",
            self.reason, self.at
        )
    }
}

/// One record read back: its vehicle, its leaf and its payload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Record<'a> {
    pub vehicle: &'a str,
    pub leaf: &'a str,
    pub payload: &'a [u8],
}

/// The records of `batch`, in order; a malformed record ends the iteration with its error.
pub fn records(batch: &[u8]) -> Records<'_> {
    Records { batch, at: 0 }
}

/// Checks a whole batch (every record's framing and key), without copying anything.
pub fn check(batch: &[u8]) -> Result<usize, BatchError> {
    let mut n = 0;
    for r in records(batch) {
        r?;
        n += 1;
    }
    Ok(n)
}

pub struct Records<'a> {
    batch: &'a [u8],
    at: usize,
}

impl<'a> Iterator for Records<'a> {
    type Item = Result<Record<'a>, BatchError>;

    fn next(&mut self) -> Option<Self::Item> {
        let b = self.batch;
        let start = self.at;
        if start >= b.len() {
            return None;
        }
        let fail = |reason| Some(Err(BatchError { at: start, reason }));
        // (A malformed record ends the batch: nothing after it can be framed.)
        self.at = b.len();
        let Some(k) = b.get(start..start + 2) else {
            return fail("truncated key length");
        };
        let key_len = u16::from_le_bytes([k[0], k[1]]) as usize;
        if key_len == 0 || key_len > MAX_RECORD_KEY {
            return fail("key length out of range");
        }
        let Some(key) = b.get(start + 2..start + 2 + key_len) else {
            return fail("truncated key");
        };
        let Ok(key) = std::str::from_utf8(key) else {
            return fail("key is not UTF-8");
        };
        let Some((vehicle, leaf)) = key.split_once('/') else {
            return fail("key is not vehicle/leaf");
        };
        if vehicle.is_empty() || leaf.is_empty() || leaf.contains('/') {
            return fail("key is not vehicle/leaf");
        }
        let p = start + 2 + key_len;
        let Some(m) = b.get(p..p + 4) else {
            return fail("truncated payload length");
        };
        let len = u32::from_le_bytes([m[0], m[1], m[2], m[3]]) as usize;
        let Some(payload) = b.get(p + 4..p + 4 + len) else {
            return fail("truncated payload");
        };
        self.at = p + 4 + len;
        Some(Ok(Record {
            vehicle,
            leaf,
            payload,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_round_trip_and_faults_are_found() {
        let mut w = BatchWriter::default();
        w.push("sc1", "gyro", br#"{"t":1,"omega":[0,0,0]}"#);
        w.push("sc-2", "vectors", b"");
        assert_eq!((w.records(), w.is_empty()), (2, false));
        let b = w.take();
        assert!(w.is_empty());
        // The format, byte for byte: a u16 key length, the key, a u32 payload length, the payload.
        assert_eq!(&b[..2], &8u16.to_le_bytes());
        assert_eq!(&b[2..10], b"sc1/gyro");
        assert_eq!(&b[10..14], &23u32.to_le_bytes());
        let got: Vec<Record> = records(&b).map(|r| r.unwrap()).collect();
        assert_eq!(
            got,
            vec![
                Record {
                    vehicle: "sc1",
                    leaf: "gyro",
                    payload: br#"{"t":1,"omega":[0,0,0]}"#
                },
                Record {
                    vehicle: "sc-2",
                    leaf: "vectors",
                    payload: b""
                }
            ]
        );
        assert_eq!(check(&b), Ok(2));
        assert_eq!(check(&[]), Ok(0));
        // Every truncation is found, at the record where it is.
        for cut in 1..b.len() {
            let r = check(&b[..cut]);
            if cut == 37 {
                assert_eq!(r, Ok(1), "{cut}");
            } else {
                assert!(r.is_err(), "{cut}");
            }
        }
        let bad_key = |key: &[u8]| {
            let mut v = (key.len() as u16).to_le_bytes().to_vec();
            v.extend_from_slice(key);
            v.extend_from_slice(&0u32.to_le_bytes());
            check(&v).unwrap_err().reason
        };
        assert_eq!(bad_key(b"nokey"), "key is not vehicle/leaf");
        assert_eq!(bad_key(b"/gyro"), "key is not vehicle/leaf");
        assert_eq!(bad_key(b"a/b/c"), "key is not vehicle/leaf");
        assert_eq!(bad_key(b"\xff/gyro"), "key is not UTF-8");
        assert_eq!(bad_key(b""), "key length out of range");
    }
}
