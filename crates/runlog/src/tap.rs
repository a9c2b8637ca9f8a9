//! A second reader of every message the log writes (the live view, crate `live`), and the
//! pace the log keeps for it.
//!
//! **One message, two sinks.** The observer builds each message once; [`crate::mcap_log`]
//! serializes it into its batch, and the log's writer thread hands the same bytes, with the
//! same log time, to [`Tap::message`] before it writes them to the file. So a tap sees exactly
//! the log's channels at the log's rates, never more: a batch the log drops for a full queue
//! ([`crate::mcap_log::Delivery::DropWhenFull`]) is missing from the tap too.
//!
//! **Never on the caller's thread.** The caller (the run loop; on a rig, the control loop)
//! only serializes into a recycled batch, as without a tap: a rig's control loop is
//! allocation-free once warm (`tests/no_heap_tick.rs`) and must not wait on a lock a socket
//! thread holds, so a tap, which may allocate and lock, runs on the writer thread only.
//!
//! **Pace.** A simulation watched live is held to the wall clock ([`Pace::WallClock`]) on the
//! caller's thread: a message is not queued before its log time (within [`PACE_SLACK_NS`]),
//! so the simulation runs at real speed and the view shows the motion as it happens. That is
//! the log's pace, not a call into the tap; without a tap, or on a rig ([`Pace::AsRun`]),
//! nothing is held.

/// Every message the log writes, handed over on the log's writer thread (see the
/// [module docs](self)).
pub trait Tap: Send + 'static {
    /// One message: its channel's topic, its bytes in the channel's encoding, its log time
    /// (ns since the Unix epoch). Called in the log's order; must not wait for a client.
    fn message(&self, topic: &'static str, bytes: &[u8], log_time_ns: u64);

    /// How the log keeps time for this tap.
    fn pace(&self) -> Pace {
        Pace::AsRun
    }
}

/// How a tapped log keeps time with the run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Pace {
    /// As the run goes: a rig runs in real time by itself.
    #[default]
    AsRun,
    /// No message goes out ahead of its log time on the wall clock: a simulation, which runs
    /// many times faster than real time, is held to it so that the view shows the motion at
    /// its real speed (log time = the run's start on the wall clock + the sample time).
    WallClock,
}

/// How far a message may run ahead of the wall clock before [`Pace::WallClock`] sleeps, ns:
/// a sleep per message of a 1 kHz run would cost more than it keeps.
pub const PACE_SLACK_NS: u64 = 2_000_000;

impl Pace {
    /// [`Pace::WallClock`]: sleeps until `log_time_ns` (ns since the Unix epoch) on the wall
    /// clock when the message is more than [`PACE_SLACK_NS`] ahead of it, so that
    /// `now ≥ log_time_ns − PACE_SLACK_NS` on return. [`Pace::AsRun`]: returns at once.
    pub fn hold(self, log_time_ns: u64) {
        if self == Pace::WallClock {
            let ahead_ns = log_time_ns.saturating_sub(crate::clock::unix_now_ns());
            if ahead_ns > PACE_SLACK_NS {
                std::thread::sleep(std::time::Duration::from_nanos(ahead_ns));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wall_clock_pace_holds_until_the_time_and_as_run_does_not() {
        let due = crate::clock::unix_now_ns() + 30_000_000;
        Pace::WallClock.hold(due);
        assert!(
            crate::clock::unix_now_ns() >= due,
            "released before its time"
        );
        // A time that has passed is not held; nor is anything as the run goes.
        let start = std::time::Instant::now();
        Pace::WallClock.hold(due);
        Pace::AsRun.hold(due + 10_000_000_000);
        assert!(start.elapsed() < std::time::Duration::from_secs(5));
    }
}
