//! The rig as a measurement's station: each measurement runs on the monitored link (first failure
//! and loop timing kept) between two `/rig/link` records, and the payload change brakes the rig,
//! asks the operator and opens the loaded run's session.

use runlog::compact::AtLogResolution;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::anyhow;
use control::io::{Backend, CommandFrame};
use measure::observer::Observer;
use measure::sequence::{Job, Station};
use measure::{End, MeasureOutcome};
use rig_description::LoadedConfig;
use runlog::messages::{self as topics, SupervisorMsg};
use runlog::rig_record::{LinkCounters, LinkMsg, LINK};

use super::Attendant;
use crate::measurement::{Closed, LinkReport};
use rig::monitored::{Failure, Link, LoopTiming, Monitored};

/// See the [module docs](self).
pub(super) struct RigStation<'a> {
    link: Link,
    loaded: &'a LoadedConfig,
    attendant: &'a mut dyn Attendant,
    body: &'static str,
    abort: &'a AtomicBool,
    reports: Vec<LinkReport>,
    failure: Option<Failure>,
}

impl<'a> RigStation<'a> {
    /// The station on `link` for the rig `loaded` describes; `attendant` puts `body` on between
    /// the runs; `abort` (a second Ctrl-C) brakes at once and ends the measurement as
    /// interrupted, without the park ramp.
    pub(super) fn new(
        link: Link,
        loaded: &'a LoadedConfig,
        body: &'static str,
        attendant: &'a mut dyn Attendant,
        abort: &'a AtomicBool,
    ) -> Self {
        Self {
            link,
            loaded,
            attendant,
            body,
            abort,
            reports: Vec::new(),
            failure: None,
        }
    }
}

fn record<O: Observer>(observer: &mut O, time_s: f64, msg: &LinkMsg) -> anyhow::Result<()> {
    observer.record(LINK, time_s, &serde_json::to_value(msg)?)
}

impl Station for RigStation<'_> {
    fn measure<O: Observer>(
        &mut self,
        job: Job<'_>,
        observer: &mut O,
    ) -> anyhow::Result<MeasureOutcome> {
        let measurement = job.measurement();
        let run = measurement.name();
        let stop = job.stop;
        let (info, before) = {
            let held = self.link.lock();
            (held.rig.info().clone(), *held.rig.stats())
        };
        let mut msg = LinkMsg {
            run,
            time_s: 0.0,
            event: "session",
            address: info.address.clone(),
            identity: info.identity.clone(),
            session_id: info.session_id,
            counters: LinkCounters::default(),
            timing: None,
            log_dropped: 0,
            fault: None,
        };
        record(observer, 0.0, &msg)?;
        let mut timing = LoopTiming::default();
        let (result, failure, last_time_s, lateness) = {
            let mut monitored = Monitored::new(&self.link, &mut timing).abort(self.abort);
            // Read at the log's resolution: the estimator uses the numbers the log holds.
            let result = job.run(&mut AtLogResolution(&mut monitored), observer);
            (
                result,
                monitored.failure().cloned(),
                monitored.last_time_s(),
                monitored.lateness(),
            )
        };
        let (counters, period_s) = {
            let held = self.link.lock();
            (
                LinkCounters::from(held.rig.stats().since(&before)),
                held.rig.sample_period_s(),
            )
        };
        let summary = timing.summary(period_s);
        let outcome = match result {
            Ok(o) => o,
            // The link, the sensors or the rig failed: the backend has sent a safe stop.
            Err(e) => match &failure {
                // Braked at the operator's word, not by a fault.
                Some(f) if f.kind == rig::ErrorKind::Stopped => {
                    MeasureOutcome::ended_early(End::Interrupted, 0)
                }
                Some(f) => MeasureOutcome {
                    stall: f.stall,
                    ..MeasureOutcome::ended_early(End::Fault(f.cause.clone()), 0)
                },
                None => {
                    if let Ok(sent) = self.link.lock().safe_stop() {
                        let time_s = last_time_s.unwrap_or(0.0);
                        let _ = observer.safe_stop(measurement, time_s, &CommandFrame::from(&sent));
                    }
                    return Err(e);
                }
            },
        };
        if outcome.end != End::Completed {
            // The run ended early: brake, and keep the brake's command with the loop's.
            let sent = self.link.lock().safe_stop()?;
            let time_s = last_time_s.unwrap_or(0.0);
            observer.safe_stop(measurement, time_s, &CommandFrame::from(&sent))?;
        }
        let mut outcome = outcome;
        if let End::Fault(cause) = &outcome.end {
            // A supervisor fault (a sensor gap, most often) after the host itself stalled past
            // the rig's watchdog says so, with the fix; a rig WATCHDOG fault says it already.
            if lateness.times > 0 && !cause.contains("this host was late") {
                let watchdog = self.link.lock().rig.info().watchdog;
                outcome.end = End::Fault(format!("{cause}; {}", lateness.explain(watchdog)));
            }
        }
        let time_s = last_time_s.unwrap_or(0.0);
        if let (Some(f), End::Fault(cause)) = (&failure, &outcome.end) {
            let supervisor = SupervisorMsg {
                run,
                time_s,
                phase: "fault".into(),
                fault: Some(cause.clone()),
                clamped: false,
                interrupted: stop.load(Ordering::SeqCst),
            };
            observer.record(
                topics::SUPERVISOR,
                time_s,
                &serde_json::to_value(&supervisor)?,
            )?;
            self.failure = Some(f.clone());
        }
        if let (Some(f), End::Interrupted) = (&failure, &outcome.end) {
            // Braked at once by a second stop: kept, so that what was done can be told.
            self.failure = Some(f.clone());
        }
        msg.time_s = time_s;
        msg.event = "end";
        msg.counters = counters;
        msg.timing = Some(summary);
        msg.fault = match (&outcome.end, &failure) {
            (End::Fault(cause), _) => Some(cause.clone()),
            (_, Some(f)) => Some(f.cause.clone()),
            _ => None,
        };
        record(observer, time_s, &msg)?;
        self.reports.push(LinkReport {
            run: run.to_string(),
            counters,
            timing: summary,
        });
        Ok(outcome)
    }

    fn load_payload<O: Observer>(&mut self, _: &mut O, stop: &AtomicBool) -> anyhow::Result<bool> {
        // The tare's session ends braked; the payload (or the reference) goes on; a new
        // session begins.
        self.link.lock().safe_stop()?;
        let confirmed = self.attendant.put_on(self.body, stop)?;
        if !confirmed {
            return Ok(false);
        }
        let mut held = self.link.lock();
        held.rig
            .restart_session()
            .map_err(|e| anyhow!("cannot open the loaded run's session: {e}"))?;
        super::check_rig(held.rig.info(), self.loaded).map_err(|e| anyhow!("{e}"))?;
        Ok(true)
    }
}

impl crate::measurement::Station for RigStation<'_> {
    /// Whatever happened, the rig is left braked.
    fn measured(&mut self, completed: bool) {
        if !completed {
            let _ = self.link.lock().safe_stop();
        }
    }

    fn close(self) -> Closed {
        let (info, link_total) = self.link.close();
        Closed {
            link: self.reports,
            failure: self.failure,
            rig: Some(info),
            link_total,
        }
    }
}
