//! Reaching the rig: the `[rig]` table with the link flags applied and the key read, and the
//! rig's limits checked against the configuration once the handshake gives them.

use std::time::Duration;

use measure::load::{ConfigError, ConfigIssue, LoadedConfig};
use rig::RigOptions;

use super::LinkArgs;
use crate::common::{refuse, CommandError};

/// The link settings of a run: the address and the host's options.
#[derive(Clone, Debug)]
pub struct LinkSettings {
    /// The rig's address.
    pub address: String,
    /// The host's options (key loaded).
    pub options: RigOptions,
}

/// The `[rig]` table with the flags applied, checked, and the key read.
pub fn link_settings(
    loaded: &LoadedConfig,
    flags: &LinkArgs,
) -> Result<LinkSettings, CommandError> {
    let config = &loaded.config;
    let mut rig_config = config.rig.clone();
    let mut issues = Vec::new();
    if let Some(address) = &flags.connect {
        if let Err(e) = address.parse::<rig::transport::Address>() {
            issues.push(flag_issue("--connect", e.to_string()));
        }
        rig_config.address = address.clone();
    }
    if let Some(ms) = flags.link_silence_ms {
        if !(ms.is_finite() && (1.0..=10_000.0).contains(&ms)) {
            issues.push(flag_issue(
                "--link-silence-ms",
                format!("must be between 1 and 10000 ms, got {ms}"),
            ));
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
        return Err(CommandError::Config(ConfigError { issues }));
    }
    let chosen = crate::key::choose(
        flags.key.as_deref(),
        rig_config.key_path(&loaded.directory()),
        crate::key::user_key_path,
        flags.insecure,
        crate::key::Side::Host,
    )?;
    if let Some(notice) = &chosen.notice {
        eprintln!("{notice}");
    }
    let key = chosen.key;
    let options = RigOptions {
        link_silence: Duration::from_secs_f64(rig_config.link_silence_ms * 1e-3),
        handshake_timeout: Duration::from_secs_f64(rig_config.handshake_timeout_s),
        key,
        require_imu: true,
        accel_position_m: Some(config.sensors.imu.position_m),
        sample_period_s: Some(1.0 / config.sensors.sample_rate_hz),
        force_limit_n: Some(config.control.max_force_n),
        ..RigOptions::default()
    };
    Ok(LinkSettings {
        address: rig_config.address,
        options,
    })
}

/// A problem with a command-line flag, blamed on the flag (not on a line of a file).
pub(crate) fn flag_issue(flag: &str, problem: String) -> ConfigIssue {
    ConfigIssue {
        file: measure::load::COMMAND_LINE_NAME.into(),
        line: None,
        key: flag.into(),
        problem,
    }
}

/// Refuses a rig whose limits do not fit the configuration the trajectories were checked
/// against (before any command is sent).
pub fn check_rig(info: &rig::host::RigInfo, loaded: &LoadedConfig) -> Result<(), CommandError> {
    let c = &loaded.config;
    let l = &info.limits;
    let (min_m, max_m) = (c.platform.min_leg_length_m, c.platform.max_leg_length_m);
    if (l.stroke_min_m - min_m).abs() > 1e-3 || (l.stroke_max_m - max_m).abs() > 1e-3 {
        return Err(refuse(format!(
            "rig layout mismatch: the rig's legs stroke from {} to {} m, the configuration's \
             from {min_m} to {max_m} m (platform.min_leg_length_m, platform.max_leg_length_m); \
             refusing the session",
            l.stroke_min_m, l.stroke_max_m
        )));
    }
    let speed = c.excitation.max_leg_speed_m_s;
    if l.speed_max_m_s < speed {
        return Err(refuse(format!(
            "rig layout mismatch: the excitation may move a leg at {speed} m/s \
             (excitation.max_leg_speed_m_s) but the rig allows {} m/s; refusing the session",
            l.speed_max_m_s
        )));
    }
    Ok(())
}
