//! OMG CDR (XCDR1, "plain CDR" as ROS 2 serialises messages): a reader and a writer of the few types
//! the ROS 2 edge needs. A payload starts with the 4-byte encapsulation header (`00 01`: little-endian,
//! `00 00`: big-endian, then two option bytes); every primitive is aligned to its size, counted from
//! the end of that header; a string is a `u32` length that counts its terminating NUL, the bytes and the
//! NUL; a sequence is a `u32` count and its elements; a fixed array is its elements alone.
//!
//! Every fault is a [`CdrError`] that says where and what; nothing here panics on any input.

use std::fmt;

/// Longest string accepted in a decoded message (a `frame_id`), bytes.
pub const MAX_STRING: usize = 4096;

/// Why a payload is not the CDR of the expected message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CdrError(pub String);

impl fmt::Display for CdrError {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(&self.0)
    }
}

fn err<T>(m: impl Into<String>) -> Result<T, CdrError> {
    Err(CdrError(m.into()))
}

/// Reads a CDR payload, encapsulation header first.
pub struct Reader<'a> {
    data: &'a [u8],
    /// Position in `data` (the header included).
    pos: usize,
    little: bool,
}

const HEADER: usize = 4;

impl<'a> Reader<'a> {
    /// Checks the encapsulation header: plain CDR, either byte order (XCDR2 and parameter lists are
    /// not what ROS 2 publishes).
    pub fn new(data: &'a [u8]) -> Result<Self, CdrError> {
        if data.len() < HEADER {
            return err(format!(
                "{} bytes: shorter than the 4-byte CDR encapsulation header",
                data.len()
            ));
        }
        let little = match (data[0], data[1]) {
            (0, 1) => true,
            (0, 0) => false,
            (a, b) => {
                return err(format!(
                    "encapsulation {a:02x} {b:02x} is not plain CDR (00 01 little-endian or 00 00 big-endian)"
                ))
            }
        };
        Ok(Reader {
            data,
            pos: HEADER,
            little,
        })
    }

    fn align(&mut self, n: usize) {
        let off = self.pos - HEADER;
        self.pos += (n - off % n) % n;
    }

    fn take<const N: usize>(&mut self, what: &str) -> Result<[u8; N], CdrError> {
        self.align(N);
        let end = self.pos + N;
        match self.data.get(self.pos..end) {
            Some(b) => {
                self.pos = end;
                let mut a = [0u8; N];
                a.copy_from_slice(b);
                Ok(a)
            }
            None => err(format!(
                "truncated: {what} needs bytes {}..{end} of {}",
                self.pos,
                self.data.len()
            )),
        }
    }

    pub fn u8(&mut self, what: &str) -> Result<u8, CdrError> {
        Ok(self.take::<1>(what)?[0])
    }

    pub fn u32(&mut self, what: &str) -> Result<u32, CdrError> {
        let b = self.take::<4>(what)?;
        Ok(if self.little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    pub fn i32(&mut self, what: &str) -> Result<i32, CdrError> {
        Ok(self.u32(what)? as i32)
    }

    pub fn f64(&mut self, what: &str) -> Result<f64, CdrError> {
        let b = self.take::<8>(what)?;
        Ok(if self.little {
            f64::from_le_bytes(b)
        } else {
            f64::from_be_bytes(b)
        })
    }

    pub fn f64s<const N: usize>(&mut self, what: &str) -> Result<[f64; N], CdrError> {
        let mut a = [0.0; N];
        for x in a.iter_mut() {
            *x = self.f64(what)?;
        }
        Ok(a)
    }

    pub fn string(&mut self, what: &str) -> Result<String, CdrError> {
        let n = self.u32(what)? as usize;
        if n == 0 {
            // (A length of 0 is not CDR, which counts the NUL, but some writers send it for "".)
            return Ok(String::new());
        }
        if n > MAX_STRING + 1 {
            return err(format!(
                "{what}: a string of {n} bytes (at most {MAX_STRING})"
            ));
        }
        let end = self.pos + n;
        let Some(b) = self.data.get(self.pos..end) else {
            return err(format!(
                "truncated: {what} ({n} bytes) needs bytes {}..{end} of {}",
                self.pos,
                self.data.len()
            ));
        };
        let (text, nul) = b.split_at(n - 1);
        if nul != [0] {
            return err(format!("{what}: the string is not NUL-terminated"));
        }
        if text.contains(&0) {
            return err(format!("{what}: a NUL inside the string"));
        }
        let s = std::str::from_utf8(text)
            .map_err(|e| CdrError(format!("{what}: not UTF-8 ({e})")))?
            .to_string();
        self.pos = end;
        Ok(s)
    }

    /// The end of the message: at most the padding to the next 4- or 8-byte boundary may follow, as
    /// zeros (some writers pad the payload).
    pub fn finish(self) -> Result<(), CdrError> {
        let rest = &self.data[self.pos..];
        if rest.len() >= 8 || rest.iter().any(|b| *b != 0) {
            return err(format!("{} bytes after the end of the message", rest.len()));
        }
        Ok(())
    }
}

/// Writes little-endian plain CDR, encapsulation header first.
pub struct Writer {
    buf: Vec<u8>,
}

impl Default for Writer {
    fn default() -> Self {
        Self::new()
    }
}

impl Writer {
    pub fn new() -> Self {
        Writer::with_capacity(64)
    }

    pub fn with_capacity(n: usize) -> Self {
        let mut buf = Vec::with_capacity(n + HEADER);
        buf.extend_from_slice(&[0, 1, 0, 0]);
        Writer { buf }
    }

    fn align(&mut self, n: usize) {
        let off = self.buf.len() - HEADER;
        let pad = (n - off % n) % n;
        self.buf.resize(self.buf.len() + pad, 0);
    }

    pub fn u8(&mut self, v: u8) {
        self.buf.push(v);
    }

    pub fn u32(&mut self, v: u32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    pub fn i32(&mut self, v: i32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    pub fn f64(&mut self, v: f64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    pub fn f64s(&mut self, v: &[f64]) {
        for x in v {
            self.f64(*x);
        }
    }

    pub fn string(&mut self, s: &str) {
        self.u32(s.len() as u32 + 1);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
    }

    pub fn finish(self) -> Vec<u8> {
        self.buf
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alignment_counts_from_the_end_of_the_header() {
        let mut w = Writer::new();
        w.u8(7);
        w.f64(1.5);
        w.string("ab");
        w.f64(-2.0);
        let b = w.finish();
        // header, u8, 7 bytes of padding, f64, u32 len 3, "ab\0", pad to 8 (1 byte), f64
        assert_eq!(b.len(), 4 + 1 + 7 + 8 + 4 + 3 + 1 + 8);
        let mut r = Reader::new(&b).unwrap();
        assert_eq!(r.u8("a").unwrap(), 7);
        assert_eq!(r.f64("b").unwrap(), 1.5);
        assert_eq!(r.string("c").unwrap(), "ab");
        assert_eq!(r.f64("d").unwrap(), -2.0);
        r.finish().unwrap();
    }

    #[test]
    fn faults_are_errors_not_panics() {
        assert!(Reader::new(&[0, 1]).is_err());
        assert!(Reader::new(&[0, 7, 0, 0]).is_err());
        let mut r = Reader::new(&[0, 1, 0, 0, 5, 0, 0, 0, b'a']).unwrap();
        assert!(r.string("s").is_err());
        let mut r = Reader::new(&[0, 1, 0, 0, 255, 255, 255, 255]).unwrap();
        assert!(r.string("s").is_err());
        let mut r = Reader::new(&[0, 1, 0, 0, 1, 2, 3]).unwrap();
        assert!(r.f64("x").is_err());
        // Big-endian.
        let mut r = Reader::new(&[0, 0, 0, 0, 0, 0, 0, 9]).unwrap();
        assert_eq!(r.u32("n").unwrap(), 9);
    }
}
