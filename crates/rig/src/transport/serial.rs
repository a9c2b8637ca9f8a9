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
        Ok(Self {
            port,
            path: path.to_string(),
            pending: Vec::with_capacity(MAX_COBS_LEN),
            overflowed: false,
        })
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
