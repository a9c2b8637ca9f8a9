//! What a [`RigCore`](super::RigCore) presents and enforces, and the key it holds.

use core::fmt;

use sha2::{Digest, Sha256};

use crate::codec::{key_id, MIN_KEY_LEN};
use crate::wire::{Limits, SensorLayout, IDENTITY_LEN};

/// Longest key a [`CoreKey`] stores as given, bytes: one HMAC-SHA256 block. HMAC hashes a
/// longer key with SHA-256 before use, so a longer key is stored as its digest, which tags
/// every frame exactly as the long key does.
pub const KEY_BLOCK_LEN: usize = 64;

/// Largest [`CoreConfig::speed_window`], samples (the window is a fixed ring, no heap).
pub const MAX_SPEED_WINDOW: usize = 32;

/// A shared key held by value (no heap), with its fingerprint.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct CoreKey {
    bytes: [u8; KEY_BLOCK_LEN],
    len: usize,
    id: u32,
}

impl CoreKey {
    /// The key `bytes` (at least [`MIN_KEY_LEN`]). Keys longer than [`KEY_BLOCK_LEN`] are kept
    /// as SHA-256(key), as HMAC itself reduces them: HMAC(K, m) = HMAC(SHA-256(K), m) for
    /// |K| > 64. The fingerprint is `codec::key_id` of the key as given.
    pub fn new(bytes: &[u8]) -> Result<Self, ConfigError> {
        if bytes.len() < MIN_KEY_LEN {
            return Err(ConfigError::KeyTooShort(bytes.len()));
        }
        let mut stored = [0u8; KEY_BLOCK_LEN];
        let len = if let Some(slot) = stored.get_mut(..bytes.len()) {
            slot.copy_from_slice(bytes);
            bytes.len()
        } else {
            let digest = Sha256::digest(bytes);
            let n = digest.len();
            if let Some(slot) = stored.get_mut(..n) {
                slot.copy_from_slice(&digest);
            }
            n
        };
        Ok(Self {
            bytes: stored,
            len,
            id: key_id(bytes),
        })
    }

    /// The bytes HMAC is keyed with.
    pub fn bytes(&self) -> &[u8] {
        self.bytes.get(..self.len).unwrap_or(&[])
    }

    /// The fingerprint a host names in its `Hello` (`codec::key_id`).
    pub fn id(&self) -> u32 {
        self.id
    }
}

impl fmt::Debug for CoreKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "CoreKey({:08x})", self.id)
    }
}

/// How a rig core presents itself in the handshake and what it enforces. Times are integer
/// nanoseconds on the caller's clock.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoreConfig {
    /// Identity sent in the `HelloAck` (UTF-8, zero padded; `wire::identity_from_str`).
    pub identity: [u8; IDENTITY_LEN],
    /// Sensor layout sent in the `HelloAck`.
    pub layout: SensorLayout,
    /// Hard limits: sent in the `HelloAck` and enforced.
    pub limits: Limits,
    /// Time between ticks, ns: announced in the `HelloAck` and the time base of the leg-speed
    /// estimate.
    pub sample_period_ns: u64,
    /// Brake when no valid command arrived for longer than this, ns (20 ms on the emulator).
    pub watchdog_ns: u64,
    /// End a session whose host has been silent for longer than this, ns, so that another
    /// host may connect.
    pub session_timeout_ns: u64,
    /// Shared key: accept only frames tagged with it, tag every frame sent.
    pub key: Option<CoreKey>,
    /// Brake on sensed stroke and speed violations while the actuators are driven.
    pub enforce_motion_limits: bool,
    /// Leg speed is the length change over this many samples (0 counts as 1), at most
    /// [`MAX_SPEED_WINDOW`], so that sensor noise does not trip the speed limit.
    pub speed_window: usize,
    /// Seed of the session numbers. Session numbers from one seed never repeat (a bijective
    /// generator), so a firmware must seed from a hardware random source or a counter kept
    /// across resets: a repeated session number lets frames of an old session replay into a
    /// new one.
    pub seed: u64,
}

/// A [`CoreConfig`] the rig core cannot run with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConfigError {
    /// The sample period is zero or does not fit the `HelloAck`'s `u32` nanoseconds.
    SamplePeriod(u64),
    /// Limits with an empty stroke or force range or a non-positive speed (or NaN).
    Limits(Limits),
    /// A speed window beyond [`MAX_SPEED_WINDOW`].
    SpeedWindow(usize),
    /// A key shorter than [`MIN_KEY_LEN`] bytes (its length is given).
    KeyTooShort(usize),
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ConfigError::SamplePeriod(ns) => write!(
                f,
                "sample period {ns} ns: must be positive and below {} ns",
                u32::MAX
            ),
            ConfigError::Limits(l) => write!(f, "unusable limits {l:?}"),
            ConfigError::SpeedWindow(n) => {
                write!(f, "speed window of {n} samples: at most {MAX_SPEED_WINDOW}")
            }
            ConfigError::KeyTooShort(n) => {
                write!(f, "a key needs at least {MIN_KEY_LEN} bytes, got {n}")
            }
        }
    }
}

impl CoreConfig {
    /// Checks the configuration (see [`ConfigError`]).
    pub fn check(&self) -> Result<(), ConfigError> {
        if self.sample_period_ns == 0 || self.sample_period_ns > u64::from(u32::MAX) {
            return Err(ConfigError::SamplePeriod(self.sample_period_ns));
        }
        let l = self.limits;
        if !(l.stroke_min_m < l.stroke_max_m
            && l.force_min_n < l.force_max_n
            && l.speed_max_m_s > 0.0)
        {
            return Err(ConfigError::Limits(l));
        }
        if self.speed_window > MAX_SPEED_WINDOW {
            return Err(ConfigError::SpeedWindow(self.speed_window));
        }
        Ok(())
    }
}
