//! The host's measurement on a rig behind the wire protocol (a real platform's I/O controller,
//! or the emulator): the same sequence, log and report as the simulator's minus the truth, plus
//! the link's counters and the loop's timing.
//!
//! Plans ([`RigPlan`]): tare run, the operator puts the payload on, loaded run; tare only;
//! loaded run with a saved tare; the calibrations (the empty fixture's run for the IMU; tare
//! run, the reference weight on, loaded run for the load cells; docs/calibration.md). Each
//! measurement is one session of the protocol: the tare's session ends braked, and the loaded
//! run opens a new one once the operator confirms the payload is on ([`Attendant`]).
//!
//! Before anything moves: the rig description, the trajectories, the tare file and the key are
//! checked, then the handshake (protocol version, sensor layout, sample period, accelerometer
//! position, and the rig's stroke and speed limits against the description, [`check_rig`]).
//! After that, any link silence longer than `rig.link_silence_ms`, an invalid sensor value, a
//! fault reported by the rig or a supervisor limit ends the measurement with a safe stop, the
//! log finished and the outcome saying [`measure::End::Fault`]. Commands are clamped to the
//! tighter of the rig's force limits and `control.max_force_n` whatever the controller computes.

mod station;

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use control::io::Backend;
use measure::sequence::TarePlan;
use measure::setup;
use rig::monitored::Link;
use rig::{RigBackend, RigOptions as HostOptions};
use rig_description::load::{ConfigError, LoadedConfig};
use runlog::mcap_log::Delivery;
use serde::{Deserialize, Serialize};

use crate::measurement::{
    self, flag_issue, refuse, Calibrate, Error, LinkReport, MeasureOptions, Message, Operator,
    Outcome, Repeated, Spec,
};

/// What the noise preset of a rig's metadata and report says: the rig's sensors are what they
/// are.
pub const NOISE: &str = "rig";

/// What a rig measurement does.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum RigPlan {
    /// Tare run, payload on, loaded run.
    #[default]
    Both,
    /// Tare run only, saved to the path.
    TareOnly(PathBuf),
    /// The empty fixture's run, fitted as the IMU calibration written to the path.
    CalibrateImu(PathBuf),
    /// Tare run, reference weight on, loaded run, fitted as the load-cell calibration written
    /// to the path.
    CalibrateLoadCells(PathBuf),
    /// Loaded run with the saved tare of [`MeasureOptions::tare`].
    MeasureOnly,
}

/// How to reach the rig, over the description's `[rig]` table.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LinkOptions {
    /// The rig's address (udp://HOST:PORT or serial:///dev/DEVICE?baud=N) instead of
    /// `rig.address`.
    pub connect: Option<String>,
    /// Fault when no valid sensor frame arrived for this long, ms, instead of
    /// `rig.link_silence_ms`.
    pub link_silence_ms: Option<f64>,
}

/// A rig measurement's options.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RigOptions {
    /// What to do.
    pub plan: RigPlan,
    /// The measurement's options.
    pub measure: MeasureOptions,
    /// How to reach the rig.
    pub link: LinkOptions,
}

/// The people and the files at the rig that the measurement needs besides its options.
pub trait Attendant {
    /// Between the tare and the loaded run, the platform braked: `body` ("the payload", "the
    /// reference weight …") goes on. `Ok(false)`: stopped while waiting (`stop` set).
    fn put_on(&mut self, body: &str, stop: &AtomicBool) -> anyhow::Result<bool>;

    /// The shared key of the link, given the key file the rig description names
    /// (`rig.key_file`, resolved against its directory); `None`: an insecure link.
    fn shared_key(&mut self, configured: Option<PathBuf>) -> Result<Option<rig::Key>, Error>;
}

/// The link settings of a run: the address and the host's options.
#[derive(Clone, Debug)]
pub struct LinkSettings {
    /// The rig's address.
    pub address: String,
    /// The host's options (key loaded).
    pub options: HostOptions,
}

/// The `[rig]` table of `loaded` with `link` applied, checked, and the key chosen by
/// `attendant`.
pub fn link_settings(
    loaded: &LoadedConfig,
    link: &LinkOptions,
    attendant: &mut dyn Attendant,
) -> Result<LinkSettings, Error> {
    let config = &loaded.config;
    let mut rig_config = config.rig.clone();
    let mut issues = Vec::new();
    if let Some(address) = &link.connect {
        if let Err(e) = address.parse::<rig::transport::Address>() {
            issues.push(flag_issue("--connect", e.to_string()));
        }
        rig_config.address = address.clone();
    }
    if let Some(ms) = link.link_silence_ms {
        if let Some(problem) = rig_description::range::ranges::LINK_SILENCE_MS.problem(ms) {
            issues.push(flag_issue("--link-silence-ms", problem));
        }
        rig_config.link_silence_ms = ms;
    }
    if issues.is_empty() {
        issues.extend(
            rig_config
                .problems()
                .into_iter()
                .map(|(key, problem)| loaded.issue(&key, problem)),
        );
    }
    if !issues.is_empty() {
        return Err(Error::Config(ConfigError { issues }));
    }
    let key = attendant.shared_key(rig_config.key_path(&loaded.directory()))?;
    let options = HostOptions {
        link_silence: Duration::from_secs_f64(rig_config.link_silence_ms * 1e-3),
        handshake_timeout: Duration::from_secs_f64(rig_config.handshake_timeout_s),
        key,
        require_imu: true,
        accel_position_m: Some(config.sensors.imu.position_m),
        sample_period_s: Some(1.0 / config.sensors.sample_rate_hz),
        force_limit_n: Some(config.control.max_force_n),
        ..HostOptions::default()
    };
    Ok(LinkSettings {
        address: rig_config.address,
        options,
    })
}

/// Refuses a rig whose limits do not fit the description the trajectories were checked
/// against (before any command is sent).
pub fn check_rig(info: &rig::host::RigInfo, loaded: &LoadedConfig) -> Result<(), Error> {
    let c = &loaded.config;
    let l = &info.limits;
    let (min_m, max_m) = (c.platform.min_leg_length_m, c.platform.max_leg_length_m);
    if (l.stroke_min_m - min_m).abs() > 1e-3 || (l.stroke_max_m - max_m).abs() > 1e-3 {
        return Err(refuse(format!(
            "rig layout mismatch: the rig's legs stroke from {} to {} m, the configuration's \
             from {min_m} to {max_m} m (platform.min_leg_length_m, platform.max_leg_length_m); \
             refusing the measurement",
            l.stroke_min_m, l.stroke_max_m
        )));
    }
    let speed = c.excitation.max_leg_speed_m_s;
    if l.speed_max_m_s < speed {
        return Err(refuse(format!(
            "rig layout mismatch: the excitation may move a leg at {speed} m/s \
             (excitation.max_leg_speed_m_s) but the rig allows {} m/s; refusing the measurement",
            l.speed_max_m_s
        )));
    }
    Ok(())
}

/// Readies `loaded` for `plan`. A calibration fits the raw readings: the IMU's calibration is
/// left out of the IMU calibration's run, the load cells' out of the load-cell calibration's
/// runs (which also need the reference's known mass). Otherwise a description asking for an
/// IMU or load-cell calibration each run (a simulator's feature) is told how to calibrate a rig.
fn prepare(
    plan: &RigPlan,
    loaded: &mut LoadedConfig,
    operator: &mut dyn Operator,
) -> Result<(), Error> {
    let calibrating_cells = matches!(plan, RigPlan::CalibrateLoadCells(_));
    if matches!(plan, RigPlan::CalibrateImu(_)) {
        // The calibration fits the raw readings: nothing of an older calibration applied.
        loaded.config.calibration.imu = None;
        loaded.config.calibration.imu_file = None;
    } else if calibrating_cells {
        crate::calibration::prepare_reference_runs(loaded)?;
    } else if loaded.config.calibration.calibrates_imu_each_run()
        && loaded.file_sets("calibration.measure_imu")
    {
        operator.tell(Message::Note(
            "calibration.measure_imu calibrates the IMU in `stewart simulate` only; on a rig, \
             run `stewart rig calibrate-imu --out FILE` once and set calibration.imu = \"FILE\" \
             (the budget counts the IMU's datasheet figures until then)",
        ));
    }
    if !calibrating_cells
        && loaded.config.calibration.calibrates_load_cells_each_run()
        && loaded.file_sets("calibration.measure_load_cells")
    {
        operator.tell(Message::Note(
            "calibration.measure_load_cells calibrates the load cells in `stewart simulate` \
             only; on a rig, run `stewart rig calibrate-load-cells --out FILE` with the \
             reference weight and set calibration.load_cells = \"FILE\" (the budget counts the \
             cells' datasheet gains until then)",
        ));
    }
    Ok(())
}

/// Runs the rig measurement of `options`, telling `operator`, with `attendant` putting the payload
/// on and choosing the key. `interrupt` parks the platform; `abort` (a second Ctrl-C) brakes at
/// once instead: the safe stop goes out within a sample period, the log is finished, and the
/// outcome says [`measure::End::Interrupted`]. A refused input or handshake is an error
/// (nothing moved); a fault is an outcome with [`measure::End::Fault`] naming the cause.
///
/// A run a stall ended (the link silent, the rig's watchdog, a sample gap: the rig braked) is
/// repeated in a new session, up to `rig.stall_retries` times, each attempt in a log of its own
/// (`<log>-repeat-N.mcap`; the stalled one stays as its record): a tare that completed is kept
/// (written beside the log, or to `--save-tare`) and only the loaded run repeated. The outcome
/// lists what was repeated and why ([`Outcome::repeated`]).
pub fn run(
    options: &RigOptions,
    operator: &mut dyn Operator,
    attendant: &mut dyn Attendant,
    interrupt: &AtomicBool,
    abort: &AtomicBool,
) -> Result<Outcome, Error> {
    let retries = options.measure.load_config()?.config.rig.stall_retries;
    let mut attempt = options.clone();
    let mut repeated: Vec<Repeated> = Vec::new();
    let mut stalled: Option<Outcome> = None;
    loop {
        let mut outcome = match (
            run_once(&attempt, operator, attendant, interrupt, abort),
            stalled,
        ) {
            (Ok(outcome), _) => outcome,
            // The repeat could not even begin (the rig does not answer): the stall's outcome
            // stands, with why it was not repeated.
            (Err(e), Some(mut last)) => {
                operator.tell(Message::Warning(&format!(
                    "the repeat after the stall could not begin: {e}"
                )));
                repeated.pop();
                last.repeated = repeated;
                return Ok(last);
            }
            (Err(e), None) => return Err(e),
        };
        let stopping = interrupt.load(std::sync::atomic::Ordering::SeqCst);
        if !outcome.stalled || repeated.len() >= retries as usize || stopping {
            outcome.repeated = repeated;
            return Ok(outcome);
        }
        let cause = match &outcome.end {
            measure::End::Fault(cause) => cause.clone(),
            _ => "a stall".to_string(),
        };
        let first_log = repeated
            .first()
            .map_or_else(|| outcome.log_path.clone(), |r| r.log.clone());
        repeated.push(Repeated {
            cause: cause.clone(),
            log: outcome.log_path.clone(),
        });
        let number = repeated.len();
        let (next, kept) = repeat(&attempt, &outcome, &first_log, number)?;
        let kept = match kept {
            Some(path) => format!(
                "; the completed tare is kept ({}) and the loaded run repeated",
                path.display()
            ),
            None => String::new(),
        };
        operator.tell(Message::Warning(&format!(
            "the run ended by a stall ({cause}); the rig braked. Repeating it in a new session \
             ({number} of at most {retries}, rig.stall_retries){kept}; the stalled run's log \
             stays: {}",
            outcome.log_path.display()
        )));
        attempt = next;
        stalled = Some(outcome);
    }
}

/// The options of the `number`-th repetition of the attempt `last` that ended as `outcome`:
/// its own log beside `first_log`, and, when the tare completed in a two-run measurement, the
/// loaded run only with that tare (written to the path returned).
fn repeat(
    last: &RigOptions,
    outcome: &Outcome,
    first_log: &Path,
    number: usize,
) -> Result<(RigOptions, Option<PathBuf>), Error> {
    let mut next = last.clone();
    let stem = first_log
        .file_stem()
        .map_or_else(|| "run".into(), |s| s.to_string_lossy().into_owned());
    next.measure.log = Some(first_log.with_file_name(format!("{stem}-repeat-{number}.mcap")));
    let kept = match (&last.plan, &outcome.tare) {
        (RigPlan::Both, Some(tare)) => {
            let path = match &last.measure.save_tare {
                Some(path) => path.clone(),
                None => {
                    let path = first_log.with_file_name(format!("{stem}.tare.json"));
                    tare.save(&path).map_err(|e| {
                        Error::Run(e.context("cannot keep the completed tare for the repeat"))
                    })?;
                    path
                }
            };
            next.plan = RigPlan::MeasureOnly;
            next.measure.tare = Some(path.clone());
            next.measure.save_tare = None;
            Some(path)
        }
        _ => None,
    };
    Ok((next, kept))
}

/// One attempt of [`run`]: the handshake, the sequence, its outcome.
fn run_once(
    options: &RigOptions,
    operator: &mut dyn Operator,
    attendant: &mut dyn Attendant,
    interrupt: &AtomicBool,
    abort: &AtomicBool,
) -> Result<Outcome, Error> {
    let plan = &options.plan;
    options.measure.check_log_free()?;
    let mut loaded = options.measure.load_config()?;
    prepare(plan, &mut loaded, operator)?;
    let calibrating_cells = matches!(plan, RigPlan::CalibrateLoadCells(_));
    let loaded = loaded;
    let config = &loaded.config;
    measurement::warn_old_calibrations(config, operator);
    let link = link_settings(&loaded, &options.link, attendant)?;
    let geometry = setup::geometry(&loaded)?;
    // The controllers are built (and their trajectories checked) here, before the rig is even
    // contacted: nothing slow remains between samples once a session runs.
    let loaded_controller = match plan {
        RigPlan::MeasureOnly | RigPlan::Both | RigPlan::CalibrateLoadCells(_) => {
            let t = setup::trajectory(&loaded, &geometry, config.run.duration_s)?;
            Some(setup::controller(
                &loaded,
                &geometry,
                t,
                measure::Measurement::Loaded,
            )?)
        }
        RigPlan::TareOnly(_) | RigPlan::CalibrateImu(_) => None,
    };
    let tare: TarePlan = options.measure.tare_plan(&loaded, &geometry)?;

    // The handshake: refusals end here, before the log and before any command.
    let backend = RigBackend::connect(&link.address, link.options.clone()).map_err(refuse)?;
    check_rig(backend.info(), &loaded)?;
    let rig_link = Link::start(backend);
    let sample_period_s = rig_link.lock().rig.sample_period_s();

    let start_ns = runlog::run_log::unix_now_ns();
    let log_path = options.measure.log_path(start_ns);
    let save_tare = match plan {
        RigPlan::TareOnly(out) => Some(out.as_path()),
        RigPlan::CalibrateImu(_) | RigPlan::CalibrateLoadCells(_) => None,
        _ => options.measure.save_tare.as_deref(),
    };
    let calibrate = match plan {
        RigPlan::CalibrateImu(path) => Calibrate::Imu(path.clone()),
        RigPlan::CalibrateLoadCells(path) => Calibrate::LoadCells(path.clone()),
        _ => Calibrate::Nothing,
    };
    let body = if calibrating_cells {
        "the reference weight (calibration.reference_mass_kg)"
    } else {
        "the payload"
    };
    let station = station::RigStation::new(rig_link, &loaded, body, attendant, abort);
    measurement::run(
        Spec {
            loaded: &loaded,
            geometry,
            tare,
            loaded_controller,
            save_tare,
            log: (log_path, start_ns),
            // The log's writer thread must never stall the control loop: when it falls behind
            // (a disk that blocks), messages are dropped and counted instead. The live view is
            // served from that thread: the control loop never calls it.
            delivery: (Delivery::DropWhenFull, runlog::Pace::AsRun),
            live: options.measure.live,
            command: if calibrating_cells {
                "rig calibrate-load-cells"
            } else {
                "rig"
            },
            backend: "rig",
            seed: 0,
            noise: NOISE,
            sample_period_s: Some(sample_period_s),
            truth_msg: None,
            truth: None,
            calibrate,
            // A calibration measures no payload: the reference's run is in the log, not
            // reported.
            report: !calibrating_cells,
        },
        station,
        operator,
        interrupt,
    )
}

/// One line per measurement: the link counters and the loop's timing.
pub fn link_lines(link: &[LinkReport]) -> Vec<String> {
    link.iter()
        .map(|l| {
            let c = &l.counters;
            let t = &l.timing;
            format!(
                "link ({}): accepted {}, lost {}, late {}, duplicate {}, out of sequence {}, \
                 corrupt {}, foreign {}, auth failed {}, clamped commands {}; loop period median \
                 {:.3} ms, jitter median {:.0} µs, p99 {:.0} µs, max {:.1} ms; work per tick \
                 median {:.0} µs, p99 {:.0} µs",
                l.run,
                c.accepted,
                c.lost,
                c.late,
                c.duplicate,
                c.out_of_sequence,
                c.corrupt,
                c.foreign,
                c.auth_failed,
                c.commands_clamped,
                t.median_period_s * 1e3,
                t.jitter_median_s * 1e6,
                t.jitter_p99_s * 1e6,
                t.jitter_max_s * 1e3,
                t.work_median_s * 1e6,
                t.work_p99_s * 1e6,
            )
        })
        .collect()
}
