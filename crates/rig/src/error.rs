//! The crate's error type (std side): one flat enum, each variant naming its cause.

use std::time::Duration;

use crate::codec::CodecError;
use crate::wire::FaultCode;

/// Coarse classes of [`RigError`], for callers that branch on the kind of failure.
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ErrorKind {
    /// A malformed `udp://` or `serial://` address, or a bad option value.
    Config,
    /// The operating system refused an I/O operation (socket, serial port, file).
    Io,
    /// The handshake failed: no answer, version or layout mismatch, key refused.
    Handshake,
    /// The link went silent.
    Link,
    /// The rig reported a fault (it has braked).
    RigFault,
    /// A sensor value is not finite or out of range.
    Sensor,
    /// A command could not be sent as asked (not finite).
    Command,
    /// The backend behind an emulator failed.
    Backend,
    /// The operator stopped the run at once (a second Ctrl-C); the rig was braked.
    Stopped,
}

/// Everything that can go wrong in the rig's I/O.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum RigError {
    /// The address, the key or an option cannot be used.
    #[error("{input}: {reason}")]
    Config {
        /// What was given, in words that name it ("the key file /x", "the address udp://…").
        input: String,
        /// Why it is refused.
        reason: String,
    },
    /// An operating-system I/O error.
    #[error("{context}: {source}")]
    Io {
        /// What was being done.
        context: String,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The rig did not answer the handshake.
    #[error("no handshake answer from the rig at {peer} within {waited:?} (is the rig or emulator running?)")]
    HandshakeTimeout {
        /// The rig's address.
        peer: String,
        /// How long the host tried.
        waited: Duration,
    },
    /// The rig speaks another protocol version.
    #[error(
        "protocol version mismatch: the rig speaks v{rig}, this host v{host}; refusing the session"
    )]
    VersionMismatch {
        /// The rig's version.
        rig: u8,
        /// This host's version.
        host: u8,
    },
    /// The rig's sensors or limits do not fit what the host expects.
    #[error("rig layout mismatch: {reason}; refusing the session")]
    LayoutMismatch {
        /// What differs.
        reason: String,
    },
    /// The rig refused the handshake.
    #[error("the rig refused the session: {} (code {}{})", code.name(), code.0, detail)]
    Refused {
        /// The rig's fault code.
        code: FaultCode,
        /// Extra words, may be empty.
        detail: String,
    },
    /// No valid sensor frame for longer than the link silence limit.
    #[error("link silent: no valid sensor frame from the rig for {silent_for:?} (limit {limit:?}, last sequence {last_sequence})")]
    LinkSilent {
        /// Time since the last valid frame.
        silent_for: Duration,
        /// The configured limit.
        limit: Duration,
        /// Sequence of the last valid frame (0: none since the handshake).
        last_sequence: u64,
    },
    /// The rig reported a fault and braked.
    #[error("rig fault: {} (code {}, leg {}, value {value}, after command {command_sequence})",
        code.name(), code.0, if *leg == crate::wire::NO_LEG { "-".to_string() } else { leg.to_string() })]
    RigFault {
        /// The fault code.
        code: FaultCode,
        /// The leg concerned or `NO_LEG`.
        leg: u8,
        /// The offending value.
        value: f64,
        /// The last command the rig accepted.
        command_sequence: u64,
    },
    /// A sensor frame holds a value that cannot be right.
    #[error("invalid sensor frame {sequence}: {reason}")]
    SensorInvalid {
        /// The frame's sequence.
        sequence: u64,
        /// Which value and why.
        reason: String,
    },
    /// A command holds a value that cannot be sent.
    #[error("invalid command: {reason} (a safe stop was sent instead)")]
    CommandInvalid {
        /// Which value and why.
        reason: String,
    },
    /// A frame could not be encoded.
    #[error("cannot encode a frame: {0}")]
    Encode(CodecError),
    /// The backend served by an emulator failed.
    #[error("emulated backend failed: {reason}")]
    Backend {
        /// The backend's message.
        reason: String,
    },
    /// The operator asked to stop at once: no park ramp, the brakes at once.
    #[error("stopped at once ({reason}): the rig was braked without parking")]
    Stopped {
        /// Who or what asked.
        reason: String,
    },
}

impl From<rig_description::link::AddressError> for RigError {
    fn from(e: rig_description::link::AddressError) -> Self {
        RigError::Config {
            input: e.input,
            reason: e.reason,
        }
    }
}

impl RigError {
    /// The class of this error.
    pub fn kind(&self) -> ErrorKind {
        match self {
            RigError::Config { .. } => ErrorKind::Config,
            RigError::Io { .. } => ErrorKind::Io,
            RigError::HandshakeTimeout { .. }
            | RigError::VersionMismatch { .. }
            | RigError::LayoutMismatch { .. }
            | RigError::Refused { .. } => ErrorKind::Handshake,
            RigError::LinkSilent { .. } => ErrorKind::Link,
            RigError::RigFault { .. } => ErrorKind::RigFault,
            RigError::SensorInvalid { .. } => ErrorKind::Sensor,
            RigError::CommandInvalid { .. } | RigError::Encode(_) => ErrorKind::Command,
            RigError::Backend { .. } => ErrorKind::Backend,
            RigError::Stopped { .. } => ErrorKind::Stopped,
        }
    }

    /// Whether this ends a run by a stall rather than a fault of the platform: the link went
    /// silent, or the rig's command watchdog tripped (it braked). Limits, sensors, the
    /// emergency stop and the operator's stop are not stalls.
    pub fn is_stall(&self) -> bool {
        match self {
            RigError::LinkSilent { .. } => true,
            RigError::RigFault { code, .. } => *code == crate::wire::FaultCode::WATCHDOG,
            _ => false,
        }
    }

    pub(crate) fn io(context: impl Into<String>, source: std::io::Error) -> Self {
        RigError::Io {
            context: context.into(),
            source,
        }
    }

    pub(crate) fn config(input: impl Into<String>, reason: impl Into<String>) -> Self {
        RigError::Config {
            input: input.into(),
            reason: reason.into(),
        }
    }
}
