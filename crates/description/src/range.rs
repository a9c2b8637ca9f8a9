//! The ranges of values the rig description's keys admit, one definition each for the
//! validator ([`crate::validate`]) and for the command-line flag that stands for the key.

/// The closed range of values a key admits, with its unit: one definition for the rig
/// description's validator and for the command-line flag that stands for the key, so that a
/// flag never takes a value its key refuses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    /// The least value admitted.
    pub min: f64,
    /// The greatest value admitted.
    pub max: f64,
    /// The unit, for messages ("" for a pure number).
    pub unit: &'static str,
}

impl Range {
    /// `[min, max]` in `unit`.
    pub const fn new(min: f64, max: f64, unit: &'static str) -> Self {
        Self { min, max, unit }
    }

    /// Whether `value` is finite and within the range.
    pub fn contains(&self, value: f64) -> bool {
        value.is_finite() && value >= self.min && value <= self.max
    }

    /// What is wrong with `value`, if anything: "must be between MIN and MAX UNIT, got VALUE".
    pub fn problem(&self, value: f64) -> Option<String> {
        (!self.contains(value)).then(|| {
            let unit = if self.unit.is_empty() {
                String::new()
            } else {
                format!(" {}", self.unit)
            };
            format!(
                "must be between {} and {}{unit}, got {}",
                self.min,
                self.max,
                number(value)
            )
        })
    }
}

/// `value` for a message: as written when that is short, else in exponent form (`1e-300`,
/// not three hundred zeros).
pub fn number(value: f64) -> String {
    let plain = value.to_string();
    if plain.len() <= 16 {
        plain
    } else {
        format!("{value:e}")
    }
}

/// The ranges of the keys that a command-line flag also sets, each named once.
pub mod ranges {
    use super::Range;

    /// `estimator.forgetting_factor` (`estimate --forgetting-factor`): below 0.9 the estimate
    /// forgets within ten samples and follows the noise; above 1 it grows without bound.
    pub const FORGETTING_FACTOR: Range = Range::new(0.9, 1.0, "");

    /// The least `estimator.cutoff_hz` (`estimate --cutoff-hz`, where 0 is no filter): a
    /// lower low-pass removes the excitation's own motion.
    pub const CUTOFF_HZ_MIN: f64 = 0.1;

    /// `estimator.cutoff_hz` at `sample_rate_hz`: from [`CUTOFF_HZ_MIN`] to 80 % of half the
    /// sample rate, where the low-pass's discrete design still holds.
    pub fn cutoff_hz(sample_rate_hz: f64) -> Range {
        Range::new(
            CUTOFF_HZ_MIN,
            sample_rate_hz / 2.0 * 0.8,
            "Hz (below 80 % of half the sample rate)",
        )
    }

    /// `run.duration_s` and `run.tare_duration_s` (`--duration`): ten hours at most.
    pub const RUN_DURATION_S: Range = Range::new(0.01, 36_000.0, "s");

    /// `rig.link_silence_ms` (`rig --link-silence-ms`).
    pub const LINK_SILENCE_MS: Range = Range::new(1.0, 10_000.0, "ms");

    /// `rig.watchdog_ms` (`emulate --watchdog-ms`).
    pub const WATCHDOG_MS: Range = Range::new(1.0, 10_000.0, "ms");

    /// `rig.handshake_timeout_s`.
    pub const HANDSHAKE_TIMEOUT_S: Range = Range::new(0.1, 600.0, "s");
}
