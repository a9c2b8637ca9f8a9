//! Serial lines: each frame COBS-encoded and ended by a 0x00 byte.

use std::io::{ErrorKind as IoKind, Read, Write};
use std::net::SocketAddr;
use std::time::{Duration, Instant};

use serialport::SerialPort;

use super::{Peer, Recv, Transport};
use crate::codec::{cobs_decode, cobs_encode, MAX_COBS_LEN};
use crate::error::RigError;

/// A serial port carrying COBS frames.
pub struct SerialTransport {
    port: Box<dyn SerialPort>,
    path: String,
    /// Bytes received after the last delimiter.
    pending: Vec<u8>,
    /// True while discarding an overlong run of bytes up to the next delimiter.
    overflowed: bool,
}

/// How long a write may wait for room in the output buffer: a few frame times at 921 600 baud,
/// short enough that a host that stopped reading cannot stall a rig loop for long.
const WRITE_TIMEOUT: Duration = Duration::from_millis(5);

impl std::fmt::Debug for SerialTransport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "SerialTransport({})", self.path)
    }
}

impl SerialTransport {
    /// Opens `path` at `baud`, 8 data bits, no parity, one stop bit, no flow control.
    pub fn open(path: &str, baud: u32) -> Result<Self, RigError> {
        let port = serialport::new(path, baud)
            .timeout(Duration::from_millis(1))
            .open()
            .map_err(|e| {
                RigError::io(
                    format!("opening serial port {path} at {baud} baud"),
                    std::io::Error::from(e),
                )
            })?;
        Ok(Self::from_port(port, path))
    }

    /// Wraps an already opened port (e.g. one end of a pseudo-terminal pair in tests);
    /// `name` appears in error messages.
    pub fn from_port(port: Box<dyn SerialPort>, name: &str) -> Self {
        Self {
            port,
            path: name.to_string(),
            pending: Vec::with_capacity(MAX_COBS_LEN),
            overflowed: false,
        }
    }

    /// Takes one delimited frame out of `pending`, if there is one.
    fn take_frame(&mut self, buf: &mut [u8]) -> Option<Recv> {
        while let Some(end) = self.pending.iter().position(|&b| b == 0) {
            let encoded: Vec<u8> = self.pending.drain(..=end).collect();
            if std::mem::take(&mut self.overflowed) {
                // The tail of an overlong run of bytes.
                return Some(Recv::Garbled);
            }
            if end == 0 {
                // An empty frame (a lone delimiter, which a sender may use to resynchronise).
                continue;
            }
            return Some(match cobs_decode(&encoded, buf) {
                Ok(len) => Recv::Frame {
                    len,
                    from: Peer::Serial,
                },
                Err(_) => Recv::Garbled,
            });
        }
        None
    }
}

impl Transport for SerialTransport {
    fn send(&mut self, frame: &[u8], _to: &Peer) -> Result<(), RigError> {
        let mut wire = [0u8; MAX_COBS_LEN];
        let n = cobs_encode(frame, &mut wire).map_err(RigError::Encode)?;
        // The port has one timeout for reads and writes, and `recv` leaves it at whatever was
        // left of its wait, often zero: a write would then fail the moment the output buffer
        // is momentarily full (regression: `a_session_runs_over_a_serial_line` under load).
        self.port
            .set_timeout(WRITE_TIMEOUT)
            .map_err(|e| RigError::io("configuring the serial port", e.into()))?;
        self.port
            .write_all(&wire[..n])
            .map_err(|e| RigError::io(format!("writing to serial port {}", self.path), e))
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<Recv, RigError> {
        let deadline = Instant::now() + timeout;
        let mut past_deadline = false;
        loop {
            if let Some(got) = self.take_frame(buf) {
                return Ok(got);
            }
            if self.pending.len() > MAX_COBS_LEN {
                // No delimiter in sight: drop what we have and skip to the next delimiter.
                self.pending.clear();
                self.overflowed = true;
            }
            if past_deadline {
                return Ok(Recv::Timeout);
            }
            // Read at least once, even for a zero timeout (a poll).
            let wait = deadline.saturating_duration_since(Instant::now());
            self.port
                .set_timeout(wait)
                .map_err(|e| RigError::io("configuring the serial port", e.into()))?;
            let mut chunk = [0u8; 256];
            match self.port.read(&mut chunk) {
                Ok(n) => self.pending.extend_from_slice(&chunk[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        IoKind::TimedOut | IoKind::WouldBlock | IoKind::Interrupted
                    ) => {}
                Err(e) => {
                    return Err(RigError::io(
                        format!("reading from serial port {}", self.path),
                        e,
                    ))
                }
            }
            past_deadline = Instant::now() >= deadline;
        }
    }

    fn local_addr(&self) -> Option<SocketAddr> {
        None
    }
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use crate::codec::{self, MAX_FRAME_LEN};
    use crate::wire::{Command, Message};

    fn pty_pair() -> (SerialTransport, SerialTransport) {
        let (a, b) = serialport::TTYPort::pair().expect("pseudo-terminal pair");
        (
            SerialTransport::from_port(Box::new(a), "pty-a"),
            SerialTransport::from_port(Box::new(b), "pty-b"),
        )
    }

    #[test]
    fn frames_cross_a_serial_line_and_garbage_is_skipped() {
        let (mut a, mut b) = pty_pair();
        let message = Message::Command(Command {
            sequence: 7,
            sensor_sequence: 6,
            leg_forces_n: [0.0, 1.0, -2.0, 0.0, 0.0, 3.5],
            enable: true,
        });
        let mut frame = [0u8; MAX_FRAME_LEN];
        let n = codec::encode(&message, None, &mut frame).unwrap();
        // Line noise before the frame: a run without delimiter that overflows, then a
        // delimiter, then a lone delimiter (ignored), then a broken COBS block.
        a.port.write_all(&[0x55; MAX_COBS_LEN + 10]).unwrap();
        a.port.write_all(&[0x00, 0x00, 0x05, 0x01, 0x00]).unwrap();
        a.send(&frame[..n], &Peer::Serial).unwrap();
        a.send(&frame[..n], &Peer::Serial).unwrap();

        let mut buf = [0u8; MAX_FRAME_LEN + 1];
        let mut garbled = 0;
        let mut got = Vec::new();
        while got.len() < 2 {
            match b.recv(&mut buf, Duration::from_secs(2)).unwrap() {
                Recv::Frame { len, from } => {
                    assert_eq!(from, Peer::Serial);
                    got.push(codec::decode(&buf[..len], None).unwrap());
                }
                Recv::Garbled => garbled += 1,
                Recv::Timeout => panic!("timed out after {got:?}"),
            }
        }
        assert_eq!(got, [message, message]);
        assert_eq!(garbled, 2);
        assert_eq!(b.recv(&mut buf, Duration::ZERO).unwrap(), Recv::Timeout);
    }
}
