//! Real-time scheduling where the operating system allows it: the host's loop and the emulator
//! must answer within the rig's command watchdog (20 ms), and a normal-priority process on a
//! busy machine is descheduled for longer than that (docs/rig.md, *Measured on this machine*).
//!
//! [`request`] asks for `SCHED_FIFO` at a modest priority for the calling thread (the loop's)
//! and, when the memory-lock limit allows all of it, locks the
//! process's memory (`mlockall(MCL_CURRENT | MCL_FUTURE)`) so that no page fault stalls the
//! loop. Each refusal is reported with its fix, never an error: the run goes on at normal
//! priority and the host names lateness when the rig's watchdog trips.
//!
//! Threads the loop's thread starts afterwards run at normal priority (`SCHED_RESET_ON_FORK`):
//! the log's writer compressing a chunk and the live view's server at the loop's priority
//! held both cores of a two-core host while the loop waited (a `SCHED_FIFO` thread is never
//! preempted by one of equal priority). Only the link's heartbeat, whose lock the loop waits
//! on, takes the loop's priority ([`follow`], called by [`crate::monitored::Link::start`]).

/// The `SCHED_FIFO` priority asked for: above every normal task, below the kernel's own
/// real-time threads (which use 50 and up) and `chrt`'s usual 50, so that an operator can still
/// put something above the loop.
pub const FIFO_PRIORITY: i32 = 20;

/// What the operating system granted.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Granted {
    /// `Ok(priority)` with `SCHED_FIFO`, or why not.
    pub fifo: Result<i32, String>,
    /// `Ok` with the memory locked, or why not.
    pub locked: Result<(), String>,
}

impl Granted {
    /// One line for the user when something was refused (with how to get it), `None` when
    /// everything was granted.
    pub fn refusal_line(&self) -> Option<String> {
        let mut refused = Vec::new();
        if let Err(why) = &self.fifo {
            refused.push(format!(
                "no real-time priority ({why}; grant CAP_SYS_NICE, e.g. `sudo setcap \
                 cap_sys_nice+ep $(which stewart)`, raise `ulimit -r` to {FIFO_PRIORITY}, or \
                 start it under `chrt -f {FIFO_PRIORITY}`)"
            ));
        }
        if let Err(why) = &self.locked {
            refused.push(format!(
                "memory not locked ({why}; `ulimit -l unlimited` or CAP_IPC_LOCK)"
            ));
        }
        if refused.is_empty() {
            return None;
        }
        let consequence = if self.fifo.is_err() {
            "a busy machine may pause the loop past the rig's watchdog"
        } else {
            "a page fault may still pause the loop"
        };
        Some(format!("{}: {consequence}", refused.join("; ")))
    }

    /// One line saying what was granted.
    pub fn granted_line(&self) -> String {
        match (&self.fifo, &self.locked) {
            (Ok(p), Ok(())) => format!("real-time: SCHED_FIFO priority {p}, memory locked"),
            (Ok(p), Err(_)) => format!("real-time: SCHED_FIFO priority {p}, memory not locked"),
            (Err(_), Ok(())) => "real-time: normal priority, memory locked".into(),
            (Err(_), Err(_)) => "real-time: normal priority, memory not locked".into(),
        }
    }
}

/// Asks for `SCHED_FIFO` at [`FIFO_PRIORITY`] for the calling thread and locked memory for the
/// process (see the module documentation).
#[cfg(target_os = "linux")]
pub fn request() -> Granted {
    Granted {
        fifo: set_fifo(FIFO_PRIORITY),
        locked: lock_memory(),
    }
}

/// Elsewhere nothing is asked for.
#[cfg(not(target_os = "linux"))]
pub fn request() -> Granted {
    let why = || "not supported on this operating system".to_string();
    Granted {
        fifo: Err(why()),
        locked: Err(why()),
    }
}

/// The `SCHED_FIFO` priority of the calling thread, `None` at normal priority: what a helper
/// thread the loop waits on must [`follow`].
#[cfg(target_os = "linux")]
pub fn fifo_priority() -> Option<i32> {
    // SAFETY: plain system calls on this thread (pid 0); `param` is valid to write into.
    let policy = unsafe { libc::sched_getscheduler(0) };
    if policy < 0 || policy & !SCHED_RESET_ON_FORK != libc::SCHED_FIFO {
        return None;
    }
    let mut param = libc::sched_param { sched_priority: 0 };
    (unsafe { libc::sched_getparam(0, &mut param) } == 0).then_some(param.sched_priority)
}

/// Elsewhere every thread runs at normal priority.
#[cfg(not(target_os = "linux"))]
pub fn fifo_priority() -> Option<i32> {
    None
}

/// Puts the calling thread at `priority` ([`fifo_priority`] of the thread it serves), or
/// leaves it at normal priority for `None` or where the system refuses.
pub fn follow(priority: Option<i32>) {
    #[cfg(target_os = "linux")]
    if let Some(p) = priority {
        let _ = set_fifo(p);
    }
    #[cfg(not(target_os = "linux"))]
    let _ = priority;
}

/// `SCHED_RESET_ON_FORK` (linux/sched.h; not in the libc crate): threads and processes this
/// thread creates start at normal priority.
#[cfg(target_os = "linux")]
const SCHED_RESET_ON_FORK: i32 = 0x4000_0000;

#[cfg(target_os = "linux")]
fn set_fifo(priority: i32) -> Result<i32, String> {
    let param = libc::sched_param {
        sched_priority: priority,
    };
    // SAFETY: `param` is a valid sched_param for the call's duration; pid 0 is this thread.
    let rc = unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO | SCHED_RESET_ON_FORK, &param) };
    if rc == 0 {
        Ok(priority)
    } else {
        Err(std::io::Error::last_os_error().to_string())
    }
}

/// The capability that lifts the locked-memory limit (linux/capability.h).
#[cfg(target_os = "linux")]
const CAP_IPC_LOCK: u32 = 14;

/// Whether this process holds the capability `bit` in its effective set (`CapEff` of
/// /proc/self/status, a hex mask).
#[cfg(target_os = "linux")]
fn has_capability(bit: u32) -> bool {
    let Ok(status) = std::fs::read_to_string("/proc/self/status") else {
        return false;
    };
    status
        .lines()
        .find_map(|l| l.strip_prefix("CapEff:"))
        .and_then(|hex| u64::from_str_radix(hex.trim(), 16).ok())
        .is_some_and(|mask| mask & (1 << bit) != 0)
}

/// Locks memory only when the limit cannot be reached later (no limit, or CAP_IPC_LOCK): with `MCL_FUTURE` under a finite
/// `RLIMIT_MEMLOCK`, an allocation past the limit would fail and abort the process mid-run.
#[cfg(target_os = "linux")]
fn lock_memory() -> Result<(), String> {
    let mut limit = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: `limit` is a valid rlimit to write into.
    if unsafe { libc::getrlimit(libc::RLIMIT_MEMLOCK, &mut limit) } != 0 {
        return Err(std::io::Error::last_os_error().to_string());
    }
    if limit.rlim_cur != libc::RLIM_INFINITY && !has_capability(CAP_IPC_LOCK) {
        return Err(format!(
            "the locked-memory limit is {} kB",
            limit.rlim_cur / 1024
        ));
    }
    // SAFETY: plain system call on flags.
    if unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) } == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error().to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refusals_are_one_line_with_the_fix_and_grants_are_silent() {
        let all = Granted {
            fifo: Ok(FIFO_PRIORITY),
            locked: Ok(()),
        };
        assert_eq!(all.refusal_line(), None);
        assert!(all.granted_line().contains("SCHED_FIFO priority 20"));
        let none = Granted {
            fifo: Err("Operation not permitted".into()),
            locked: Err("the locked-memory limit is 8192 kB".into()),
        };
        let line = none.refusal_line().unwrap();
        assert!(!line.contains('\n'));
        assert!(line.contains("past the rig's watchdog"), "{line}");
        let unlocked = Granted {
            fifo: Ok(FIFO_PRIORITY),
            locked: Err("the locked-memory limit is 8192 kB".into()),
        };
        for fix in ["CAP_SYS_NICE", "ulimit -r", "chrt -f", "ulimit -l"] {
            assert!(line.contains(fix), "{line}");
        }
        let line = unlocked.refusal_line().unwrap();
        assert!(!line.contains("real-time priority"), "{line}");
        assert!(line.contains("ulimit -l"), "{line}");
    }

    /// A thread started by a real-time thread runs at normal priority (the log's writer, the
    /// live view), and one that follows it runs at its priority (the heartbeat). Where this
    /// process may not use SCHED_FIFO the test has nothing to check and says so.
    #[cfg(target_os = "linux")]
    #[test]
    fn threads_started_by_the_loop_run_at_normal_priority_unless_they_follow_it() {
        let checked = std::thread::spawn(|| {
            if set_fifo(FIFO_PRIORITY).is_err() {
                eprintln!("SCHED_FIFO refused here: nothing to check");
                return None;
            }
            let own = fifo_priority();
            let plain = std::thread::spawn(fifo_priority).join().unwrap();
            let followed = std::thread::spawn(move || {
                follow(own);
                fifo_priority()
            })
            .join()
            .unwrap();
            Some((own, plain, followed))
        })
        .join()
        .unwrap();
        if let Some((own, plain, followed)) = checked {
            assert_eq!(own, Some(FIFO_PRIORITY));
            assert_eq!(plain, None, "a plain thread inherited the loop's priority");
            assert_eq!(followed, Some(FIFO_PRIORITY));
        }
    }
}
