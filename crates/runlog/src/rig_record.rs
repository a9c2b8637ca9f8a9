//! `/rig/link`: the rig, the link's counters and the host loop's timing over a measurement, as
//! `stewart rig` logs them when a session opens and when a measurement ends.

use serde::Serialize;

use crate::schema::{int, nullable, num, object, string, Schema};

/// Topic of the link records.
pub const LINK: &str = "/rig/link";

/// Schema name of [`LinkMsg`].
pub const LINK_SCHEMA_NAME: &str = "stewart.RigLink";

pub use rig::monitored::TimingSummary;

/// The link counters in the log and the report (`rig::LinkStats` with names that say what
/// each counts).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct LinkCounters {
    /// Frames received from anyone.
    pub received: u64,
    /// Sensor frames handed to the loop.
    pub accepted: u64,
    /// Sensor frames that never arrived (sequence gaps).
    pub lost: u64,
    /// Frames skipped because a newer one was waiting.
    pub late: u64,
    /// Repeats of the last sequence.
    pub duplicate: u64,
    /// Frames older than the last accepted.
    pub out_of_sequence: u64,
    /// Damaged frames (CRC, framing).
    pub corrupt: u64,
    /// Frames from an address other than the rig's.
    pub foreign: u64,
    /// Frames with a missing or wrong key tag.
    pub auth_failed: u64,
    /// Frames of another protocol (version).
    pub version_mismatch: u64,
    /// Valid frames not expected then.
    pub unexpected: u64,
    /// Commands sent.
    pub commands_sent: u64,
    /// Commands with a force clamped to the limits.
    pub commands_clamped: u64,
}

impl LinkCounters {
    fn schema() -> Schema {
        let n = |d: &'static str| int(d);
        object(
            vec![
                ("received", n("frames received from anyone")),
                ("accepted", n("sensor frames handed to the loop")),
                (
                    "lost",
                    n("sensor frames that never arrived (sequence gaps)"),
                ),
                ("late", n("frames skipped because a newer one was waiting")),
                ("duplicate", n("repeats of the last sequence")),
                ("out_of_sequence", n("frames older than the last accepted")),
                ("corrupt", n("damaged frames (CRC, framing)")),
                ("foreign", n("frames from an address other than the rig's")),
                ("auth_failed", n("frames with a missing or wrong key tag")),
                ("version_mismatch", n("frames of another protocol version")),
                ("unexpected", n("valid frames not expected then")),
                ("commands_sent", n("commands sent")),
                (
                    "commands_clamped",
                    n("commands with a force clamped to the limits"),
                ),
            ],
            "link counters over the measurement",
        )
    }
}

impl From<rig::LinkStats> for LinkCounters {
    fn from(s: rig::LinkStats) -> Self {
        Self {
            received: s.received,
            accepted: s.accepted,
            lost: s.lost,
            late: s.late,
            duplicate: s.duplicate,
            out_of_sequence: s.out_of_sequence,
            corrupt: s.corrupt,
            foreign: s.foreign_sender,
            auth_failed: s.auth_failed,
            version_mismatch: s.version_mismatch,
            unexpected: s.unexpected,
            commands_sent: s.commands_sent,
            commands_clamped: s.commands_clamped,
        }
    }
}

/// `stewart.RigLink` on [`LINK`]: the rig and the link counters, written when a session opens
/// and when a measurement ends (completed, interrupted or faulted).
#[derive(Clone, Debug, Serialize)]
pub struct LinkMsg {
    /// Measurement (`"tare"` or `"loaded"`).
    pub run: &'static str,
    /// Rig time of the last frame, s (0 before the first).
    pub time_s: f64,
    /// `"session"` (opened) or `"end"` (measurement over).
    pub event: &'static str,
    /// The rig's address.
    pub address: String,
    /// The rig's identity from the handshake.
    pub identity: String,
    /// The session number the rig chose.
    pub session_id: u64,
    /// Counters over this measurement (zero at `"session"`).
    pub counters: LinkCounters,
    /// The loop's timing over this measurement (`null` at `"session"`).
    pub timing: Option<TimingSummary>,
    /// Log messages dropped so far in this run because the log's writer thread fell behind
    /// (the control loop never waits for the disk).
    pub log_dropped: u64,
    /// What stopped the measurement, when it faulted.
    pub fault: Option<String>,
}

impl LinkMsg {
    /// JSON schema.
    pub fn schema() -> Schema {
        object(
            vec![
                (
                    "run",
                    string("measurement this belongs to: \"tare\" or \"loaded\""),
                ),
                ("time_s", num("rig time of the last frame, s")),
                (
                    "event",
                    string("\"session\" (opened) or \"end\" (measurement over)"),
                ),
                ("address", string("the rig's address")),
                ("identity", string("the rig's identity from the handshake")),
                ("session_id", int("session number chosen by the rig")),
                ("counters", LinkCounters::schema()),
                (
                    "timing",
                    nullable(object(
                        vec![
                            ("periods", int("loop periods measured")),
                            ("nominal_period_s", num("nominal sample period, s")),
                            ("median_period_s", num("median loop period, s")),
                            ("jitter_median_s", num("median |period - T|, s")),
                            ("jitter_p99_s", num("99th percentile of |period - T|, s")),
                            ("jitter_max_s", num("largest |period - T|, s")),
                            ("work_median_s", num("median frame-to-command time, s")),
                            (
                                "work_p99_s",
                                num("99th percentile of frame-to-command time, s"),
                            ),
                        ],
                        "host loop timing (wall clock)",
                    )),
                ),
                (
                    "log_dropped",
                    int("log messages dropped so far in this run: the log's writer fell behind"),
                ),
                ("fault", nullable(string("what stopped the measurement"))),
            ],
            "The rig link: identity and counters",
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn link_message_matches_its_schema() {
        let msg = LinkMsg {
            run: "loaded",
            time_s: 1.5,
            event: "end",
            address: "udp://127.0.0.1:7700".into(),
            identity: "stewart-emulator".into(),
            session_id: 7,
            counters: LinkCounters {
                lost: 3,
                ..LinkCounters::default()
            },
            timing: Some(TimingSummary::default()),
            log_dropped: 0,
            fault: Some("link silent".into()),
        };
        let value = serde_json::to_value(&msg).unwrap();
        LinkMsg::schema().check(&value).unwrap();
        assert_eq!(value["counters"]["lost"], 3);
        let no_timing = LinkMsg {
            timing: None,
            fault: None,
            ..msg
        };
        LinkMsg::schema()
            .check(&serde_json::to_value(&no_timing).unwrap())
            .unwrap();
    }
}
