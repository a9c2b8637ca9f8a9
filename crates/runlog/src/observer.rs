//! The [`Observer`] that writes a measurement into the run's MCAP log: every sensor frame and
//! command (in blocks, [`crate::compact`]); pose, legs and PID terms at [`rates::DERIVED_HZ`];
//! the platform's transform at [`rates::TF_HZ`]; the estimate and the payload's transform at
//! [`rates::ESTIMATE_HZ`]; the scene at [`rates::SCENE_HZ`]; the supervisor on
//! every change and at [`rates::SUPERVISOR_HZ`]; the estimator's settings at the excitation's
//! start, repeated while it runs and at its end ([`RunLog::write_settings`]); the tare and the
//! station's own records once.

use control::supervisor::Phase;
use estimator::Estimate;
use kinematics::{Geometry, Pose};
use measure::observer::{EstimatorStarted, MeasurementEnded, Observer, TickEvent};
use measure::run::payload_estimate;
use measure::tare::TareFile;
use measure::{Measurement, TareEstimate};
use rig_description::Config;

use crate::foxglove::{self, InertiaEllipsoid, SceneGeometry};
use crate::messages::{
    self as topics, BodyEstimate, EstimateMsg, LegsMsg, PidMsg, PoseMsg, PoseValue, SupervisorMsg,
};
use crate::metadata::EstimatorSettings;
use crate::run_log::{rates, RunLog};

/// Writes measurements into `log`. See the [module docs](self).
pub struct LogObserver<'a> {
    log: &'a mut RunLog,
    scene: SceneGeometry,
    home: Pose,
    derived_every: u64,
    estimate_every: u64,
    tf_every: u64,
    scene_every: u64,
    supervisor_every: u64,
    last_phase: Option<Phase>,
    last_fault: Option<String>,
}

fn every(rate_hz: f64, sample_rate_hz: f64) -> u64 {
    ((sample_rate_hz / rate_hz).round() as u64).max(1)
}

impl<'a> LogObserver<'a> {
    /// Logs into `log` the measurements of the rig `config` describes, with `geometry`.
    pub fn new(log: &'a mut RunLog, geometry: &Geometry, config: &Config) -> Self {
        let scene = SceneGeometry {
            base_joints_m: *geometry.base_joints_m(),
            plate_joints_m: *geometry.plate_joints_m(),
            base_radius_m: mean_radius(geometry.base_joints_m()),
            plate_radius_m: mean_radius(geometry.plate_joints_m()),
            force_scale_n: config.control.max_force_n,
        };
        let sample_rate_hz = config.sensors.sample_rate_hz;
        Self {
            log,
            scene,
            home: geometry.home_pose(),
            derived_every: every(rates::DERIVED_HZ, sample_rate_hz),
            estimate_every: every(rates::ESTIMATE_HZ, sample_rate_hz),
            tf_every: every(rates::TF_HZ, sample_rate_hz),
            scene_every: every(rates::SCENE_HZ, sample_rate_hz),
            supervisor_every: every(rates::SUPERVISOR_HZ, sample_rate_hz),
            last_phase: None,
            last_fault: None,
        }
    }

    /// The log.
    pub fn log(&mut self) -> &mut RunLog {
        self.log
    }

    fn derived(&mut self, e: &TickEvent<'_>, pose: &Pose) -> anyhow::Result<()> {
        let (run, t) = (e.measurement.name(), e.frame.time_s);
        let Some(out) = e.control else {
            return Ok(());
        };
        if e.index.is_multiple_of(self.derived_every) {
            self.log.write_proto(
                topics::POSE,
                t,
                &PoseMsg {
                    run,
                    time_s: t,
                    desired: PoseValue::new(&out.desired.pose),
                    measured: PoseValue::new(pose),
                },
            )?;
            let error_m =
                core::array::from_fn(|i| out.desired_leg_lengths_m[i] - e.frame.leg_lengths_m[i]);
            self.log.write_proto(
                topics::LEGS,
                t,
                &LegsMsg {
                    run,
                    time_s: t,
                    desired_length_m: out.desired_leg_lengths_m,
                    measured_length_m: e.frame.leg_lengths_m,
                    error_m,
                    command_force_n: e.command.leg_forces_n,
                    measured_force_n: e.frame.leg_forces_n,
                },
            )?;
            self.log
                .write_proto(topics::PID, t, &PidMsg::new(run, t, &out.pid))?;
        }
        if e.index.is_multiple_of(self.tf_every) {
            let time = foxglove::timestamp(self.log.time_ns(t));
            let tf = foxglove::platform_transform(time, pose.position_m, &pose.rotation);
            self.log.write_foxglove(topics::TF, t, &tf)?;
        }
        Ok(())
    }

    fn estimate(&mut self, e: &TickEvent<'_>, estimate: &Estimate) -> anyhow::Result<()> {
        let (run, t) = (e.measurement.name(), e.frame.time_s);
        self.log
            .write(topics::ESTIMATE, t, &estimate_msg(run, t, estimate, e.tare))?;
        // platform → payload_com: the payload's estimated centre of mass and axes.
        if let Some(tare) = e.tare {
            let p = payload_estimate(estimate, Some(tare));
            let time = foxglove::timestamp(self.log.time_ns(t));
            let body = InertiaEllipsoid {
                mass_kg: p.parameters.mass_kg,
                com_m: p.com_m,
                inertia_com_kg_m2: p.inertia_com_kg_m2,
            };
            if let Some(tf) = foxglove::payload_transform(time, &body) {
                self.log.write_foxglove(topics::TF_PAYLOAD, t, &tf)?;
            }
        }
        Ok(())
    }

    fn scene(
        &mut self,
        e: &TickEvent<'_>,
        pose: Option<&Pose>,
        estimate: Option<&Estimate>,
    ) -> anyhow::Result<()> {
        let payload = estimate.map(|est| payload_estimate(est, e.tare));
        let ellipsoid = payload.as_ref().and_then(|p| {
            (p.parameters.mass_kg > 0.0 && p.com_m.iter().all(|v| v.is_finite())).then_some(
                InertiaEllipsoid {
                    mass_kg: p.parameters.mass_kg,
                    com_m: p.com_m,
                    inertia_com_kg_m2: p.inertia_com_kg_m2,
                },
            )
        });
        let pose = pose.copied().unwrap_or(self.home);
        let time = foxglove::timestamp(self.log.time_ns(e.frame.time_s));
        let scene = foxglove::scene(
            time,
            &self.scene,
            pose.position_m,
            &pose.rotation,
            &e.frame.leg_forces_n,
            ellipsoid.as_ref(),
        );
        self.log
            .write_foxglove(topics::SCENE, e.frame.time_s, &scene)
    }

    fn supervisor(&mut self, e: &TickEvent<'_>) -> anyhow::Result<()> {
        let fault = e.control.and_then(|c| c.fault).map(|f| f.to_string());
        let clamped = e.control.is_some_and(|c| c.clamped);
        let changed = self.last_phase != Some(e.phase) || self.last_fault != fault;
        if changed || clamped || e.index.is_multiple_of(self.supervisor_every) {
            self.last_phase = Some(e.phase);
            self.last_fault.clone_from(&fault);
            let t = e.frame.time_s;
            self.log.write(
                topics::SUPERVISOR,
                t,
                &SupervisorMsg {
                    run: e.measurement.name(),
                    time_s: t,
                    phase: e.phase.name().to_string(),
                    fault,
                    clamped,
                    interrupted: e.interrupted,
                },
            )?;
        }
        Ok(())
    }
}

impl Observer for LogObserver<'_> {
    fn measurement_started(&mut self, _: Measurement) -> anyhow::Result<()> {
        self.last_phase = None;
        self.last_fault = None;
        Ok(())
    }

    fn tick(&mut self, e: &TickEvent<'_>) -> anyhow::Result<()> {
        let (run, t) = (e.measurement.name(), e.frame.time_s);
        self.log.write_sensor(run, e.frame)?;
        self.log.write_command(run, t, e.command)?;
        if let Some(pose) = e.pose {
            self.derived(e, pose)?;
        }
        let estimate_due = e.index.is_multiple_of(self.estimate_every);
        let scene_due = e.index.is_multiple_of(self.scene_every);
        // One estimate (with its covariance) serves both channels when both are due.
        let estimate = if estimate_due || scene_due {
            e.estimator.map(|est| est.estimate())
        } else {
            None
        };
        if let (true, Some(est)) = (estimate_due, estimate.as_ref()) {
            self.estimate(e, est)?;
        }
        if scene_due {
            self.scene(e, e.pose, estimate.as_ref())?;
        }
        self.supervisor(e)
    }

    fn estimator_started(&mut self, e: &EstimatorStarted<'_>) -> anyhow::Result<()> {
        let run = e.measurement.name();
        self.log.write_settings(
            e.time_s,
            &EstimatorSettings::from_config(run, e.config, e.fk),
        )
    }

    fn measurement_ended(&mut self, e: &MeasurementEnded<'_>) -> anyhow::Result<()> {
        if let Some(estimate) = e.estimate {
            let run = e.measurement.name();
            self.log.write(
                topics::ESTIMATE,
                e.time_s,
                &estimate_msg(run, e.time_s, estimate, e.tare),
            )?;
        }
        self.log.end_settings()?;
        self.log.flush()
    }

    fn tare(&mut self, tare: &TareFile) -> anyhow::Result<()> {
        self.log.write_now(topics::TARE, tare)
    }

    fn safe_stop(
        &mut self,
        measurement: Measurement,
        time_s: f64,
        command: &control::io::CommandFrame,
    ) -> anyhow::Result<()> {
        self.log
            .write_command(measurement.name(), time_s, command)?;
        // A safe stop ends the measurement: its record goes to the file at once.
        self.log.flush()
    }

    fn record(
        &mut self,
        topic: &'static str,
        time_s: f64,
        value: &serde_json::Value,
    ) -> anyhow::Result<()> {
        if topic == crate::rig_record::LINK {
            // Only the log knows how many of its messages it dropped so far.
            let mut value = value.clone();
            if let Some(map) = value.as_object_mut() {
                map.insert("log_dropped".into(), self.log.dropped().into());
            }
            return self.log.write(topic, time_s, &value);
        }
        self.log.write(topic, time_s, value)
    }
}

fn estimate_msg(
    run: &'static str,
    time_s: f64,
    e: &Estimate,
    tare: Option<&TareEstimate>,
) -> EstimateMsg {
    EstimateMsg {
        run,
        time_s,
        samples: e.counts.used,
        rejected: e.counts.rejected,
        theta: e.parameters.to_vector().into(),
        theta_sigma: e.parameter_sigma.into(),
        residual_rms: e.residual_rms.into(),
        body: BodyEstimate::new(e),
        payload: tare.map(|t| BodyEstimate::new(&payload_estimate(e, Some(t)))),
    }
}

/// Mean distance of six joints from their body's z axis, m: the joint circle a scene draws.
fn mean_radius(joints: &[nalgebra::Vector3<f64>; 6]) -> f64 {
    joints.iter().map(|p| p.xy().norm()).sum::<f64>() / 6.0
}
