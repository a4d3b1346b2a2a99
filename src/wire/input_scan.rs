//! The inputs' fast path: a strict reader of the shape nearly every `P/V/gyro`, `P/V/vectors` and
//! `P/V/imu` payload has (one object or an array of them, known fields once each, numbers, strings
//! without escapes), straight into the messages without serde's visitors.
//!
//! It gives up (`None`) on anything it does not read exactly as serde would: an escape in a string, a
//! `null`, an unknown, missing or repeated field, a number out of range, text that is not JSON, an
//! empty batch or one over its limit. [`super::decode_batch_into`] then reads the payload again with
//! serde from the start, so what is accepted is the same value either way (the property test in
//! `wire/mod.rs` compares them) and every fault is told in serde's words.

use super::{GyroMsg, ImuMsg, ObservationMsg, VectorsMsg};

/// A message the fast path can read.
pub trait Scanned: Sized {
    /// Reads one message, a JSON object, at the cursor; `None`: not read here.
    fn scan(s: &mut Scan) -> Option<Self>;
}

/// A cursor over a payload's text.
pub struct Scan<'a> {
    text: &'a str,
    i: usize,
}

impl<'a> Scan<'a> {
    fn byte(&self) -> Option<u8> {
        self.text.as_bytes().get(self.i).copied()
    }

    /// The next byte after JSON whitespace, not taken.
    fn peek(&mut self) -> Option<u8> {
        while let Some(c) = self.byte() {
            if !matches!(c, b' ' | b'\t' | b'\n' | b'\r') {
                return Some(c);
            }
            self.i += 1;
        }
        None
    }

    fn eat(&mut self, c: u8) -> Option<()> {
        (self.peek()? == c).then(|| self.i += 1)
    }

    /// A string without escapes or control characters (JSON forbids the latter unescaped).
    fn string(&mut self) -> Option<&'a str> {
        self.eat(b'"')?;
        let start = self.i;
        loop {
            match self.byte()? {
                b'"' => break,
                b'\\' => return None,
                c if c < 0x20 => return None,
                _ => self.i += 1,
            }
        }
        // (Between two ASCII quotes of a `str`: a slice on character boundaries.)
        let s = &self.text[start..self.i];
        self.i += 1;
        Some(s)
    }

    /// A JSON number, to the nearest `f64` (what serde_json with `float_roundtrip` reads, integers
    /// included); `None` when it is not finite (serde_json: out of range).
    ///
    /// Read once: where the digits make an integer `m ≤ 2^53` and the power of ten `|e| ≤ 22`, both
    /// are exact in `f64` and one multiplication or division rounds correctly (Clinger's fast path,
    /// which the standard library takes as well); other numbers (longer mantissas, most of a double's
    /// 17-digit shortest forms) go to the standard library's parser.
    fn number(&mut self) -> Option<f64> {
        const EXACT: u64 = 1 << 53;
        const POW10: [f64; 23] = [
            1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
            1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
        ];
        self.peek()?;
        let b = self.text.as_bytes();
        let start = self.i;
        let negative = b[start] == b'-';
        let mut i = start + usize::from(negative);
        // The digits (integer and fraction) as one integer `m`, `k` of them in all (up to 19 cannot
        // overflow; beyond, `m` is not used). Eight at a time where eight are there: a double's
        // shortest form has up to 17, and one by one they were most of the reading's work.
        let (mut m, mut k) = (0u64, 0usize);
        let mut digits = |i: &mut usize| {
            let from = *i;
            while let Some(v) = b
                .get(*i..*i + 8)
                .map(|c| u64::from_le_bytes(c.try_into().expect("8 bytes")))
                .filter(|&v| eight_digits(v))
            {
                m = m
                    .wrapping_mul(100_000_000)
                    .wrapping_add(eight_digits_value(v));
                *i += 8;
            }
            while let Some(d) = b.get(*i).map(|c| c.wrapping_sub(b'0')).filter(|&d| d <= 9) {
                m = m.wrapping_mul(10).wrapping_add(u64::from(d));
                *i += 1;
            }
            k += *i - from;
            *i - from
        };
        match b.get(i)? {
            b'0' => i += 1,
            b'1'..=b'9' => {
                digits(&mut i);
            }
            _ => return None,
        }
        let mut e = 0i64;
        if b.get(i) == Some(&b'.') {
            i += 1;
            match digits(&mut i) {
                0 => return None,
                k => e = -(k as i64),
            }
        }
        if matches!(b.get(i), Some(b'e' | b'E')) {
            i += 1;
            let minus = b.get(i) == Some(&b'-');
            if matches!(b.get(i), Some(b'+' | b'-')) {
                i += 1;
            }
            let from = i;
            let mut x = 0i64;
            while let Some(d) = b.get(i).map(|c| c.wrapping_sub(b'0')).filter(|&d| d <= 9) {
                // (Held below any exponent a finite double can have with any mantissa.)
                x = (x * 10 + i64::from(d)).min(1 << 30);
                i += 1;
            }
            if i == from {
                return None;
            }
            e += if minus { -x } else { x };
        }
        self.i = i;
        if k <= 19 && m <= EXACT && e.unsigned_abs() < POW10.len() as u64 {
            let p = POW10[e.unsigned_abs() as usize];
            let x = if e < 0 { m as f64 / p } else { m as f64 * p };
            return Some(if negative { -x } else { x });
        }
        let x: f64 = self.text[start..i].parse().ok()?;
        x.is_finite().then_some(x)
    }

    fn vec3(&mut self) -> Option<[f64; 3]> {
        self.eat(b'[')?;
        let x = self.number()?;
        self.eat(b',')?;
        let y = self.number()?;
        self.eat(b',')?;
        let z = self.number()?;
        self.eat(b']')?;
        Some([x, y, z])
    }

    /// An object: `field` reads the value of each key (its index in `keys`), each key at most once.
    fn object(
        &mut self,
        keys: &[&str],
        mut field: impl FnMut(&mut Self, usize) -> Option<()>,
    ) -> Option<()> {
        self.eat(b'{')?;
        if self.peek()? == b'}' {
            self.i += 1;
            return Some(());
        }
        let mut seen = 0u32;
        loop {
            let key = self.string()?;
            let k = keys.iter().position(|&n| n == key)?;
            if seen & (1 << k) != 0 {
                return None;
            }
            seen |= 1 << k;
            self.eat(b':')?;
            field(self, k)?;
            match self.peek()? {
                b',' => self.i += 1,
                b'}' => {
                    self.i += 1;
                    return Some(());
                }
                _ => return None,
            }
        }
    }
}

impl Scan<'_> {
    /// An array: `item` reads each element at the cursor; how many.
    fn array(&mut self, mut item: impl FnMut(&mut Self) -> Option<()>) -> Option<usize> {
        self.eat(b'[')?;
        if self.peek()? == b']' {
            self.i += 1;
            return Some(0);
        }
        let mut n = 0;
        loop {
            item(self)?;
            n += 1;
            match self.peek()? {
                b',' => self.i += 1,
                b']' => {
                    self.i += 1;
                    return Some(n);
                }
                _ => return None,
            }
        }
    }
}

/// The fast path of [`super::decode_batch_into`]: the payload's messages, one object or a non-empty
/// array of at most `max_batch`, each handed to `each` with its index as it is read; their count, or
/// `None` (then `each` may have been handed some: the caller discards them).
pub fn scan_batch<T: Scanned>(
    text: &str,
    max_batch: usize,
    each: &mut dyn FnMut(usize, T),
) -> Option<usize> {
    let mut s = Scan { text, i: 0 };
    let n = match s.peek()? {
        b'{' => {
            each(0, T::scan(&mut s)?);
            1
        }
        b'[' => {
            let mut n = 0;
            let read = s.array(|s| {
                // (More than max_batch, or none: serde's to refuse.)
                (n < max_batch).then_some(())?;
                each(n, T::scan(s)?);
                n += 1;
                Some(())
            })?;
            (read > 0).then_some(read)?
        }
        _ => return None,
    };
    (s.peek().is_none()).then_some(n)
}

impl Scanned for GyroMsg {
    fn scan(s: &mut Scan) -> Option<Self> {
        let (mut t, mut omega) = (None, None);
        s.object(&["t", "omega"], |s, k| {
            match k {
                0 => t = Some(s.number()?),
                _ => omega = Some(s.vec3()?),
            }
            Some(())
        })?;
        Some(GyroMsg {
            t: t?,
            omega: omega?,
        })
    }
}

impl Scanned for ImuMsg {
    fn scan(s: &mut Scan) -> Option<Self> {
        let (mut t, mut gyr, mut acc, mut mag) = (None, None, None, None);
        s.object(&["t", "gyr", "acc", "mag"], |s, k| {
            match k {
                0 => t = Some(s.number()?),
                1 => gyr = Some(s.vec3()?),
                2 => acc = Some(s.vec3()?),
                _ => mag = Some(s.vec3()?),
            }
            Some(())
        })?;
        Some(ImuMsg {
            t: t?,
            gyr: gyr?,
            acc: acc?,
            mag,
        })
    }
}

impl Scanned for ObservationMsg {
    fn scan(s: &mut Scan) -> Option<Self> {
        let (mut body, mut reference, mut sigma, mut sensor) = (None, None, None, None);
        s.object(&["body", "ref", "sigma", "sensor"], |s, k| {
            match k {
                0 => body = Some(s.vec3()?),
                1 => reference = Some(s.vec3()?),
                2 => sigma = Some(s.number()?),
                _ => sensor = Some(s.string()?.to_owned()),
            }
            Some(())
        })?;
        Some(ObservationMsg {
            body: body?,
            reference: reference?,
            sigma: sigma?,
            sensor,
        })
    }
}

impl Scanned for VectorsMsg {
    fn scan(s: &mut Scan) -> Option<Self> {
        let (mut t, mut obs) = (None, None);
        s.object(&["t", "obs"], |s, k| {
            match k {
                0 => t = Some(s.number()?),
                _ => {
                    let mut items = Vec::new();
                    s.array(|s| Some(items.push(ObservationMsg::scan(s)?)))?;
                    obs = Some(items);
                }
            }
            Some(())
        })?;
        Some(VectorsMsg { t: t?, obs: obs? })
    }
}

/// Whether the eight bytes of `v` (little-endian) are all ASCII digits.
fn eight_digits(v: u64) -> bool {
    // A byte is a digit when its high nibble is 3 and adding 6 leaves it 3 (no carry past 9).
    (v & 0xF0F0_F0F0_F0F0_F0F0)
        | ((v.wrapping_add(0x0606_0606_0606_0606) & 0xF0F0_F0F0_F0F0_F0F0) >> 4)
        == 0x3333_3333_3333_3333
}

/// The value of eight ASCII digits (the first byte in memory the most significant), by three
/// multiplications: pairs, then fours, then the eight.
fn eight_digits_value(v: u64) -> u64 {
    const MASK: u64 = 0x0000_00FF_0000_00FF;
    const MUL1: u64 = 100 + (1_000_000 << 32);
    const MUL2: u64 = 1 + (10_000 << 32);
    let v = v.wrapping_sub(0x3030_3030_3030_3030);
    let v = v.wrapping_mul(10).wrapping_add(v >> 8);
    ((v & MASK)
        .wrapping_mul(MUL1)
        .wrapping_add(((v >> 16) & MASK).wrapping_mul(MUL2)))
        >> 32
}

#[cfg(test)]
mod tests {
    use super::super::input::decode_batch_via;
    use super::*;
    use crate::wire::InputLimits;
    use proptest::prelude::*;
    use serde::de::DeserializeOwned;
    use std::fmt::Debug;

    /// The payload through both readers (the fast path with serde behind it, serde alone): the same
    /// messages or the same rejection, to the bit (`Debug` tells `-0.0` from `0.0`).
    fn both<T: DeserializeOwned + Scanned + Debug>(
        p: &str,
        limits: &InputLimits,
    ) -> (String, String) {
        let run = |fast| {
            let mut v: Vec<T> = vec![];
            format!(
                "{:?}",
                decode_batch_via(p.as_bytes(), limits, Ok, &mut v, fast).map(|_| v)
            )
        };
        (run(true), run(false))
    }

    /// Whether the fast path reads it (alone).
    fn scanned<T: Scanned>(p: &str) -> bool {
        scan_batch::<T>(p, 100, &mut |_, _| {}).is_some()
    }

    /// What senders write (serde_json, Python's `json.dumps`, by hand): all read by the fast path,
    /// as serde reads them.
    #[test]
    fn the_usual_shapes_take_the_fast_path() {
        let gyro = [
            r#"{"t":12.5,"omega":[0.001,-0.002,0.0005]}"#,
            r#"{"t": 12.5, "omega": [1e-3, -2E-3, 5e+0]}"#,
            "[{\"omega\": [0, -0, 0.0],\n \"t\": 1}, {\"t\": 1.0000000000000002, \"omega\": [1.7976931348623157e308, 5e-324, 123456789012345678901234567890]}]\r\n",
        ];
        let imu = [
            r#"{"t":0.0035,"gyr":[0.01,0.02,-0.03],"acc":[0.1,-0.2,9.81],"mag":[12.5,-3.25,40]}"#,
            r#"{"t": 0.0035, "gyr": [0.01, 0.02, -0.03], "acc": [0.1, -0.2, 9.81]}"#,
        ];
        let vectors = [
            r#"{"t":1.5,"obs":[{"body":[0.1,0.2,0.97],"ref":[0,0,1],"sigma":2.9e-5,"sensor":"st1"},{"sigma":0.01,"ref":[1,0,0],"body":[0.9,0.1,0.1]}]}"#,
            r#"{"obs": [], "t": 2}"#,
            r#"{"t": 2, "obs": [{"body": [1, 0, 0], "ref": [1, 0, 0], "sigma": 1, "sensor": "ünïcode ⊗"}]}"#,
        ];
        let limits = InputLimits::default();
        for p in gyro {
            assert!(scanned::<GyroMsg>(p), "{p}");
            let (fast, slow) = both::<GyroMsg>(p, &limits);
            assert_eq!(fast, slow, "{p}");
            assert!(fast.starts_with("Ok("), "{fast}");
        }
        for p in imu {
            assert!(scanned::<ImuMsg>(p), "{p}");
            let (fast, slow) = both::<ImuMsg>(p, &limits);
            assert_eq!(fast, slow, "{p}");
        }
        for p in vectors {
            assert!(scanned::<VectorsMsg>(p), "{p}");
            let (fast, slow) = both::<VectorsMsg>(p, &limits);
            assert_eq!(fast, slow, "{p}");
        }
    }

    /// What it leaves to serde, each for its reason.
    #[test]
    fn what_it_leaves_to_serde() {
        for p in [
            r#"{"t": 1, "omega": [0, 0, 0], "t": 2}"#, // a repeated field
            r#"{"t": 1, "omega": [0, 0, 0], "x": 2}"#, // an unknown one
            r#"{"t": 1}"#,                             // a missing one
            r#"{"t": null, "omega": [0, 0, 0]}"#,      // null
            r#"{"t": 1e400, "omega": [0, 0, 0]}"#,     // out of range
            r#"{"t": 01, "omega": [0, 0, 0]}"#,        // not a JSON number
            r#"{"t": 1., "omega": [0, 0, 0]}"#,
            r#"{"t": -, "omega": [0, 0, 0]}"#,
            r#"{"t": 1, "omega": [0, 0, 0, 0]}"#, // a fourth element
            r#"{"t": 1, "omega": [0, 0, 0],}"#,   // a trailing comma
            r#"{"\u0074": 1, "omega": [0, 0, 0]}"#, // an escape
            r#"[]"#,                              // an empty batch
            r#"[{"t": 1, "omega": [0, 0, 0]}] x"#, // text after the value
            r#"[[1, [0, 0, 0]]]"#,                // an array for an object
            "\u{feff}{\"t\": 1, \"omega\": [0, 0, 0]}", // a byte-order mark
        ] {
            assert!(!scanned::<GyroMsg>(p), "{p}");
        }
        assert!(!scanned::<VectorsMsg>(
            r#"{"t": 1, "obs": [{"body": [1, 0, 0], "ref": [1, 0, 0], "sigma": 1, "sensor": "a\"b"}]}"#
        ));
        let two = r#"[{"t": 1, "omega": [0, 0, 0]}, {"t": 2, "omega": [0, 0, 0]}]"#;
        assert!(scan_batch::<GyroMsg>(two, 2, &mut |_, _| {}).is_some());
        assert!(scan_batch::<GyroMsg>(two, 1, &mut |_, _| {}).is_none());
    }

    #[test]
    fn eight_digits_are_recognised_and_read_as_one_by_one() {
        // Each position, every byte value, the other seven digits: a digit only for b'0'..=b'9'.
        for pos in 0..8 {
            for byte in 0..=255u8 {
                let mut c = *b"31415926";
                c[pos] = byte;
                let v = u64::from_le_bytes(c);
                assert_eq!(eight_digits(v), byte.is_ascii_digit(), "{c:?}");
            }
        }
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..100_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let text = format!("{:08}", x % 100_000_000);
            let v = u64::from_le_bytes(text.as_bytes().try_into().unwrap());
            assert_eq!(
                eight_digits_value(v),
                text.parse::<u64>().unwrap(),
                "{text}"
            );
        }
        for text in ["00000000", "99999999", "10000000", "00000001"] {
            let v = u64::from_le_bytes(text.as_bytes().try_into().unwrap());
            assert_eq!(
                eight_digits_value(v),
                text.parse::<u64>().unwrap(),
                "{text}"
            );
        }
    }

    /// A JSON number, or something near one.
    fn number() -> impl Strategy<Value = String> {
        prop_oneof![
            4 => any::<f64>()
                .prop_filter("finite", |x| x.is_finite())
                .prop_map(|x| serde_json::to_string(&x).unwrap()),
            2 => any::<f64>().prop_map(|x| format!("{x:e}")),
            2 => (-1e6..1e6f64).prop_map(|x| format!("{x:.25}")),
            2 => any::<i64>().prop_map(|x| x.to_string()),
            1 => any::<u64>().prop_map(|x| format!("{x}{x}")),
            4 => ("-?[0-9]{1,40}(\\.[0-9]{1,40})?([eE][+-]?[0-9]{1,3})?").prop_map(|s| s),
            1 => prop::sample::select(vec!["-0", "2.2250738585072011e-308", "9007199254740993", "4.9e-324"])
                .prop_map(str::to_owned),
            1 => prop::sample::select(vec!["01", "1.", ".5", "+1", "NaN", "null", "-", "1e", "1e999", "\"1\"", "true"])
                .prop_map(str::to_owned),
        ]
    }

    fn ws() -> impl Strategy<Value = String> {
        prop::sample::select(vec!["", "", "", " ", "\n  ", "\t", "\r\n"]).prop_map(str::to_owned)
    }

    fn vec3() -> impl Strategy<Value = String> {
        (proptest::collection::vec(number(), 2..=4), ws())
            .prop_map(|(n, w)| format!("[{w}{}{w}]", n.join(&format!("{w},{w}"))))
    }

    /// An object of some of `fields` (name, value), in any order, one perhaps repeated, perhaps an
    /// unknown one.
    fn object(fields: Vec<(&'static str, BoxedStrategy<String>)>) -> impl Strategy<Value = String> {
        let n = fields.len();
        let values: Vec<_> = fields
            .into_iter()
            .map(|(k, v)| (Just(k), v, prop::bool::weighted(0.9)))
            .collect();
        (
            values,
            Just((0..n).collect::<Vec<usize>>()).prop_shuffle(),
            prop::bool::weighted(0.05),
            prop::bool::weighted(0.05),
            ws(),
        )
            .prop_map(|(values, order, repeat, unknown, w)| {
                let mut parts: Vec<String> = order
                    .iter()
                    .filter(|&&i| values[i].2)
                    .map(|&i| format!("\"{}\"{w}:{w}{}", values[i].0, values[i].1))
                    .collect();
                if repeat && !parts.is_empty() {
                    parts.push(parts[0].clone());
                }
                if unknown {
                    parts.push("\"extra\": 1".to_owned());
                }
                format!("{{{w}{}{w}}}", parts.join(&format!(",{w}")))
            })
    }

    fn sensor() -> BoxedStrategy<String> {
        prop_oneof![
            "[a-z0-9_]{0,8}".prop_map(|s| format!("\"{s}\"")),
            Just("\"ünï ⊗\"".to_owned()),
            Just("\"a\\\"b\"".to_owned()),
            Just("\"a\u{1}b\"".to_owned()),
            Just("null".to_owned()),
            "[a]{65,70}".prop_map(|s| format!("\"{s}\"")),
        ]
        .boxed()
    }

    /// One item or a batch of them, sometimes cut short.
    fn payload(item: BoxedStrategy<String>) -> impl Strategy<Value = (String, usize)> {
        (
            proptest::collection::vec(item, 1..4),
            any::<bool>(),
            ws(),
            0..5usize,
            prop::option::weighted(0.05, any::<prop::sample::Index>()),
        )
            .prop_map(|(items, array, w, max_batch, cut)| {
                let mut p = match array {
                    false => items[0].clone(),
                    true => format!("{w}[{}]{w}", items.join(&format!("{w},"))),
                };
                if let Some(c) = cut {
                    let mut at = c.index(p.len());
                    while !p.is_char_boundary(at) {
                        at -= 1;
                    }
                    p.truncate(at);
                }
                (p, max_batch.max(1))
            })
    }

    fn gyro() -> BoxedStrategy<String> {
        object(vec![("t", number().boxed()), ("omega", vec3().boxed())]).boxed()
    }

    fn imu() -> BoxedStrategy<String> {
        object(vec![
            ("t", number().boxed()),
            ("gyr", vec3().boxed()),
            ("acc", vec3().boxed()),
            ("mag", vec3().boxed()),
        ])
        .boxed()
    }

    fn vectors() -> BoxedStrategy<String> {
        let obs = object(vec![
            ("body", vec3().boxed()),
            ("ref", vec3().boxed()),
            ("sigma", number().boxed()),
            ("sensor", sensor()),
        ]);
        let list = proptest::collection::vec(obs, 0..3).prop_map(|o| format!("[{}]", o.join(", ")));
        object(vec![("t", number().boxed()), ("obs", list.boxed())]).boxed()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(3000))]
        /// Any payload, well formed or not: what the fast path reads is what serde reads.
        #[test]
        fn any_payload_reads_as_serde_reads_it(
            (g, gb) in payload(gyro()),
            (i, ib) in payload(imu()),
            (v, vb) in payload(vectors()),
        ) {
            let limits = |max_batch| InputLimits { max_batch, ..InputLimits::default() };
            let (fast, slow) = both::<GyroMsg>(&g, &limits(gb));
            prop_assert_eq!(fast, slow, "{}", g);
            let (fast, slow) = both::<ImuMsg>(&i, &limits(ib));
            prop_assert_eq!(fast, slow, "{}", i);
            let (fast, slow) = both::<VectorsMsg>(&v, &limits(vb));
            prop_assert_eq!(fast, slow, "{}", v);
            // Into domain values, where the conversion refuses items too.
            let conv = |p: &str, fast| {
                let mut out = vec![];
                let l = limits(4);
                format!("{:?}", decode_batch_via(p.as_bytes(), &l, |m: VectorsMsg| m.to_domain(&l), &mut out, fast).map(|_| out))
            };
            prop_assert_eq!(conv(&v, true), conv(&v, false));
        }
    }
}
