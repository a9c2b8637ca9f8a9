//! Counters of what the host's link saw. Frames counted here other than `accepted` never
//! reach the cores.

use std::fmt;

use crate::codec::{CodecError, CodecErrorKind};

/// What the host received and sent over one session.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkStats {
    /// Datagrams (or stream frames) received, of any kind and from anyone.
    pub received: u64,
    /// Sensor frames handed to the cores.
    pub accepted: u64,
    /// Sensor frames that never arrived (gaps in the sequence).
    pub lost: u64,
    /// Valid frames skipped because a newer one was already waiting (the host fell behind).
    pub late: u64,
    /// Frames repeating the last accepted sequence number.
    pub duplicate: u64,
    /// Frames older than the last accepted one (reordered or delayed on the way).
    pub out_of_sequence: u64,
    /// Frames damaged on the way (CRC, framing, body).
    pub corrupt: u64,
    /// Frames from an address other than the rig's.
    pub foreign_sender: u64,
    /// Frames whose HMAC tag was missing, unexpected or wrong.
    pub auth_failed: u64,
    /// Frames of another protocol version or not of this protocol at all.
    pub version_mismatch: u64,
    /// Valid frames of a kind the host does not expect at that point.
    pub unexpected: u64,
    /// Commands sent.
    pub commands_sent: u64,
    /// Commands with at least one force clamped to the rig's limits.
    pub commands_clamped: u64,
}

impl LinkStats {
    /// Counts a frame the codec refused.
    pub fn count_codec_error(&mut self, error: &CodecError) {
        match error.kind() {
            CodecErrorKind::Corrupt | CodecErrorKind::Encode => self.corrupt += 1,
            CodecErrorKind::Auth => self.auth_failed += 1,
            CodecErrorKind::Foreign => self.version_mismatch += 1,
        }
    }

    /// What happened between `earlier` (a copy taken before) and now, e.g. over one
    /// measurement of a longer session.
    pub fn since(&self, earlier: &LinkStats) -> LinkStats {
        LinkStats {
            received: self.received.saturating_sub(earlier.received),
            accepted: self.accepted.saturating_sub(earlier.accepted),
            lost: self.lost.saturating_sub(earlier.lost),
            late: self.late.saturating_sub(earlier.late),
            duplicate: self.duplicate.saturating_sub(earlier.duplicate),
            out_of_sequence: self.out_of_sequence.saturating_sub(earlier.out_of_sequence),
            corrupt: self.corrupt.saturating_sub(earlier.corrupt),
            foreign_sender: self.foreign_sender.saturating_sub(earlier.foreign_sender),
            auth_failed: self.auth_failed.saturating_sub(earlier.auth_failed),
            version_mismatch: self
                .version_mismatch
                .saturating_sub(earlier.version_mismatch),
            unexpected: self.unexpected.saturating_sub(earlier.unexpected),
            commands_sent: self.commands_sent.saturating_sub(earlier.commands_sent),
            commands_clamped: self
                .commands_clamped
                .saturating_sub(earlier.commands_clamped),
        }
    }

    /// Received frames that were not handed to the cores.
    pub fn rejected(&self) -> u64 {
        self.late
            + self.duplicate
            + self.out_of_sequence
            + self.corrupt
            + self.foreign_sender
            + self.auth_failed
            + self.version_mismatch
            + self.unexpected
    }
}

impl fmt::Display for LinkStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "received {}, accepted {}, lost {}, late {}, duplicate {}, out of sequence {}, \
             corrupt {}, foreign sender {}, auth failed {}, version mismatch {}, unexpected {}, \
             commands sent {}, clamped {}",
            self.received,
            self.accepted,
            self.lost,
            self.late,
            self.duplicate,
            self.out_of_sequence,
            self.corrupt,
            self.foreign_sender,
            self.auth_failed,
            self.version_mismatch,
            self.unexpected,
            self.commands_sent,
            self.commands_clamped
        )
    }
}
