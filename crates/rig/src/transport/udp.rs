//! UDP: one frame per datagram.

use std::io::ErrorKind as IoKind;
use std::net::{Ipv4Addr, Ipv6Addr, SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use super::{Peer, Recv, Transport};
use crate::error::RigError;

/// Waits shorter than this poll with short sleeps: a socket read timeout is rounded up to the
/// kernel's tick (up to 4 ms on Linux), far too coarse to pace a 1 kHz loop.
const POLL_BELOW: Duration = Duration::from_millis(5);
/// Sleep between polls: short enough for sub-millisecond pacing, long enough to stay idle.
const POLL_SLEEP: Duration = Duration::from_micros(100);

/// A UDP socket that reports who sent each datagram (it is never `connect`ed, so that frames
/// from strangers are seen and counted rather than silently filtered by the kernel).
#[derive(Debug)]
pub struct UdpTransport {
    socket: UdpSocket,
    nonblocking: bool,
    read_timeout: Option<Duration>,
}

impl UdpTransport {
    /// A socket for talking to `rig`, bound to an ephemeral port of the same address family.
    pub fn client(rig: SocketAddr) -> Result<Self, RigError> {
        let local: SocketAddr = match rig {
            SocketAddr::V4(a) if a.ip().is_loopback() => (Ipv4Addr::LOCALHOST, 0).into(),
            SocketAddr::V4(_) => (Ipv4Addr::UNSPECIFIED, 0).into(),
            SocketAddr::V6(a) if a.ip().is_loopback() => (Ipv6Addr::LOCALHOST, 0).into(),
            SocketAddr::V6(_) => (Ipv6Addr::UNSPECIFIED, 0).into(),
        };
        Self::bind(local)
    }

    /// A socket bound to `addr` (port 0 picks a free port; see [`Transport::local_addr`]).
    pub fn bind(addr: SocketAddr) -> Result<Self, RigError> {
        let socket =
            UdpSocket::bind(addr).map_err(|e| RigError::io(format!("binding udp://{addr}"), e))?;
        Ok(Self {
            socket,
            nonblocking: false,
            read_timeout: None,
        })
    }

    fn set_nonblocking(&mut self, on: bool) -> Result<(), RigError> {
        if self.nonblocking != on {
            self.socket
                .set_nonblocking(on)
                .map_err(|e| RigError::io("configuring the UDP socket", e))?;
            self.nonblocking = on;
        }
        Ok(())
    }

    fn try_recv(&mut self, buf: &mut [u8]) -> Result<Option<Recv>, RigError> {
        match self.socket.recv_from(buf) {
            Ok((len, from)) => Ok(Some(Recv::Frame {
                len,
                from: Peer::Udp(from),
            })),
            Err(e)
                if matches!(
                    e.kind(),
                    IoKind::WouldBlock
                        | IoKind::TimedOut
                        | IoKind::Interrupted
                        // An ICMP "port unreachable" for an earlier send: the peer is not
                        // (yet) listening. That is silence, which the caller times.
                        | IoKind::ConnectionRefused
                        | IoKind::ConnectionReset
                ) =>
            {
                Ok(None)
            }
            Err(e) => Err(RigError::io("receiving from the UDP socket", e)),
        }
    }
}

impl Transport for UdpTransport {
    fn send(&mut self, frame: &[u8], to: &Peer) -> Result<(), RigError> {
        let Peer::Udp(addr) = to else {
            return Err(RigError::config(
                format!("the address {to}"),
                "a UDP link can only send to a UDP address",
            ));
        };
        match self.socket.send_to(frame, addr) {
            Ok(_) => Ok(()),
            // A full send buffer or a refused earlier datagram loses this frame; the protocol
            // is built for lost frames.
            Err(e)
                if matches!(
                    e.kind(),
                    IoKind::WouldBlock | IoKind::ConnectionRefused | IoKind::Interrupted
                ) =>
            {
                Ok(())
            }
            Err(e) => Err(RigError::io(format!("sending to udp://{addr}"), e)),
        }
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<Recv, RigError> {
        if timeout >= POLL_BELOW {
            self.set_nonblocking(false)?;
            if self.read_timeout != Some(timeout) {
                self.socket
                    .set_read_timeout(Some(timeout))
                    .map_err(|e| RigError::io("configuring the UDP socket", e))?;
                self.read_timeout = Some(timeout);
            }
            return Ok(self.try_recv(buf)?.unwrap_or(Recv::Timeout));
        }
        self.set_nonblocking(true)?;
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(got) = self.try_recv(buf)? {
                return Ok(got);
            }
            let now = Instant::now();
            if now >= deadline {
                return Ok(Recv::Timeout);
            }
            std::thread::sleep(POLL_SLEEP.min(deadline - now));
        }
    }

    fn local_addr(&self) -> Option<SocketAddr> {
        self.socket.local_addr().ok()
    }
}
