//! Where a measurement reports as it goes, in the manner of ripgrep's searcher and its `Sink`:
//! the procedure calls an [`Observer`] after every tick and at each step of the sequence, and the
//! observer decides what to make of it (an MCAP log, a progress bar, a live view, a GUI). The
//! procedure never waits on anything but the observer's return.
//!
//! Every method but [`Observer::tick`] has a default that does nothing. An error from any of
//! them ends the measurement with a best-effort safe stop, as a backend failure does.

use control::controller::TickOutput;
use control::io::{CommandFrame, SensorFrame};
use control::supervisor::Phase;
use estimator::{Estimate, EstimatorConfig, OnlineEstimator};
use kinematics::{FkOptions, Pose};

use crate::setup::Measurement;
use crate::tare::TareFile;
use crate::TareEstimate;

/// One tick of a measurement, as the observer sees it: everything the procedure knows then.
#[derive(Clone, Copy, Debug)]
pub struct TickEvent<'a> {
    /// Tare or loaded.
    pub measurement: Measurement,
    /// Ticks of this measurement before this one (the brake hold's included).
    pub index: u64,
    /// The sensor frame the backend gave.
    pub frame: &'a SensorFrame,
    /// The command written back.
    pub command: &'a CommandFrame,
    /// The controller's phase after the tick ([`Phase::Idle`] during the brake hold).
    pub phase: Phase,
    /// The controller's output (set-point, PIDs, fault); `None` during the brake hold, when
    /// the procedure itself holds the brakes.
    pub control: Option<&'a TickOutput>,
    /// The latest pose measured by forward kinematics (this frame's when it had one).
    pub pose: Option<&'a Pose>,
    /// The estimator, once the excitation has started.
    pub estimator: Option<&'a OnlineEstimator>,
    /// The tare to subtract for the payload alone (loaded measurements).
    pub tare: Option<&'a TareEstimate>,
    /// Stop was requested (Ctrl-C): the platform parks.
    pub interrupted: bool,
}

/// The estimator's fit window opened, on the first frame of the excitation (the estimator
/// itself exists from the measurement's first frame, warming its conditioning).
#[derive(Clone, Copy, Debug)]
pub struct EstimatorStarted<'a> {
    /// Tare or loaded.
    pub measurement: Measurement,
    /// Backend time of that frame, s.
    pub time_s: f64,
    /// Its settings (a replay of the log needs them).
    pub config: &'a EstimatorConfig,
    /// The forward kinematics options of the frame-to-sample rule.
    pub fk: &'a FkOptions,
}

/// The measurement ended (parked, faulted or interrupted).
#[derive(Clone, Copy, Debug)]
pub struct MeasurementEnded<'a> {
    /// Tare or loaded.
    pub measurement: Measurement,
    /// Backend time of the last frame, s.
    pub time_s: f64,
    /// The final estimate of everything on the plate, when the excitation started.
    pub estimate: Option<&'a Estimate>,
    /// The tare subtracted for the payload alone (loaded measurements).
    pub tare: Option<&'a TareEstimate>,
}

/// Receives the measurement's progress. See the [module docs](self).
pub trait Observer {
    /// A measurement begins (before its first frame is read).
    fn measurement_started(&mut self, measurement: Measurement) -> anyhow::Result<()> {
        let _ = measurement;
        Ok(())
    }

    /// One tick happened: the frame was read and the command written.
    fn tick(&mut self, event: &TickEvent<'_>) -> anyhow::Result<()>;

    /// The estimator's fit window opened at the start of the excitation.
    fn estimator_started(&mut self, event: &EstimatorStarted<'_>) -> anyhow::Result<()> {
        let _ = event;
        Ok(())
    }

    /// The measurement ended; whatever the observer buffers should reach its destination.
    fn measurement_ended(&mut self, event: &MeasurementEnded<'_>) -> anyhow::Result<()> {
        let _ = event;
        Ok(())
    }

    /// The tare the sequence subtracts: measured now (with its sensitivities) or from a file.
    fn tare(&mut self, tare: &TareFile) -> anyhow::Result<()> {
        let _ = tare;
        Ok(())
    }

    /// A safe stop was sent outside the loop's ticks (after a failure, a fault or a stop that
    /// ended the measurement early), answering the frame of backend time `time_s`: observers
    /// that log keep it with the ticks' commands, so that what was last on the wire can be read
    /// back from the record.
    fn safe_stop(
        &mut self,
        measurement: Measurement,
        time_s: f64,
        command: &CommandFrame,
    ) -> anyhow::Result<()> {
        let _ = (measurement, time_s, command);
        Ok(())
    }

    /// A record of the station's own (a rig's link counters), on `topic`, at backend time
    /// `time_s`: observers that log keep it, others ignore it.
    fn record(
        &mut self,
        topic: &'static str,
        time_s: f64,
        value: &serde_json::Value,
    ) -> anyhow::Result<()> {
        let _ = (topic, time_s, value);
        Ok(())
    }
}

/// Ignores everything: for a measurement whose result alone matters.
#[derive(Clone, Copy, Debug, Default)]
pub struct Ignore;

impl Observer for Ignore {
    fn tick(&mut self, _: &TickEvent<'_>) -> anyhow::Result<()> {
        Ok(())
    }
}

/// Two observers, told everything in turn (the first one first).
#[derive(Debug)]
pub struct Both<A, B>(pub A, pub B);

impl<A: Observer, B: Observer> Observer for Both<A, B> {
    fn measurement_started(&mut self, m: Measurement) -> anyhow::Result<()> {
        self.0.measurement_started(m)?;
        self.1.measurement_started(m)
    }
    fn tick(&mut self, e: &TickEvent<'_>) -> anyhow::Result<()> {
        self.0.tick(e)?;
        self.1.tick(e)
    }
    fn estimator_started(&mut self, e: &EstimatorStarted<'_>) -> anyhow::Result<()> {
        self.0.estimator_started(e)?;
        self.1.estimator_started(e)
    }
    fn measurement_ended(&mut self, e: &MeasurementEnded<'_>) -> anyhow::Result<()> {
        self.0.measurement_ended(e)?;
        self.1.measurement_ended(e)
    }
    fn tare(&mut self, t: &TareFile) -> anyhow::Result<()> {
        self.0.tare(t)?;
        self.1.tare(t)
    }
    fn safe_stop(&mut self, m: Measurement, t: f64, c: &CommandFrame) -> anyhow::Result<()> {
        self.0.safe_stop(m, t, c)?;
        self.1.safe_stop(m, t, c)
    }
    fn record(&mut self, topic: &'static str, t: f64, v: &serde_json::Value) -> anyhow::Result<()> {
        self.0.record(topic, t, v)?;
        self.1.record(topic, t, v)
    }
}

impl<O: Observer + ?Sized> Observer for &mut O {
    fn measurement_started(&mut self, m: Measurement) -> anyhow::Result<()> {
        (**self).measurement_started(m)
    }
    fn tick(&mut self, e: &TickEvent<'_>) -> anyhow::Result<()> {
        (**self).tick(e)
    }
    fn estimator_started(&mut self, e: &EstimatorStarted<'_>) -> anyhow::Result<()> {
        (**self).estimator_started(e)
    }
    fn measurement_ended(&mut self, e: &MeasurementEnded<'_>) -> anyhow::Result<()> {
        (**self).measurement_ended(e)
    }
    fn tare(&mut self, t: &TareFile) -> anyhow::Result<()> {
        (**self).tare(t)
    }
    fn safe_stop(&mut self, m: Measurement, t: f64, c: &CommandFrame) -> anyhow::Result<()> {
        (**self).safe_stop(m, t, c)
    }
    fn record(&mut self, topic: &'static str, t: f64, v: &serde_json::Value) -> anyhow::Result<()> {
        (**self).record(topic, t, v)
    }
}
