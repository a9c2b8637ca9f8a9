//! Links that carry frames: UDP datagrams (primary) and COBS-framed serial byte streams, behind
//! one trait so that the host backend and the emulator do not care which.

use std::fmt;
use std::net::SocketAddr;
use std::time::Duration;

use crate::error::RigError;

mod serial;
mod udp;

pub use serial::SerialTransport;
pub use udp::UdpTransport;

pub use rig_description::link::{Address, AddressError, DEFAULT_BAUD};

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
