//! The `[rig]` table of the rig description: how the host reaches the rig (`stewart rig`) and
//! how the emulator listens (`stewart emulate`).

use std::fmt;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// Where `stewart rig` looks for the rig and `stewart emulate` listens, unless the
/// configuration's `rig.address` or `--connect`/`--listen` say otherwise.
pub const DEFAULT_ADDRESS: &str = "udp://127.0.0.1:7700";

/// The `[rig]` table of the scenario file: the link to the rig. Every key is optional.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RigLinkConfig {
    /// The rig's address: `udp://HOST:PORT` or `serial:///dev/DEVICE?baud=N`.
    pub address: String,
    /// File holding the shared key in hex (HMAC-SHA256 on every frame, docs/protocol.md
    /// section 3), relative to the scenario file; absent: the user's key file
    /// (`$XDG_CONFIG_HOME/stewart/rig.key`, else `~/.config/stewart/rig.key`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub key_file: Option<String>,
    /// The host faults when no valid sensor frame arrived for this long, ms.
    pub link_silence_ms: f64,
    /// The emulator brakes when no valid command arrived for this long, ms (a real rig sends
    /// its own in the handshake).
    pub watchdog_ms: f64,
    /// How long the host tries the handshake, s.
    pub handshake_timeout_s: f64,
    /// How many times the host repeats a run a stall ended (the link silent, or the rig's
    /// watchdog tripped: the rig braked), in a new session, a completed tare kept. An
    /// operating system can always stall a loop; a lost measurement costs a lab more than a
    /// repeated run. 0: a stall ends the measurement.
    pub stall_retries: u32,
}

/// The most runs a stall may repeat ([`RigLinkConfig::stall_retries`]): a rig that stalls more
/// often than this has a fault to find, not to ride out.
pub const MAX_STALL_RETRIES: u32 = 5;

impl Default for RigLinkConfig {
    fn default() -> Self {
        Self {
            address: DEFAULT_ADDRESS.into(),
            key_file: None,
            link_silence_ms: 50.0,
            watchdog_ms: 20.0,
            handshake_timeout_s: 2.0,
            stall_retries: 1,
        }
    }
}

/// Default baud rate of `serial://` addresses that do not give one.
pub const DEFAULT_BAUD: u32 = 921_600;

/// Why an address string is not a rig address.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("invalid rig address or option `{input}`: {reason}")]
pub struct AddressError {
    /// What was given.
    pub input: String,
    /// Why it is refused.
    pub reason: String,
}

/// A parsed rig address: `udp://HOST:PORT` or `serial:///dev/ttyUSB0?baud=921600`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Address {
    /// UDP: the resolved socket address.
    Udp(SocketAddr),
    /// Serial: device path and baud rate.
    Serial {
        /// Device path, e.g. `/dev/ttyUSB0`.
        path: String,
        /// Baud rate.
        baud: u32,
    },
}

impl FromStr for Address {
    type Err = AddressError;

    fn from_str(input: &str) -> Result<Self, AddressError> {
        let bad = |reason: &str| AddressError {
            input: input.to_string(),
            reason: reason.to_string(),
        };
        if let Some(rest) = input.strip_prefix("udp://") {
            let (host, port) = rest
                .rsplit_once(':')
                .ok_or_else(|| bad("expected udp://HOST:PORT (no port given)"))?;
            if host.is_empty() {
                return Err(bad("expected udp://HOST:PORT (no host given)"));
            }
            let port: u16 = port
                .parse()
                .map_err(|_| bad("the port must be a number from 0 to 65535"))?;
            let host = host.trim_start_matches('[').trim_end_matches(']');
            use std::net::ToSocketAddrs;
            let addrs: Vec<SocketAddr> = (host, port)
                .to_socket_addrs()
                .map_err(|e| bad(&format!("cannot resolve host `{host}`: {e}")))?
                .collect();
            // Prefer IPv4 when a name has both ("localhost"): emulators listen on 127.0.0.1 by
            // default, and a host aiming at ::1 would wait for an answer that never comes.
            let addr = addrs
                .iter()
                .find(|a| a.is_ipv4())
                .or(addrs.first())
                .copied()
                .ok_or_else(|| bad(&format!("host `{host}` has no address")))?;
            Ok(Address::Udp(addr))
        } else if let Some(rest) = input.strip_prefix("serial://") {
            let (path, query) = match rest.split_once('?') {
                Some((p, q)) => (p, Some(q)),
                None => (rest, None),
            };
            if path.is_empty() {
                return Err(bad(
                    "expected serial:///dev/DEVICE?baud=N (no device path given)",
                ));
            }
            let mut baud = DEFAULT_BAUD;
            for pair in query.into_iter().flat_map(|q| q.split('&')) {
                match pair.split_once('=') {
                    Some(("baud", value)) => {
                        baud = value
                            .parse()
                            .ok()
                            .filter(|&b: &u32| b > 0)
                            .ok_or_else(|| bad("baud must be a positive whole number"))?;
                    }
                    _ => {
                        return Err(bad(&format!(
                            "unknown serial option `{pair}` (only baud=N)"
                        )))
                    }
                }
            }
            Ok(Address::Serial {
                path: path.to_string(),
                baud,
            })
        } else {
            Err(bad(
                "expected udp://HOST:PORT or serial:///dev/DEVICE?baud=N",
            ))
        }
    }
}

impl fmt::Display for Address {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Address::Udp(addr) => write!(f, "udp://{addr}"),
            Address::Serial { path, baud } => write!(f, "serial://{path}?baud={baud}"),
        }
    }
}

impl RigLinkConfig {
    /// Range problems as (key, problem), like [`crate::validate::validate`].
    pub fn problems(&self) -> Vec<(String, String)> {
        use crate::range::ranges;
        let mut out = Vec::new();
        for (key, value, range) in [
            (
                "link_silence_ms",
                self.link_silence_ms,
                ranges::LINK_SILENCE_MS,
            ),
            ("watchdog_ms", self.watchdog_ms, ranges::WATCHDOG_MS),
            (
                "handshake_timeout_s",
                self.handshake_timeout_s,
                ranges::HANDSHAKE_TIMEOUT_S,
            ),
        ] {
            if let Some(problem) = range.problem(value) {
                out.push((format!("rig.{key}"), problem));
            }
        }
        if self.stall_retries > MAX_STALL_RETRIES {
            out.push((
                "rig.stall_retries".into(),
                format!(
                    "must be at most {MAX_STALL_RETRIES}, got {}: a rig that stalls that often \
                     has a fault to find (the loop's priority, the link)",
                    self.stall_retries
                ),
            ));
        }
        if let Err(e) = self.address.parse::<Address>() {
            out.push(("rig.address".into(), e.to_string()));
        }
        out
    }

    /// The key file, a relative path taken from `directory` (the rig description's, as
    /// [`crate::load::LoadedConfig::directory`] gives it).
    pub fn key_path(&self, directory: &Path) -> Option<PathBuf> {
        let file = Path::new(self.key_file.as_ref()?);
        if file.is_absolute() {
            return Some(file.to_path_buf());
        }
        Some(directory.join(file))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn link_config_defaults_and_ranges() {
        let c = RigLinkConfig::default();
        assert!(c.problems().is_empty());
        assert_eq!(c.address, DEFAULT_ADDRESS);
        let bad = RigLinkConfig {
            link_silence_ms: 0.0,
            address: "tcp://x:1".into(),
            ..RigLinkConfig::default()
        };
        let keys: Vec<String> = bad.problems().into_iter().map(|(k, _)| k).collect();
        assert_eq!(keys, ["rig.link_silence_ms", "rig.address"]);
    }

    #[test]
    fn key_files_are_found_next_to_the_scenario() {
        let c = RigLinkConfig {
            key_file: Some("rig.key".into()),
            ..RigLinkConfig::default()
        };
        assert_eq!(
            c.key_path(Path::new("configs")),
            Some(PathBuf::from("configs/rig.key"))
        );
        assert_eq!(c.key_path(Path::new("")), Some(PathBuf::from("rig.key")));
        let abs = RigLinkConfig {
            key_file: Some("/etc/rig.key".into()),
            ..RigLinkConfig::default()
        };
        assert_eq!(
            abs.key_path(Path::new("configs")),
            Some(PathBuf::from("/etc/rig.key"))
        );
        assert_eq!(RigLinkConfig::default().key_path(Path::new("x")), None);
    }
}
