//! The gains of the pipeline's first-order low-passes and of the hard-iron fit's forgetting, which
//! depend on a sample's interval alone: an `exp` each, five per sample, for intervals that take a
//! handful of values (a recording's time stamps `k/f` give some twenty distinct differences, most of
//! them rare). [`GainCache`] remembers them by the interval's exact bits, so a gain reused is the
//! very value computed: the cache changes no result and is no state (a checkpoint does not hold it; a
//! restored pipeline computes the same values afresh).

use super::AhrsConfig;
use crate::sensors::field::FieldGains;
use crate::sensors::lowpass::gain;

/// Every interval-dependent gain of one sample (see [`IntervalGains::new`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IntervalGains {
    /// `1 − e^{−Δt/τ}` for the gravity channel's levels (`acc.lowpass_s`).
    pub acc: Option<f64>,
    pub field: FieldGains,
}

impl IntervalGains {
    /// The gains over `dt_s ≥ 0`.
    pub fn new(c: &AhrsConfig, dt_s: f64) -> Self {
        IntervalGains {
            acc: gain(dt_s, c.acc.lowpass_s),
            field: FieldGains::new(&c.mag, dt_s),
        }
    }
}

/// Slots of the cache (direct-mapped by a hash of the interval's bits). Eight hold every frequent
/// interval of BROAD's recordings (99.96 % hits).
const SLOTS: usize = 8;
/// An interval's bits no interval has: a NaN (intervals are `max(t − t₀, 0)` of finite times).
const EMPTY: u64 = 0x7ff8_0000_0000_0000;

/// [`IntervalGains`] by the interval's exact bits, for the time constants of one configuration.
#[derive(Clone, Debug)]
pub struct GainCache {
    /// The time constants the slots were computed with (bits): another configuration empties them.
    taus: [u64; 5],
    keys: [u64; SLOTS],
    gains: [IntervalGains; SLOTS],
}

/// (Not state: every cache is equal.)
impl PartialEq for GainCache {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl Default for GainCache {
    fn default() -> Self {
        GainCache {
            taus: [EMPTY; 5],
            keys: [EMPTY; SLOTS],
            gains: [IntervalGains {
                acc: None,
                field: FieldGains {
                    lowpass: None,
                    reference: None,
                    fit_recent: None,
                    fit_forget: 1.0,
                },
            }; SLOTS],
        }
    }
}

fn taus(c: &AhrsConfig) -> [u64; 5] {
    [
        c.acc.lowpass_s.to_bits(),
        c.mag.lowpass_s.to_bits(),
        c.mag.reference_s.to_bits(),
        c.mag.hard_iron.recent_s.to_bits(),
        c.mag.hard_iron.window_s.to_bits(),
    ]
}

impl GainCache {
    /// The gains of `c` over `dt_s ≥ 0`: the same bits as [`IntervalGains::new`].
    #[inline]
    pub fn get(&mut self, c: &AhrsConfig, dt_s: f64) -> IntervalGains {
        let taus = taus(c);
        if taus != self.taus {
            *self = GainCache::default();
            self.taus = taus;
        }
        let key = dt_s.to_bits();
        let slot = (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 61) as usize;
        if self.keys[slot] != key {
            self.keys[slot] = key;
            self.gains[slot] = IntervalGains::new(c, dt_s);
        }
        self.gains[slot]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A gain from the cache is the gain computed, bit for bit, for every interval and after a
    /// change of configuration.
    #[test]
    fn the_cache_gives_the_computed_bits() {
        let mut c = AhrsConfig::default();
        let mut cache = GainCache::default();
        let dts: Vec<f64> = (0..200)
            .map(|k| (k as f64 + 1.0) / 285.714 - k as f64 / 285.714)
            .chain([0.0, 0.01, 1e-300, 3.5])
            .collect();
        for round in 0..3 {
            if round == 2 {
                c.mag.reference_s *= 2.0;
            }
            for &dt in &dts {
                let got = cache.get(&c, dt);
                let want = IntervalGains::new(&c, dt);
                let bits = |g: &IntervalGains| {
                    [
                        g.acc.map(f64::to_bits),
                        g.field.lowpass.map(f64::to_bits),
                        g.field.reference.map(f64::to_bits),
                        g.field.fit_recent.map(f64::to_bits),
                        Some(g.field.fit_forget.to_bits()),
                    ]
                };
                assert_eq!(bits(&got), bits(&want), "dt = {dt:e}");
            }
        }
    }
}
