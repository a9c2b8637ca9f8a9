//! One `stewart rig` invocation from its flags to its outcome: the configuration and the
//! controllers checked, the handshake, the log, the sessions of the plan on the rig's link, the
//! rig left braked whatever happened, then the calibration fitted or the report built.

use std::sync::atomic::AtomicBool;

use control::io::Backend;

use measure::report::RunInfo;
use measure::session::{self, SessionPlan, TarePlan};
use measure::setup;
use rig::link::Link;
use rig::RigBackend;
use runlog::mcap_log::Delivery;
use runlog::metadata::RunMetadata;
use runlog::{LogObserver, RunLog};

use super::RigOutcome;
use super::{calibration, check_rig, link_settings, outcome, resolve, station, Plan, RigArgs};
use crate::common::{self, refuse, CommandError};
use crate::progress::Progress;

/// [`super::rig`], and when `abort` is set (a second Ctrl-C) the rig brakes at once instead of
/// parking: the safe stop goes out within a sample period, the log is finished, and the
/// outcome says [`measure::End::Interrupted`].
pub fn rig_with_abort(
    args: &RigArgs,
    interrupt: &AtomicBool,
    abort: &AtomicBool,
) -> Result<RigOutcome, CommandError> {
    let (plan, common) = resolve(args)?;
    let common = &common;
    let mut loaded = common.run.load_config()?;
    calibration::prepare(&plan, &mut loaded, common.run.shared.quiet)?;
    let calibrating_cells = matches!(plan, Plan::CalibrateLoadCells(_));
    let loaded = loaded;
    let config = &loaded.config;
    crate::common::warn_old_calibrations(config);
    let link = link_settings(&loaded, &common.link)?;
    let geometry = setup::geometry(&loaded)?;
    // The controllers are built (and their trajectories checked) here, before the rig is even
    // contacted: nothing slow remains between samples once a session runs.
    let loaded_controller = if plan == Plan::MeasureOnly || plan == Plan::Both || calibrating_cells
    {
        let t = setup::trajectory(&loaded, &geometry, config.run.duration_s)?;
        Some(setup::controller(
            &loaded,
            &geometry,
            t,
            measure::Measurement::Loaded,
        )?)
    } else {
        None
    };
    let tare = common::tare_plan(&loaded, &geometry, common.run.tare.as_deref())?;

    // The handshake: refusals end here, before the log and before any command.
    let backend = RigBackend::connect(&link.address, link.options.clone())
        .map_err(|e| refuse(format!("{e}")))?;
    check_rig(backend.info(), &loaded)?;
    let rig_link = Link::start(backend);

    let start_ns = runlog::run_log::unix_now_ns();
    let log_path = common::log_path(&common.run, start_ns);
    // The log's writer thread must never stall the control loop: when it falls behind (a disk
    // that blocks), messages are dropped and counted instead.
    let live =
        live::serve(common.run.shared.live, live::Pace::AsRun).map_err(CommandError::Input)?;
    let live_addr = live.as_ref().map(live::LiveServer::addr);
    // The live view is served from the log's writer thread: the control loop never calls it.
    let tap = live.map(live::LiveServer::into_tap);
    let mut log = RunLog::create_tapped(&log_path, start_ns, Delivery::DropWhenFull, tap)
        .map_err(CommandError::Run)?;
    common::announce_live(live_addr, common.run.shared.quiet);
    let mut runs = Vec::new();
    if matches!(tare, TarePlan::Measure(_)) {
        runs.push("tare".to_string());
    }
    if loaded_controller.is_some() {
        runs.push("loaded".to_string());
    }
    let total = match &tare {
        TarePlan::Measure(c) => measure::measurement::expected_samples(config, c.trajectory()),
        TarePlan::File(..) => 0,
    } + loaded_controller.as_ref().map_or(0, |c| {
        measure::measurement::expected_samples(config, c.trajectory())
    });
    let command = if calibrating_cells {
        "rig calibrate-load-cells"
    } else {
        "rig"
    };
    let header = log.write_metadata(&RunMetadata {
        noise: outcome::NOISE.into(),
        sample_period_s: rig_link.lock().rig.sample_period_s(),
        start_unix_ns: log.start_unix_ns(),
        runs,
        tare_file: common.run.tare.as_ref().map(|p| p.display().to_string()),
        ..RunMetadata::describing(&loaded, &geometry, command, "rig")
    });
    let save_tare = match &plan {
        Plan::TareOnly(out) => Some(out.as_path()),
        Plan::CalibrateImu(_) | Plan::CalibrateLoadCells(_) => None,
        _ => common.run.save_tare.as_deref(),
    };
    let mut progress = Progress::new(total, common.run.shared.quiet);
    let mut station = station::RigStation::new(
        &rig_link,
        &loaded,
        progress.handle(),
        (
            if calibrating_cells {
                "the reference weight (calibration.reference_mass_kg)"
            } else {
                "the payload"
            },
            common.link.no_prompt,
        ),
        abort,
    );
    let result = header.and_then(|()| {
        let mut observer =
            measure::observer::Both(LogObserver::new(&mut log, &geometry, config), &mut progress);
        session::run(
            SessionPlan {
                config: &loaded,
                geometry,
                tare,
                loaded: loaded_controller,
                save_tare,
                backend: "rig",
            },
            &mut station,
            &mut observer,
            interrupt,
        )
    });
    let (link_reports, failure) = station.into_reports();
    progress.finish();
    if !matches!(result, Ok(ref o) if o.end == measure::End::Completed) {
        // Whatever happened, leave the rig braked.
        let _ = rig_link.lock().safe_stop();
    }
    let dropped = log.dropped();
    let finished = log.finish();
    if dropped > 0 {
        eprintln!(
            "warning: the log's writer fell behind; {dropped} log messages were dropped rather \
             than stall the control loop (the gaps show in the MCAP sequence numbers)"
        );
    }
    // The rig is braked and the link closed before anything else can fail: the fits below
    // are the host's work alone.
    let (info, link_total) = rig_link.close();
    let outcome = result.map_err(CommandError::Run)?;
    finished.map_err(CommandError::Run)?;
    let (calibration, load_cell_calibration) =
        calibration::fit_and_write(&plan, &outcome, &loaded, start_ns, &log_path)?;
    // A calibration measures no payload: the reference's run is in the log, not reported.
    let report = outcome
        .report(
            config,
            RunInfo {
                config: loaded.source.clone(),
                seed: 0,
                noise: outcome::NOISE.into(),
                params: config.estimator.params.into(),
                log: Some(log_path.display().to_string()),
                backend: "rig".into(),
                tool: measure::calibration::tool(),
                calibrations: config.calibration.applied(),
            },
            None,
        )
        .filter(|_| !calibrating_cells);
    Ok(RigOutcome {
        report,
        log_path,
        end: outcome.end.clone(),
        tare: outcome.measured_tare().cloned(),
        link: link_reports,
        failure,
        rig: info,
        link_total,
        calibration,
        load_cell_calibration,
    })
}
