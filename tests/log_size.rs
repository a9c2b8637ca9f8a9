//! A 1 kHz log stays under 10 MB a minute of data (docs/log-schema.md): a short
//! `simulate` run with the datasheet's noise, every frame logged, measured in bytes of the
//! whole file per minute of log time. The file's fixed part (metadata, schemas, summary) counts
//! against the short run, so the bound holds with room for the default run's longer one.

use crate::support;

/// The requirement, with a tenth kept in hand: MB (10⁶ bytes) per minute of data.
const MAX_MB_PER_MIN: f64 = 0.9 * 10.0;

/// A step between frames this long is a pause between runs, not a lost stretch of data, s.
const PAUSE_S: f64 = 0.5;

#[test]
fn a_one_kilohertz_log_stays_under_ten_megabytes_a_minute() {
    let run = support::simulate();
    let log = runlog::LogContents::read(&run.log).unwrap();
    assert!(log.damaged.is_clean(), "{:?}", log.damaged);
    let sensors = &log.channels["/sensors"];
    // The minutes of data are the time the frames cover: a pause between the runs (the
    // braked plate settling while the payload is put on) holds no frames and no data.
    let steps: Vec<f64> = log
        .sensors
        .windows(2)
        .map(|w| w[1].time_s - w[0].time_s)
        .filter(|dt| *dt < PAUSE_S)
        .collect();
    let span_min = steps.iter().sum::<f64>() / 60.0;
    // Every sample is there: the bound is not met by logging less.
    let rate_hz = steps.len() as f64 / (span_min * 60.0);
    assert!(
        (rate_hz - 1000.0).abs() < 5.0,
        "{rate_hz} frames a second in {} messages",
        sensors.count
    );
    let bytes = std::fs::metadata(&run.log).unwrap().len() as f64;
    let mb_per_min = bytes * 1e-6 / span_min;
    eprintln!(
        "{bytes} bytes over {:.1} s of data: {mb_per_min:.2} MB a minute",
        span_min * 60.0
    );
    assert!(
        mb_per_min <= MAX_MB_PER_MIN,
        "{mb_per_min:.2} MB a minute ({bytes} bytes over {:.1} s)",
        span_min * 60.0
    );
}
