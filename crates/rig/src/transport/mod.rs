//! Links that carry frames: UDP datagrams (primary) and COBS-framed serial byte streams, behind
//! one trait so that the host backend and the emulator do not care which.

use std::fmt;
use std::net::SocketAddr;
use std::str::FromStr;
use std::time::Duration;

use crate::error::RigError;

mod serial;
mod udp;

pub use serial::SerialTransport;
pub use udp::UdpTransport;

/// Default baud rate of `serial://` addresses that do not give one.
pub const DEFAULT_BAUD: u32 = 921_600;

/// Who a frame came from or goes to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Peer {
    /// A UDP socket address.
    Udp(SocketAddr),
    /// The other end of a serial line (there is only one).
    Serial,
}

impl fmt::Display for Peer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Peer::Udp(addr) => write!(f, "udp://{addr}"),
            Peer::Serial => write!(f, "serial peer"),
        }
    }
}

/// The outcome of waiting for a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Recv {
    /// A frame of `len` bytes is at the start of the buffer.
    Frame {
        /// Its length in bytes (may exceed the codec's maximum: the codec refuses it).
        len: usize,
        /// Its sender.
        from: Peer,
    },
    /// Nothing arrived in time.
    Timeout,
    /// Bytes arrived that do not form a frame (broken COBS, overlong); already discarded.
    Garbled,
}

/// A link that sends and receives whole frames.
pub trait Transport: Send {
    /// Sends one frame (codec output, not COBS-encoded) to `to`.
    fn send(&mut self, frame: &[u8], to: &Peer) -> Result<(), RigError>;

    /// Waits at most `timeout` for one frame and copies it into `buf`. A zero timeout polls.
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<Recv, RigError>;

    /// The local socket address, for UDP.
    fn local_addr(&self) -> Option<SocketAddr>;
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
    type Err = RigError;

    fn from_str(input: &str) -> Result<Self, RigError> {
        let bad = |reason: &str| RigError::config(input, reason);
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

/// Opens a link to the rig at `address`; returns it and the rig's peer identity.
pub fn open_client(address: &Address) -> Result<(Box<dyn Transport>, Peer), RigError> {
    match address {
        Address::Udp(addr) => Ok((Box::new(UdpTransport::client(*addr)?), Peer::Udp(*addr))),
        Address::Serial { path, baud } => {
            Ok((Box::new(SerialTransport::open(path, *baud)?), Peer::Serial))
        }
    }
}

/// Opens a link that waits for hosts at `address` (the emulator's side).
pub fn open_server(address: &Address) -> Result<Box<dyn Transport>, RigError> {
    match address {
        Address::Udp(addr) => Ok(Box::new(UdpTransport::bind(*addr)?)),
        Address::Serial { path, baud } => Ok(Box::new(SerialTransport::open(path, *baud)?)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_parse() {
        assert_eq!(
            "udp://127.0.0.1:9000".parse::<Address>().unwrap(),
            Address::Udp("127.0.0.1:9000".parse().unwrap())
        );
        assert_eq!(
            "udp://[::1]:9000".parse::<Address>().unwrap(),
            Address::Udp("[::1]:9000".parse().unwrap())
        );
        assert!(matches!(
            "udp://localhost:9000".parse::<Address>().unwrap(),
            Address::Udp(a) if a.ip().is_loopback() && a.port() == 9000
        ));
        assert_eq!(
            "serial:///dev/ttyUSB0?baud=115200"
                .parse::<Address>()
                .unwrap(),
            Address::Serial {
                path: "/dev/ttyUSB0".into(),
                baud: 115_200
            }
        );
        assert_eq!(
            "serial:///dev/ttyACM1".parse::<Address>().unwrap(),
            Address::Serial {
                path: "/dev/ttyACM1".into(),
                baud: DEFAULT_BAUD
            }
        );
    }

    #[test]
    fn bad_addresses_say_what_is_wrong() {
        for (input, words) in [
            ("127.0.0.1:9000", "expected udp://"),
            ("udp://127.0.0.1", "no port"),
            ("udp://:9000", "no host"),
            ("udp://127.0.0.1:99999", "port must be"),
            ("serial://?baud=9600", "no device"),
            ("serial:///dev/ttyUSB0?baud=fast", "baud must be"),
            ("serial:///dev/ttyUSB0?parity=even", "unknown serial option"),
        ] {
            let err = input.parse::<Address>().unwrap_err().to_string();
            assert!(err.contains(words), "{input}: {err}");
            assert!(err.contains(input), "{input}: {err}");
        }
    }
}
