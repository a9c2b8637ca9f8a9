//! What a call of the rig core produces besides the actuator output: frames to send and events
//! for the operator, in a fixed buffer the caller owns and drains after every call.

use crate::codec::{self, Auth, MAX_FRAME_LEN};
use crate::wire::{Fault, Message};

/// Frames one [`Outbox`] holds. The most one call of the rig core emits is three (a motion
/// fault, its periodic repeat and the sensor frame of the same tick).
pub const OUTBOX_FRAMES: usize = 4;

/// Events one [`Outbox`] holds (one call of the rig core raises at most one).
pub const OUTBOX_EVENTS: usize = 2;

/// Why a frame is sent: the transport may treat sensor frames (the stream) differently from
/// the rest (e.g. count their send failures).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameKind {
    /// The answer to a `Hello` (first or repeated).
    HelloAck,
    /// An untagged `Fault` refusing a sender that has no session (busy, key, version).
    Refusal,
    /// A `Fault` report of the session: when it latched, and every `FAULT_REPEAT_FRAMES`.
    Fault,
    /// A `Sensor` frame of the session with this sequence number.
    Sensor {
        /// The frame's `Sensor::sequence`.
        sequence: u64,
    },
}

/// One encoded frame and where it goes.
#[derive(Clone, Copy, Debug)]
pub struct Outgoing<P> {
    /// Destination (the peer id the frame's datagram came from, or the session's host).
    pub to: P,
    /// What the frame is.
    pub kind: FrameKind,
    len: usize,
    bytes: [u8; MAX_FRAME_LEN],
}

impl<P> Outgoing<P> {
    /// The frame, as `codec::encode` wrote it (not COBS-encoded).
    pub fn bytes(&self) -> &[u8] {
        self.bytes.get(..self.len).unwrap_or(&[])
    }
}

/// What happened in a call of the rig core that an operator (or a log) may want to know.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CoreEvent<P> {
    /// A host opened a session (the `HelloAck` is in the same outbox, after this event).
    SessionOpened {
        /// 1 for the rig core's first session, then +1 per session.
        number: u64,
        /// The session's host.
        peer: P,
        /// The session number sent in the `HelloAck`.
        session_id: u64,
    },
    /// The rig core latched a fault and braked.
    Fault {
        /// The session's number.
        session: u64,
        /// Its host.
        peer: P,
        /// The fault as reported to the host.
        fault: Fault,
    },
    /// The session's host stayed silent for longer than the session timeout: the session ended.
    SessionTimedOut {
        /// The session's number.
        session: u64,
        /// Its host.
        peer: P,
        /// How long the host had been silent, ns.
        silent_for_ns: u64,
    },
}

/// Frames and events of calls of the rig core, in order. Fixed size: [`OUTBOX_FRAMES`] frames
/// of `MAX_FRAME_LEN` bytes and [`OUTBOX_EVENTS`] events. The rig core appends; the caller
/// sends the frames, handles the events and [`clear`](Self::clear)s it after every call. What
/// does not fit is dropped and counted in [`overflow`](Self::overflow).
#[derive(Clone, Debug)]
pub struct Outbox<P> {
    frames: [Option<Outgoing<P>>; OUTBOX_FRAMES],
    events: [Option<CoreEvent<P>>; OUTBOX_EVENTS],
    overflow: u64,
}

impl<P: Copy> Default for Outbox<P> {
    fn default() -> Self {
        Self::new()
    }
}

impl<P: Copy> Outbox<P> {
    /// An empty outbox.
    pub const fn new() -> Self {
        Self {
            frames: [None; OUTBOX_FRAMES],
            events: [None; OUTBOX_EVENTS],
            overflow: 0,
        }
    }

    /// Empties frames and events (the overflow count stays).
    pub fn clear(&mut self) {
        self.frames = [None; OUTBOX_FRAMES];
        self.events = [None; OUTBOX_EVENTS];
    }

    /// The frames to send, in order.
    pub fn frames(&self) -> impl Iterator<Item = &Outgoing<P>> {
        self.frames.iter().flatten()
    }

    /// The events, in order.
    pub fn events(&self) -> impl Iterator<Item = &CoreEvent<P>> {
        self.events.iter().flatten()
    }

    /// True when there is nothing to send and nothing to report.
    pub fn is_empty(&self) -> bool {
        self.frames.iter().all(Option::is_none) && self.events.iter().all(Option::is_none)
    }

    /// Frames and events dropped because the outbox was full (zero when drained every call).
    pub fn overflow(&self) -> u64 {
        self.overflow
    }

    fn free_frame(&mut self) -> Option<&mut Option<Outgoing<P>>> {
        let slot = self.frames.iter_mut().find(|slot| slot.is_none());
        if slot.is_none() {
            self.overflow += 1;
        }
        slot
    }

    /// Encodes `message` (tagged with `auth`) as a frame to `to`. Every message fits
    /// `MAX_FRAME_LEN` (the codec's tests check it), so encoding does not fail.
    pub(super) fn push_message(
        &mut self,
        to: P,
        kind: FrameKind,
        message: &Message,
        auth: Option<&Auth<'_>>,
    ) {
        let mut bytes = [0u8; MAX_FRAME_LEN];
        let Ok(len) = codec::encode(message, auth, &mut bytes) else {
            self.overflow += 1;
            return;
        };
        if let Some(slot) = self.free_frame() {
            *slot = Some(Outgoing {
                to,
                kind,
                len,
                bytes,
            });
        }
    }

    /// Queues an already encoded frame (`frame` is at most `MAX_FRAME_LEN` bytes).
    pub(super) fn push_encoded(&mut self, to: P, kind: FrameKind, frame: &[u8]) {
        let mut bytes = [0u8; MAX_FRAME_LEN];
        let Some(dest) = bytes.get_mut(..frame.len()) else {
            self.overflow += 1;
            return;
        };
        dest.copy_from_slice(frame);
        if let Some(slot) = self.free_frame() {
            *slot = Some(Outgoing {
                to,
                kind,
                len: frame.len(),
                bytes,
            });
        }
    }

    pub(super) fn push_event(&mut self, event: CoreEvent<P>) {
        match self.events.iter_mut().find(|slot| slot.is_none()) {
            Some(slot) => *slot = Some(event),
            None => self.overflow += 1,
        }
    }
}
