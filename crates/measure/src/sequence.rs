//! The sequence: the whole measurement of a payload, the same on every station.
//!
//! 1. **Tare**: the empty fixture is measured (a tare run), or a saved tare is loaded. A
//!    measured tare is handed to the observer and, when asked, saved at once, so a failure of
//!    the loaded run loses nothing of it.
//! 2. **Payload change** ([`Station::load_payload`]): only after a measured tare. The simulator
//!    puts the payload on; a rig brakes, asks the operator and opens a new session.
//! 3. **Loaded run**: fixture and payload, the tare subtracted for the payload alone.
//! 4. **Report** ([`SequenceOutcome::report`]): the payload with its uncertainty, the tare, the
//!    systematic part; each command adds how it ran (and a simulator its truth).
//!
//! A station is what runs the measurements: it owns the backend and may wrap each measurement
//! (a rig watches its link and logs its counters through [`Observer::record`]).

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{anyhow, Result};
use control::controller::Controller;
use control::io::Backend;
use kinematics::Geometry;

use crate::observer::Observer;
use crate::report::{self, Quantities, Report, ReportInputs, RunInfo, TareKind};
use crate::run::{measure, End, MeasureOutcome, MeasureSetup};
use crate::setup::{self, Measurement};
use crate::tare::TareFile;
use rig_description::load::LoadedConfig;

/// One measurement to run: what it measures, its controller (checked beforehand) and the stop
/// flag. A [`Station`] runs it on its backend with [`Job::run`].
pub struct Job<'a> {
    /// The measurement's settings.
    pub setup: MeasureSetup<'a>,
    /// Its controller, trajectory checked.
    pub controller: Controller,
    /// Set to park early (Ctrl-C).
    pub stop: &'a AtomicBool,
}

impl Job<'_> {
    /// Tare or loaded.
    pub fn measurement(&self) -> Measurement {
        self.setup.measurement
    }

    /// Runs the measurement on `backend` ([`measure`]).
    pub fn run<B, O>(self, backend: &mut B, observer: &mut O) -> Result<MeasureOutcome>
    where
        B: Backend,
        B::Error: std::fmt::Display,
        O: Observer + ?Sized,
    {
        measure(backend, &self.setup, self.controller, observer, self.stop)
    }
}

/// What runs a sequence's runs: a simulator, a rig behind a link, a user's hardware.
pub trait Station {
    /// Runs `job` on this station's backend ([`Job::run`]), wrapped as the station needs.
    fn measure<O: Observer>(&mut self, job: Job<'_>, observer: &mut O) -> Result<MeasureOutcome>;

    /// Between a measured tare and the loaded run: puts the payload on (a simulator swaps it
    /// in; a rig brakes and waits for the operator). `Ok(false)`: stopped while waiting.
    fn load_payload<O: Observer>(&mut self, observer: &mut O, stop: &AtomicBool) -> Result<bool>;
}

/// Where the sequence's tare comes from.
pub enum TarePlan {
    /// A tare run with this controller.
    Measure(Box<Controller>),
    /// A saved tare, read from this path.
    File(Box<TareFile>, String),
}

/// The tare run's effects of one datasheet sigma of accelerometer bias and of load-cell
/// offsets on its θ, and its error-budget inputs, kept for the loaded run's report.
#[derive(Clone, Debug, Default)]
pub struct TareEffects {
    /// Per accelerometer axis.
    pub accel: Option<[[f64; 10]; 3]>,
    /// Per load cell.
    pub load_cell: Option<[[f64; 10]; 6]>,
    /// The tare run's error-budget inputs ([`crate::budget`]).
    pub budget: Option<crate::budget::RunBudget>,
    /// The tare run's record, for the IMU calibration ([`rig_description::calibration::imu`]).
    pub record: Option<crate::record::RunRecord>,
    /// The accelerometer's offset the tare run measured at rest ([`MeasureOutcome`]).
    pub accel_offset_m_s2: Option<[f64; 3]>,
}

/// The tare a sequence subtracts.
#[derive(Clone, Debug)]
pub enum TareSource {
    /// Measured in this sequence, with its effects.
    Measured(TareFile, Box<TareEffects>),
    /// A saved tare, from this path.
    File(TareFile, String),
}

impl TareSource {
    /// The tare.
    pub fn file(&self) -> &TareFile {
        match self {
            Self::Measured(f, _) | Self::File(f, _) => f,
        }
    }
}

/// A whole sequence's settings.
pub struct SequencePlan<'a> {
    /// The rig description.
    pub config: &'a LoadedConfig,
    /// The platform design.
    pub geometry: Geometry,
    /// The tare.
    pub tare: TarePlan,
    /// The loaded run's controller; `None` measures the tare only.
    pub loaded: Option<Controller>,
    /// Save a measured tare here as soon as it is measured.
    pub save_tare: Option<&'a Path>,
    /// The station's name, recorded in a measured tare (`"sim"`, `"rig"`).
    pub backend: &'a str,
}

/// What a sequence produced.
#[derive(Clone, Debug)]
pub struct SequenceOutcome {
    /// How it ended: [`End::Completed`] when every planned measurement completed.
    pub end: End,
    /// The tare subtracted (or measured, for a tare-only sequence).
    pub tare: Option<TareSource>,
    /// The loaded run, when it ran.
    pub loaded: Option<MeasureOutcome>,
    /// The run that ended the sequence ended by a stall ([`MeasureOutcome::stall`]): the
    /// caller may repeat it.
    pub stalled: bool,
}

impl SequenceOutcome {
    /// The tare measured in this sequence, if any.
    pub fn measured_tare(&self) -> Option<&TareFile> {
        match &self.tare {
            Some(TareSource::Measured(f, _)) => Some(f),
            _ => None,
        }
    }

    /// The report of the payload alone, when the loaded run completed with an estimate: the
    /// loaded estimate minus the tare with the systematic part of `config`'s datasheet, how the
    /// run was made (`run`) and the truth where it is known.
    pub fn report(
        &self,
        config: &rig_description::config::Config,
        run: RunInfo,
        truth: Option<Quantities>,
    ) -> Option<Report> {
        if self.end != End::Completed {
            return None;
        }
        let loaded = self.loaded.as_ref()?;
        let estimate = loaded.estimate.as_ref()?;
        let tare = self.tare.as_ref()?;
        let (kind, path, effects) = match tare {
            TareSource::Measured(_, e) => (TareKind::Measured, None, (**e).clone()),
            TareSource::File(_, p) => (TareKind::File, Some(p.clone()), TareEffects::default()),
        };
        Some(report::build(&ReportInputs {
            loaded: estimate,
            theta_history: &loaded.theta_history,
            excitation_s: loaded.excitation_s,
            fk_failures: loaded.fk_failures,
            tare: tare.file(),
            tare_kind: kind,
            tare_path: path,
            loaded_budget: loaded.budget.as_ref(),
            tare_budget: effects.budget.as_ref(),
            accel_bias_sigma_m_s2: setup::accel_bias_sigma(config),
            load_cell_bias_sigma_n: setup::load_cell_bias_sigma(config),
            params: config.estimator.params,
            truth,
            run,
            loaded_weighing: loaded.static_weighing.as_ref(),
            description: Some(config),
        }))
    }
}

/// Base and plate joints as arrays, as tare files and logs store them.
pub fn joints(g: &Geometry) -> ([[f64; 3]; 6], [[f64; 3]; 6]) {
    (
        g.base_joints_m().map(|v| [v.x, v.y, v.z]),
        g.plate_joints_m().map(|v| [v.x, v.y, v.z]),
    )
}

/// Runs the sequence of `plan` on `station`, telling `observer` everything. See the
/// [module docs](self). Errors are station, observer or file failures; a fault or a stop ends
/// the sequence normally with that [`End`].
pub fn run<S: Station, O: Observer>(
    plan: SequencePlan<'_>,
    station: &mut S,
    observer: &mut O,
    stop: &AtomicBool,
) -> Result<SequenceOutcome> {
    let config = &plan.config.config;
    let setup = |measurement, tare| MeasureSetup {
        config,
        geometry: plan.geometry,
        measurement,
        tare,
    };
    let (tare, measured) = match plan.tare {
        TarePlan::File(file, path) => {
            observer.tare(&file)?;
            (TareSource::File(*file, path), false)
        }
        TarePlan::Measure(controller) => {
            let outcome = station.measure(
                Job {
                    setup: setup(Measurement::Tare, None),
                    controller: *controller,
                    stop,
                },
                observer,
            )?;
            if outcome.end != End::Completed {
                return Ok(SequenceOutcome {
                    end: outcome.end,
                    tare: None,
                    loaded: None,
                    stalled: outcome.stall,
                });
            }
            let estimate = outcome
                .estimate
                .as_ref()
                .ok_or_else(|| anyhow!("the tare run produced no estimate"))?;
            let effects = TareEffects {
                accel: outcome.accel_bias_effect,
                load_cell: outcome.load_cell_bias_effect,
                budget: outcome.budget.clone(),
                record: outcome.record.clone(),
                accel_offset_m_s2: outcome.accel_offset_m_s2,
            };
            let (base, plate) = joints(&plan.geometry);
            // With the run's sensitivities, so a saved tare reused later counts its share of
            // the systematic part as this same-sequence tare does.
            let file =
                TareFile::from_estimate(estimate, &base, &plate, &plan.config.source, plan.backend)
                    .with_bias_effects(
                        effects.accel.as_ref(),
                        setup::accel_bias_sigma(config),
                        effects.load_cell.as_ref(),
                        setup::load_cell_bias_sigma(config),
                    )
                    .with_budget(effects.budget.clone())
                    .with_static_weighing(outcome.static_weighing.clone());
            observer.tare(&file)?;
            if let Some(path) = plan.save_tare {
                file.save(path)?;
            }
            (TareSource::Measured(file, Box::new(effects)), true)
        }
    };
    let Some(controller) = plan.loaded else {
        return Ok(SequenceOutcome {
            end: End::Completed,
            tare: Some(tare),
            loaded: None,
            stalled: false,
        });
    };
    if measured && !station.load_payload(observer, stop)? {
        return Ok(SequenceOutcome {
            end: End::Interrupted,
            tare: Some(tare),
            loaded: None,
            stalled: false,
        });
    }
    if stop.load(Ordering::SeqCst) {
        return Ok(SequenceOutcome {
            end: End::Interrupted,
            tare: Some(tare),
            loaded: None,
            stalled: false,
        });
    }
    let tare_estimate = (tare.file().parameters(), tare.file().covariance_matrix());
    let outcome = station.measure(
        Job {
            setup: setup(Measurement::Loaded, Some(&tare_estimate)),
            controller,
            stop,
        },
        observer,
    )?;
    Ok(SequenceOutcome {
        end: outcome.end.clone(),
        stalled: outcome.stall,
        tare: Some(tare),
        loaded: Some(outcome),
    })
}
