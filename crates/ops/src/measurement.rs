//! The measurement on any station (the simulator, a rig behind its link): the log
//! opened with the run's metadata, the sequence of [`measure::sequence`] (tare, payload change,
//! loaded run) told to the log and to an [`Operator`], the log finished however the sequence
//! ended, then the calibration the options ask for fitted and written, and the report built.
//! Every station's command returns the same [`Outcome`].
//!
//! What the operator sees of it goes through [`Operator`]: the samples' progress (it is a
//! [`measure::Observer`]), notes and warnings ([`Message`]). The library prints nothing.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use control::controller::Controller;
use kinematics::Geometry;
use measure::observer::{Both, Observer, TickEvent};
use measure::report::{Quantities, RunInfo};
use measure::sequence::{SequencePlan, TarePlan};
use measure::{End, Report, TareFile};
use rig_description::calibration::{CalibrationDocument, CalibrationFile, LoadCellFile};
use rig_description::config::ParamCount;
use rig_description::load::{ConfigError, ConfigIssue, LoadedConfig, Overrides};
use runlog::mcap_log::Delivery;
use runlog::metadata::{RunMetadata, TruthMsg};
use runlog::rig_record::{LinkCounters, TimingSummary};
use runlog::{LogObserver, RunLog};
use serde::{Deserialize, Serialize};

/// Why an operation failed; the binary maps each kind to its exit code.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The rig description (or a flag standing for one of its keys) was refused before anything
    /// ran.
    #[error("{0}")]
    Config(#[from] ConfigError),
    /// An input other than the rig description (a tare file, a key, the rig's handshake) was
    /// refused before anything moved.
    #[error("{0:#}")]
    Input(anyhow::Error),
    /// The run failed (backend, log, a calibration's fit).
    #[error("{0:#}")]
    Run(anyhow::Error),
}

/// A refused input, in words ([`Error::Input`]).
pub fn refuse(message: impl std::fmt::Display) -> Error {
    Error::Input(anyhow::anyhow!("{message}"))
}

/// A problem with an option that stands for a key of the rig description (a command-line
/// flag), blamed on the option by its name `flag`, not on a line of a file.
pub fn flag_issue(flag: &str, problem: String) -> ConfigIssue {
    ConfigIssue {
        file: rig_description::load::COMMAND_LINE_NAME.into(),
        line: None,
        key: flag.into(),
        problem,
    }
}

/// A calibration pass of `simulate` (`[calibration] measure_imu`, `measure_load_cells`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pass {
    /// The IMU's alignment on the empty fixture.
    Imu,
    /// The load cells' gains with the reference body.
    LoadCells,
}

/// What an operation tells its operator besides the samples' progress.
#[derive(Clone, Copy, Debug)]
pub enum Message<'a> {
    /// A remark a quiet front end leaves out.
    Note(&'a str),
    /// A warning a front end always shows.
    Warning(&'a str),
    /// The live view serves the run at this address.
    Live(SocketAddr),
    /// A calibration pass begins.
    PassStarted(Pass),
    /// A calibration pass wrote this IMU calibration to this file.
    ImuCalibrated(&'a CalibrationFile, &'a Path),
    /// A calibration pass wrote this load-cell calibration to this file.
    LoadCellsCalibrated(&'a LoadCellFile, &'a Path),
}

/// Who watches a measurement: the samples' progress ([`Observer`]), its bounds and its messages.
pub trait Operator: Observer {
    /// The measurement's runs begin; `total_samples` are expected.
    fn begin(&mut self, total_samples: u64) {
        let _ = total_samples;
    }

    /// The measurement's runs are over.
    fn end(&mut self) {}

    /// Something to tell.
    fn tell(&mut self, message: Message<'_>) {
        let _ = message;
    }
}

/// An operator who watches nothing: for a program or a test that wants the outcome alone.
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Observer for Silent {
    fn tick(&mut self, _: &TickEvent<'_>) -> anyhow::Result<()> {
        Ok(())
    }
}

impl Operator for Silent {}

/// `operator`'s warnings alone: what a calibration pass, run quietly beside the measurement,
/// passes on.
pub(crate) struct Quietly<'a>(pub &'a mut dyn Operator);

impl Observer for Quietly<'_> {
    fn tick(&mut self, _: &TickEvent<'_>) -> anyhow::Result<()> {
        Ok(())
    }
}

impl Operator for Quietly<'_> {
    fn tell(&mut self, message: Message<'_>) {
        if let Message::Warning(_) = message {
            self.0.tell(message);
        }
    }
}

/// The options of every measurement, whatever the station.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MeasureOptions {
    /// The rig description laid over the embedded default (configs/default.toml); `None`: the
    /// default.
    pub config: Option<PathBuf>,
    /// The parameter model instead of the description's `estimator.params`.
    pub params: Option<ParamCount>,
    /// An `[excitation]` table to move along (tare run included) instead of the description's.
    pub excitation: Option<PathBuf>,
    /// The loaded run's excitation time including the fades, s, instead of `run.duration_s`.
    pub duration_s: Option<f64>,
    /// The MCAP log; `None`: `runs/<UTC time>.mcap`.
    pub log: Option<PathBuf>,
    /// Serve the log's channels live (Foxglove WebSocket) at this address.
    pub live: Option<SocketAddr>,
    /// A saved tare (JSON) to subtract instead of a tare run.
    pub tare: Option<PathBuf>,
    /// Save the measured tare (JSON) here.
    pub save_tare: Option<PathBuf>,
}

impl MeasureOptions {
    /// The rig description with the excitation, duration and parameter model applied,
    /// validated.
    pub fn load_config(&self) -> Result<LoadedConfig, ConfigError> {
        let mut loaded = rig_description::load::load(self.config.as_deref())?;
        if let Some(path) = &self.excitation {
            loaded = loaded.with_excitation_file(path)?;
        }
        loaded.with_overrides(&Overrides {
            duration_s: self.duration_s,
            params: self.params,
        })
    }

    /// The log's path: [`log`](Self::log), or `runs/<UTC time>.mcap` for a run that starts
    /// at `start_ns`, with `-2`, `-3`, … when another run of that second took the name
    /// ([`runlog::mcap_log::default_log_path`]).
    pub fn log_path(&self, start_ns: u64) -> PathBuf {
        match &self.log {
            Some(p) => p.clone(),
            None => runlog::mcap_log::default_log_path(Path::new("runs"), start_ns / 1_000_000_000),
        }
    }

    /// Refuses a [`log`](Self::log) that names an existing file, before anything moves: a log
    /// is never written over ([`runlog::mcap_log::LogExists`]). The log's exclusive creation
    /// refuses it too; this check comes first so that nothing runs (a calibration pass, a
    /// handshake) for a run whose log cannot be written.
    pub fn check_log_free(&self) -> Result<(), Error> {
        match &self.log {
            Some(path) if path.exists() || path.is_symlink() => Err(Error::Input(
                runlog::mcap_log::LogExists(path.clone()).into(),
            )),
            _ => Ok(()),
        }
    }

    /// The measurement's tare: the saved tare of [`tare`](Self::tare) (checked against the
    /// design), or a tare run whose controller is built and checked now, before anything moves.
    pub fn tare_plan(&self, loaded: &LoadedConfig, geometry: &Geometry) -> Result<TarePlan, Error> {
        Ok(match &self.tare {
            Some(path) => {
                let (base, plate) = measure::sequence::joints(geometry);
                let file = TareFile::load(path, &base, &plate).map_err(Error::Input)?;
                TarePlan::File(Box::new(file), path.display().to_string())
            }
            None => {
                let t = measure::setup::tare_trajectory(loaded, geometry)?;
                TarePlan::Measure(Box::new(measure::setup::controller(
                    loaded,
                    geometry,
                    t,
                    measure::Measurement::Tare,
                )?))
            }
        })
    }
}

/// Tells `operator` about each calibration `config` applies that is older than its
/// `calibration.max_age_days`.
pub(crate) fn warn_old_calibrations(config: &rig_description::Config, operator: &mut dyn Operator) {
    let now_s = runlog::run_log::unix_now_ns() / 1_000_000_000;
    for w in config.calibration.age_warnings(now_s) {
        operator.tell(Message::Warning(&w));
    }
}

/// The link over one measurement on a rig.
#[derive(Clone, Debug, Serialize)]
pub struct LinkReport {
    /// `"tare"` or `"loaded"`.
    pub run: String,
    /// Counters over the measurement.
    pub counters: LinkCounters,
    /// The loop's timing.
    pub timing: TimingSummary,
}

/// What a station adds to the outcome once its measurement is over: a rig's link.
#[derive(Debug, Default)]
pub struct Closed {
    /// The link and loop timing of each measurement made, in order.
    pub link: Vec<LinkReport>,
    /// The link, sensor or rig failure that ended the run, with when the host noticed it.
    pub failure: Option<rig::monitored::Failure>,
    /// The rig as it described itself in the (last) handshake.
    pub rig: Option<rig::host::RigInfo>,
    /// The counters of the whole link, from the first handshake to the closing safe stop.
    pub link_total: rig::LinkStats,
}

/// What a measurement produced, on any station.
#[derive(Debug)]
pub struct Outcome {
    /// The report of the payload; `None` when the run ended before an estimate, measured a
    /// tare only, or was a rig's calibration.
    pub report: Option<Report>,
    /// The MCAP log written.
    pub log_path: PathBuf,
    /// How the run ended (anything but `Completed` is a non-zero exit).
    pub end: End,
    /// The tare measured here, if any.
    pub tare: Option<TareFile>,
    /// The IMU calibration written.
    pub calibration: Option<CalibrationFile>,
    /// The load-cell calibration written.
    pub load_cell_calibration: Option<LoadCellFile>,
    /// The link and loop timing of each measurement made on a rig, in order (empty on the
    /// simulator).
    pub link: Vec<LinkReport>,
    /// The link, sensor or rig failure that ended a rig's run, with when the host noticed it
    /// (kind `Stopped`: a second stop braked it at once).
    pub failure: Option<rig::monitored::Failure>,
    /// The rig as it described itself in the (last) handshake (`None` on the simulator).
    pub rig: Option<rig::host::RigInfo>,
    /// A rig's whole link, from the first handshake to the closing safe stop: unlike
    /// [`link`](Self::link) (each measurement's window) it includes the brake heartbeats sent
    /// between measurements and while the log is finished.
    pub link_total: rig::LinkStats,
    /// The run that ended the measurement ended by a stall (the rig braked): it may be repeated.
    pub stalled: bool,
    /// The runs a stall ended and the measurement repeated, in order (`rig.stall_retries`).
    pub repeated: Vec<Repeated>,
}

/// A run a stall ended, repeated in a new session of the rig protocol.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Repeated {
    /// Why it ended.
    pub cause: String,
    /// Its log, kept as the record of the stall.
    pub log: PathBuf,
}

impl Outcome {
    /// The report as JSON, with a rig's extras: `link` (per measurement: counters and loop
    /// timing) and `rig` (address, identity, sample period).
    pub fn report_json(&self) -> Option<String> {
        let report = self.report.as_ref()?;
        let Some(rig) = &self.rig else {
            return Some(report.to_json());
        };
        let mut value = serde_json::to_value(report).ok()?;
        if let Some(map) = value.as_object_mut() {
            map.insert(
                "link".into(),
                serde_json::to_value(&self.link).unwrap_or_default(),
            );
            map.insert(
                "rig".into(),
                serde_json::json!({
                    "address": rig.address,
                    "identity": rig.identity,
                    "sample_period_s": rig.sample_period_s,
                }),
            );
            if !self.repeated.is_empty() {
                map.insert(
                    "repeated".into(),
                    serde_json::to_value(&self.repeated).unwrap_or_default(),
                );
            }
        }
        Some(serde_json::to_string_pretty(&value).unwrap_or_default())
    }
}

/// A measurement's station: does its runs ([`measure::sequence::Station`]) and, when they
/// are over, leaves its backend safe and says what it adds to the outcome.
pub trait Station: measure::sequence::Station {
    /// The measurement's runs are over (`completed`: all of them completed), before the
    /// log is finished.
    fn measured(&mut self, completed: bool) {
        let _ = completed;
    }

    /// After the log is finished: closes the backend.
    fn close(self) -> Closed
    where
        Self: Sized,
    {
        Closed::default()
    }
}

/// The calibration a measurement is made for, written to the path.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Calibrate {
    /// None: a measurement.
    Nothing,
    /// The IMU's alignment, fitted on the tare run.
    Imu(PathBuf),
    /// The load cells' gains, fitted on the tare run and the reference's loaded run.
    LoadCells(PathBuf),
}

/// One measurement to run, everything checked.
pub(crate) struct Spec<'a> {
    /// The rig description.
    pub loaded: &'a LoadedConfig,
    /// The platform.
    pub geometry: Geometry,
    /// The tare.
    pub tare: TarePlan,
    /// The loaded run's controller; `None`: the tare only.
    pub loaded_controller: Option<Controller>,
    /// Save a measured tare here.
    pub save_tare: Option<&'a Path>,
    /// The log's path, and the run's start.
    pub log: (PathBuf, u64),
    /// How the log's writer keeps up, and how the live view is paced.
    pub delivery: (Delivery, runlog::Pace),
    /// Serve the log live here.
    pub live: Option<SocketAddr>,
    /// The command, as the log's metadata names it.
    pub command: &'a str,
    /// `"sim"` or `"rig"`.
    pub backend: &'static str,
    /// The world's seed (0 on a rig).
    pub seed: u64,
    /// The noise preset's name (`"rig"` on a rig).
    pub noise: &'a str,
    /// A rig's sample period from the handshake, instead of the description's.
    pub sample_period_s: Option<f64>,
    /// The simulator's truth, for `/run/truth`.
    pub truth_msg: Option<TruthMsg>,
    /// The payload's truth, for the report.
    pub truth: Option<Quantities>,
    /// The calibration to fit.
    pub calibrate: Calibrate,
    /// Whether a report is built (a rig's load-cell calibration measures no payload).
    pub report: bool,
}

/// Runs `spec`'s measurement on `station`: see the [module docs](self). `interrupt` parks the
/// platform; the outcome then says [`End::Interrupted`].
pub(crate) fn run<S: Station>(
    spec: Spec<'_>,
    mut station: S,
    operator: &mut dyn Operator,
    interrupt: &AtomicBool,
) -> Result<Outcome, Error> {
    let loaded = spec.loaded;
    let config = &loaded.config;
    let geometry = spec.geometry;
    let (log_path, start_ns) = spec.log;
    // The live view's address is bound before the log exists: a refused one leaves no log.
    let live = live::serve(spec.live, spec.delivery.1).map_err(Error::Input)?;
    let live_addr = live.as_ref().map(live::LiveServer::addr);
    let tap = live.map(live::LiveServer::into_tap);
    // A log whose name is taken is refused as an input: nothing has moved yet.
    let mut log =
        RunLog::create_tapped(&log_path, start_ns, spec.delivery.0, tap).map_err(|e| {
            if runlog::mcap_log::is_log_exists(&e) {
                Error::Input(e)
            } else {
                Error::Run(e)
            }
        })?;
    if let Some(addr) = live_addr {
        operator.tell(Message::Live(addr));
    }
    let mut runs = Vec::new();
    if matches!(spec.tare, TarePlan::Measure(_)) {
        runs.push("tare".to_string());
    }
    if spec.loaded_controller.is_some() {
        runs.push("loaded".to_string());
    }
    let described = RunMetadata::describing(loaded, &geometry, spec.command, spec.backend);
    let header = log
        .write_metadata(&RunMetadata {
            seed: spec.seed,
            noise: spec.noise.into(),
            sample_period_s: spec.sample_period_s.unwrap_or(described.sample_period_s),
            start_unix_ns: log.start_unix_ns(),
            runs,
            tare_file: match &spec.tare {
                TarePlan::File(_, path) => Some(path.clone()),
                TarePlan::Measure(_) => None,
            },
            ..described
        })
        .and_then(|()| match &spec.truth_msg {
            Some(truth) => log.write_now(runlog::messages::TRUTH, truth),
            None => Ok(()),
        });
    let total = match &spec.tare {
        TarePlan::Measure(c) => measure::run::expected_samples(config, c.trajectory()),
        TarePlan::File(..) => 0,
    } + spec.loaded_controller.as_ref().map_or(0, |c| {
        measure::run::expected_samples(config, c.trajectory())
    });
    let result = header.and_then(|()| {
        operator.begin(total);
        let mut observer = Both(
            LogObserver::new(&mut log, &geometry, config),
            &mut *operator,
        );
        measure::sequence::run(
            SequencePlan {
                config: loaded,
                geometry,
                tare: spec.tare,
                loaded: spec.loaded_controller,
                save_tare: spec.save_tare,
                backend: spec.backend,
            },
            &mut station,
            &mut observer,
            interrupt,
        )
    });
    operator.end();
    station.measured(matches!(result, Ok(ref o) if o.end == End::Completed));
    let dropped = log.dropped();
    let finished = log.finish();
    if dropped > 0 {
        operator.tell(Message::Warning(&format!(
            "the log's writer fell behind; {dropped} log messages were dropped rather than \
             stall the control loop (the gaps show in the MCAP sequence numbers)"
        )));
    }
    // The backend is left safe and closed before anything else can fail: the fits below are
    // the host's work alone.
    let closed = station.close();
    let sequence = result.map_err(Error::Run)?;
    finished.map_err(Error::Run)?;
    let completed = sequence.end == End::Completed;
    // Each fit is written as it is made: a later failure does not lose it.
    fn written<D: CalibrationDocument>(file: anyhow::Result<D>, path: &Path) -> Result<D, Error> {
        let file = file.map_err(Error::Run)?;
        file.write(path).map_err(Error::Run)?;
        Ok(file)
    }
    use crate::calibration::{imu_calibration, load_cell_calibration};
    let (backend, log) = (spec.backend, log_path.as_path());
    let (calibration, load_cell_calibration) = match &spec.calibrate {
        Calibrate::Imu(path) if completed => {
            let file = imu_calibration(&sequence, loaded, backend, start_ns, log);
            (Some(written(file, path)?), None)
        }
        Calibrate::LoadCells(path) if completed => {
            let file = load_cell_calibration(&sequence, loaded, backend, start_ns, log);
            (None, Some(written(file, path)?))
        }
        _ => (None, None),
    };
    let report = sequence
        .report(
            config,
            RunInfo {
                config: loaded.source.clone(),
                seed: spec.seed,
                noise: spec.noise.into(),
                params: config.estimator.params.into(),
                log: Some(log_path.display().to_string()),
                backend: spec.backend.into(),
                tool: rig_description::calibration::tool(),
                started_unix_s: Some(start_ns / 1_000_000_000),
                ended_unix_s: std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .ok()
                    .map(|d| d.as_secs()),
                calibrations: config.calibration.applied(),
                // The description's identification, hash and gravity: `report::build`'s.
                ..RunInfo::default()
            },
            spec.truth,
        )
        .filter(|_| spec.report);
    Ok(Outcome {
        report,
        log_path,
        end: sequence.end.clone(),
        tare: sequence.measured_tare().cloned(),
        calibration,
        load_cell_calibration,
        link: closed.link,
        failure: closed.failure,
        rig: closed.rig,
        link_total: closed.link_total,
        stalled: sequence.stalled,
        repeated: Vec::new(),
    })
}
