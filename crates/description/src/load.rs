//! Reading a rig description (or a scenario file, which adds the simulated world's `[world]`
//! table): TOML text → [`Config`], refusing anything wrong with the file, the dotted key and
//! what is wrong.
//!
//! A scenario file is laid over the embedded default (`configs/default.toml`): tables merge key
//! by key, any other value (numbers, strings, arrays) replaces the default's. So a scenario need
//! only state what differs from the default car, and `stewart simulate` needs no file at all.
//! Unknown keys are refused, not ignored: units live in the key names (`mass_kg`), so a key with
//! the wrong unit (`mass_lb`) is an unknown key, and we name the known key it was probably meant
//! to be.

use std::fmt;
use std::path::Path;

use crate::config::Config;
use crate::validate::Scope;

/// The default scenario, compiled in so that `stewart simulate` needs no arguments.
pub const DEFAULT_CONFIG_TOML: &str = include_str!("../../../configs/default.toml");

/// The table of a scenario file that describes the simulated world; the rig description leaves
/// it to the simulator's layer ([`LoadedConfig::section`]).
pub const WORLD_TABLE: &str = "world";

/// Name used for the embedded default in messages.
pub const DEFAULT_CONFIG_NAME: &str = "<embedded configs/default.toml>";

/// One thing wrong with a configuration: where (file, line when known, dotted key) and what.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ConfigIssue {
    /// The file as the user named it (or [`DEFAULT_CONFIG_NAME`]).
    pub file: String,
    /// 1-based line of the key in that file, when the key is in the file.
    pub line: Option<usize>,
    /// Dotted key path, e.g. `payload.inertia_com_kg_m2[0][1]`; empty for a file-level problem.
    pub key: String,
    /// What is wrong, in words a user can act on.
    pub problem: String,
}

impl fmt::Display for ConfigIssue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", abbreviate_echo(&self.file))?;
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
        }
        let problem = abbreviate_echo(&self.problem);
        if self.key.is_empty() {
            write!(f, ": {problem}")
        } else {
            write!(f, ": `{}`: {problem}", abbreviate_echo(&self.key))
        }
    }
}

/// Longest run of non-blank characters an error message echoes whole, in characters.
pub const MAX_ECHOED_CHARS: usize = 80;

/// `text` with every run of non-blank characters longer than [`MAX_ECHOED_CHARS`] cut to its
/// start and a count of what was left out: an error echoes what the user gave (a value, a key,
/// a flag) so that they can find it, and a 50 MB value must not become a 50 MB message.
pub fn abbreviate_echo(text: &str) -> std::borrow::Cow<'_, str> {
    let too_long = text
        .split_whitespace()
        .any(|word| word.chars().nth(MAX_ECHOED_CHARS).is_some());
    if !too_long {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::new();
    let mut rest = text;
    while let Some(start) = rest.find(|c: char| !c.is_whitespace()) {
        out.push_str(&rest[..start]);
        let word_and_after = &rest[start..];
        let end = word_and_after
            .find(char::is_whitespace)
            .unwrap_or(word_and_after.len());
        let word = &word_and_after[..end];
        match word.char_indices().nth(MAX_ECHOED_CHARS) {
            Some((cut, _)) => {
                let left_out = word[cut..].chars().count();
                out.push_str(&word[..cut]);
                out.push_str(&format!("… ({left_out} more characters)"));
            }
            None => out.push_str(word),
        }
        rest = &word_and_after[end..];
    }
    out.push_str(rest);
    std::borrow::Cow::Owned(out)
}

/// Every problem found in a configuration (never empty).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ConfigError {
    /// The problems, in file order where known.
    pub issues: Vec<ConfigIssue>,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.issues.len();
        write!(
            f,
            "invalid configuration ({n} problem{})",
            if n == 1 { "" } else { "s" }
        )?;
        for issue in &self.issues {
            write!(f, "\n  {issue}")?;
        }
        Ok(())
    }
}

impl std::error::Error for ConfigError {}

impl ConfigError {
    /// One issue.
    pub fn single(issue: ConfigIssue) -> Self {
        Self {
            issues: vec![issue],
        }
    }
}

/// A configuration together with where it came from.
#[derive(Clone, Debug)]
pub struct LoadedConfig {
    /// The merged, validated rig description.
    pub config: Config,
    /// The file name for messages ([`DEFAULT_CONFIG_NAME`] for the embedded default).
    pub source: String,
    /// The user's file text as read (the default's text when no file was given).
    pub text: String,
    /// The whole merged document, tables this schema does not read included (`[world]`).
    merged: toml::Table,
}

impl LoadedConfig {
    /// The directory that paths in the rig description are relative to: the file's own, or
    /// the working directory for the embedded default.
    pub fn directory(&self) -> std::path::PathBuf {
        if self.source == DEFAULT_CONFIG_NAME {
            return std::path::PathBuf::new();
        }
        std::path::Path::new(&self.source)
            .parent()
            .map(std::path::Path::to_path_buf)
            .unwrap_or_default()
    }

    /// Whether the user's file itself sets the dotted `key` (e.g. `calibration.measure_imu`),
    /// rather than inheriting it from the embedded default: a note about a key is for the
    /// user who wrote it.
    pub fn file_sets(&self, key: &str) -> bool {
        if self.source == DEFAULT_CONFIG_NAME {
            return false;
        }
        let Ok(table) = self.text.parse::<toml::Table>() else {
            return false;
        };
        let mut parts = key.split('.').peekable();
        let mut here = &table;
        while let Some(part) = parts.next() {
            match (here.get(part), parts.peek()) {
                (Some(_), None) => return true,
                (Some(toml::Value::Table(inner)), Some(_)) => here = inner,
                _ => return false,
            }
        }
        false
    }

    /// The effective rig description (default merged with the file) as TOML, for logs.
    pub fn effective_toml(&self) -> String {
        toml::to_string(&self.config).unwrap_or_default()
    }

    /// Another layer's table of the merged document (e.g. the simulator's `[world]`),
    /// deserialized with the same messages as the rig description: file, line, dotted key.
    pub fn section<T: serde::de::DeserializeOwned>(&self, table: &str) -> Result<T, ConfigError> {
        let value = self
            .merged
            .get(table)
            .cloned()
            .unwrap_or_else(|| toml::Value::Table(toml::Table::new()));
        serde_path_to_error::deserialize(value).map_err(|e| {
            let inner = e.path().to_string();
            let path = if inner == "." {
                table.to_string()
            } else {
                format!("{table}.{inner}")
            };
            let message = e.inner().message().trim().to_string();
            let (key, problem) = explain_serde_error(&path, &message);
            ConfigError::single(self.issue(&key, problem))
        })
    }

    /// Locates `key` in the user's file (1-based line), for messages about values checked after
    /// loading (trajectory, geometry).
    pub fn issue(&self, key: &str, problem: impl Into<String>) -> ConfigIssue {
        ConfigIssue {
            file: self.source.clone(),
            line: locate_key(&self.text, key),
            key: key.to_string(),
            problem: problem.into(),
        }
    }
}

/// Values given on the command line, which take precedence over the file.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Overrides {
    /// `--duration` → `run.duration_s`.
    pub duration_s: Option<f64>,
    /// `--params` → `estimator.params`.
    pub params: Option<crate::config::ParamCount>,
}

/// Name used for the command line in messages.
pub const COMMAND_LINE_NAME: &str = "<command line>";

impl LoadedConfig {
    /// Applies command-line values and validates again; a problem with an overridden value is
    /// reported against the flag (e.g. `--duration`), not the file.
    pub fn with_overrides(mut self, o: &Overrides) -> Result<Self, ConfigError> {
        let mut flags: Vec<(&str, &str)> = Vec::new();
        if let Some(d) = o.duration_s {
            self.config.run.duration_s = d;
            flags.push(("run.duration_s", "--duration"));
        }
        if let Some(p) = o.params {
            self.config.estimator.params = p;
            flags.push(("estimator.params", "--params"));
        }
        let problems = crate::validate::validate(&self.config);
        if problems.is_empty() {
            return Ok(self);
        }
        Err(ConfigError {
            issues: problems
                .into_iter()
                .map(
                    |(key, problem)| match flags.iter().find(|(k, _)| *k == key) {
                        Some((_, flag)) => ConfigIssue {
                            file: COMMAND_LINE_NAME.into(),
                            line: None,
                            key: format!("{flag} ({key})"),
                            problem,
                        },
                        None => self.issue(&key, problem),
                    },
                )
                .collect(),
        })
    }
}

/// Loads the embedded default, or `path` laid over it, and validates the ranges.
pub fn load(path: Option<&Path>) -> Result<LoadedConfig, ConfigError> {
    load_scoped(path, Scope::Everything)
}

/// As [`load`], validating only the keys `scope` covers.
pub fn load_scoped(path: Option<&Path>, scope: Scope) -> Result<LoadedConfig, ConfigError> {
    match path {
        None => load_str_scoped(DEFAULT_CONFIG_TOML, DEFAULT_CONFIG_NAME, scope),
        Some(path) => {
            let (text, name) = read_text(
                path,
                "the file",
                crate::bounded::DESCRIPTION_CAP_BYTES,
                "a rig description",
            )?;
            load_str_scoped(&text, &name, scope)
        }
    }
}

/// The text of `path` and its name for messages, read with a cap of `cap_bytes`
/// ([`crate::bounded`]; `kind` names what the file should be); a file that cannot be read is
/// refused as "cannot read `what`".
fn read_text(
    path: &Path,
    what: &str,
    cap_bytes: u64,
    kind: &str,
) -> Result<(String, String), ConfigError> {
    let name = path.display().to_string();
    match crate::bounded::read_to_string_capped(path, cap_bytes, kind) {
        Ok(text) => Ok((text, name)),
        Err(e) => Err(ConfigError::single(ConfigIssue {
            file: name,
            line: None,
            key: String::new(),
            problem: format!("cannot read {what}: {e}"),
        })),
    }
}

/// Loads scenario `text` (named `source` in messages) laid over the embedded default.
pub fn load_str(text: &str, source: &str) -> Result<LoadedConfig, ConfigError> {
    load_str_scoped(text, source, Scope::Everything)
}

/// As [`load_str`], validating only the keys `scope` covers.
pub fn load_str_scoped(
    text: &str,
    source: &str,
    scope: Scope,
) -> Result<LoadedConfig, ConfigError> {
    let issue = |line: Option<usize>, key: String, problem: String| ConfigIssue {
        file: source.to_string(),
        line,
        key,
        problem,
    };
    let user: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        let line = e.span().map(|s| line_of(text, s.start));
        ConfigError::single(issue(
            line,
            String::new(),
            format!("not valid TOML: {}", e.message()),
        ))
    })?;
    let mut merged: toml::Table = DEFAULT_CONFIG_TOML.parse().map_err(|e: toml::de::Error| {
        ConfigError::single(ConfigIssue {
            file: DEFAULT_CONFIG_NAME.into(),
            line: e.span().map(|s| line_of(DEFAULT_CONFIG_TOML, s.start)),
            key: String::new(),
            problem: format!("embedded default is not valid TOML: {}", e.message()),
        })
    })?;
    let moved = moved_keys(&user);
    if !moved.is_empty() {
        return Err(ConfigError {
            issues: moved
                .into_iter()
                .map(|(key, problem)| issue(locate_key(text, &key), key, problem))
                .collect(),
        });
    }
    platform_form(&user, &mut merged).map_err(|(key, problem)| {
        ConfigError::single(issue(locate_key(text, &key), key, problem))
    })?;
    noise_forms(&user, &mut merged);
    merge(&mut merged, user);
    let mut config = describe(&merged, text, source, scope)?;
    read_calibrations(&mut config, text, source)?;
    Ok(LoadedConfig {
        config,
        source: source.to_string(),
        text: text.to_string(),
        merged,
    })
}

/// A rig description as a run log recorded it ([`LoadedConfig::effective_toml`]), named
/// `source`, with the IMU calibration and the load cells' gains the run applied given as the
/// files' contents (`imu`, `load_cells`) instead of the paths or the calibration pass the
/// description names: a log is re-estimated with what the run applied, wherever it is read.
pub fn load_recorded(
    text: &str,
    source: &str,
    imu: Option<crate::calibration::CalibrationFile>,
    load_cells: Option<crate::calibration::LoadCellFile>,
) -> Result<LoadedConfig, ConfigError> {
    // Text that is not TOML goes to `load_str` as it is, which says where it is not.
    let stripped = match text.parse::<toml::Table>() {
        Ok(mut table) => {
            if let Some(toml::Value::Table(c)) = table.get_mut("calibration") {
                c.remove("imu");
                c.remove("measure_imu");
                c.remove("load_cells");
                c.remove("measure_load_cells");
            }
            toml::to_string(&table).unwrap_or_else(|_| text.to_string())
        }
        Err(_) => text.to_string(),
    };
    let mut loaded = load_str_scoped(&stripped, source, Scope::Estimation)?;
    if let Some(file) = imu {
        loaded.config.calibration.imu = Some("<IMU calibration in the log>".into());
        loaded.config.calibration.imu_file = Some(file);
    }
    if let Some(file) = load_cells {
        loaded.config.calibration.load_cells = Some("<load-cell calibration in the log>".into());
        loaded.config.calibration.load_cells_file = Some(file);
    }
    Ok(loaded)
}

/// Reads the calibration files `config` references, relative to `source`'s directory; a file
/// that cannot be used is refused at its key.
fn read_calibrations(config: &mut Config, text: &str, source: &str) -> Result<(), ConfigError> {
    use crate::calibration::CalibrationDocument;
    let directory = if source == DEFAULT_CONFIG_NAME {
        std::path::PathBuf::new()
    } else {
        Path::new(source)
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default()
    };
    let refused = |key: &str, problem: String| {
        ConfigError::single(ConfigIssue {
            file: source.to_string(),
            line: locate_key(text, key),
            key: key.into(),
            problem,
        })
    };
    if let Some(name) = config.calibration.imu.clone() {
        let file = crate::calibration::CalibrationFile::read(&directory.join(&name))
            .map_err(|e| refused("calibration.imu", e.to_string()))?;
        config.calibration.imu_file = Some(file);
    }
    if let Some(name) = config.calibration.load_cells.clone() {
        let file = crate::calibration::LoadCellFile::read(&directory.join(&name))
            .map_err(|e| refused("calibration.load_cells", e.to_string()))?;
        config.calibration.load_cells_file = Some(file);
    }
    Ok(())
}

/// The rig description of a merged document (the world left out, the tare's excitation
/// completed), validated; problems are located in `text`, named `source`.
fn describe(
    merged: &toml::Table,
    text: &str,
    source: &str,
    scope: Scope,
) -> Result<Config, ConfigError> {
    let issue = |line: Option<usize>, key: String, problem: String| ConfigIssue {
        file: source.to_string(),
        line,
        key,
        problem,
    };
    let mut description = merged.clone();
    description.remove(WORLD_TABLE);
    complete_tare_excitation(&mut description);
    let config: Config = serde_path_to_error::deserialize(description).map_err(|e| {
        let key = e.path().to_string();
        let key = if key == "." { String::new() } else { key };
        let message = e.inner().message().trim().to_string();
        let (key, problem) = explain_serde_error(&key, &message);
        ConfigError::single(issue(locate_key(text, &key), key, problem))
    })?;
    let mut problems = crate::validate::validate(&config);
    problems.retain(|(key, _)| scope.covers(key));
    if !problems.is_empty() {
        return Err(ConfigError {
            issues: problems
                .into_iter()
                .map(|(key, problem)| issue(locate_key(text, &key), key, problem))
                .collect(),
        });
    }
    Ok(config)
}

impl LoadedConfig {
    /// Lays an excitation file (`stewart plan --out FILE`: an `[excitation]` table and nothing
    /// else) over the rig description: both runs follow it, the tare run with the keys of a
    /// `[tare_excitation]` table laid over it. Problems name the excitation file.
    pub fn with_excitation_file(self, path: &Path) -> Result<Self, ConfigError> {
        let (text, name) = read_text(
            path,
            "the excitation file",
            crate::bounded::EXCITATION_CAP_BYTES,
            "an excitation file",
        )?;
        self.with_excitation_text(&text, &name)
    }

    /// [`Self::with_excitation_file`] on the file's `text`, named `source` in messages.
    pub fn with_excitation_text(mut self, text: &str, source: &str) -> Result<Self, ConfigError> {
        let single = |line: Option<usize>, key: &str, problem: String| {
            ConfigError::single(ConfigIssue {
                file: source.to_string(),
                line,
                key: key.to_string(),
                problem,
            })
        };
        let mut table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
            single(
                e.span().map(|s| line_of(text, s.start)),
                "",
                format!("not valid TOML: {}", e.message()),
            )
        })?;
        if let Some(other) = table.keys().find(|k| k.as_str() != "excitation") {
            return Err(single(
                locate_key(text, other),
                other,
                "an excitation file holds only an [excitation] table (as `stewart plan --out` \
                 writes it); put other settings in the rig description"
                    .into(),
            ));
        }
        let Some(toml::Value::Table(excitation)) = table.remove("excitation") else {
            return Err(single(
                None,
                "excitation",
                "no [excitation] table: write one with `stewart plan --out FILE`".into(),
            ));
        };
        let mut merged = self.merged.clone();
        let mut over = toml::Table::new();
        over.insert("excitation".into(), toml::Value::Table(excitation));
        merge(&mut merged, over);
        self.config = describe(&merged, text, source, Scope::Everything)?;
        self.merged = merged;
        Ok(self)
    }
}

/// Keys of older scenario files that moved when the rig description was separated from the
/// simulated world, with where each went.
const MOVED: [(&str, &str); 10] = [
    ("fixture", "moved to [world.fixture]: the fixture's true mass properties belong to the simulated world, not to the rig description"),
    ("payload", "moved to [world.payload]: the payload's truth belongs to the simulated world, not to the rig description"),
    ("actuator", "moved to [world.actuator]: the actuator model belongs to the simulated world"),
    ("sensors.noise", "removed: the rig description's [sensors.encoder], [sensors.load_cell], [sensors.gyro] and [sensors.accelerometer] give the datasheet figures; `stewart simulate --noise none|harsh` scales them"),
    ("sensors.physics_substeps", "moved to world.physics_substeps (a setting of the simulator, not of the rig)"),
    ("sensors.imu_position_m", "moved to sensors.imu.position_m (beside the IMU's orientation_deg)"),
    ("run.seed", "moved to world.seed (the simulated world's random draws)"),
    ("estimator.gyro_noise_rad_s", "removed: the estimator takes the gyro's noise from sensors.gyro.noise_density_rad_s_sqrt_hz (× √sample rate)"),
    ("estimator.accel_noise_m_s2", "removed: the estimator takes the accelerometer's noise from sensors.accelerometer.noise_density_m_s2_sqrt_hz (× √sample rate)"),
    ("estimator.accel_bias_m_s2", "moved to sensors.accelerometer.bias_m_s2"),
];

/// The keys of `user` that an older scenario format had, as (key, where it went).
fn moved_keys(user: &toml::Table) -> Vec<(String, String)> {
    MOVED
        .iter()
        .filter(|(key, _)| {
            let mut table = user;
            let parts: Vec<&str> = key.split('.').collect();
            for (i, part) in parts.iter().enumerate() {
                match table.get(*part) {
                    Some(toml::Value::Table(t)) if i + 1 < parts.len() => table = t,
                    Some(_) if i + 1 == parts.len() => return true,
                    _ => return false,
                }
            }
            false
        })
        .map(|(key, why)| (key.to_string(), why.to_string()))
        .collect()
}

/// A `[tare_excitation]` table holds only the keys that differ from `[excitation]`: lays it
/// over a copy of `[excitation]` so that the schema reads a whole excitation.
fn complete_tare_excitation(description: &mut toml::Table) {
    let Some(toml::Value::Table(over)) = description.remove(TARE_EXCITATION_TABLE) else {
        return;
    };
    let mut tare = match description.get("excitation") {
        Some(toml::Value::Table(e)) => e.clone(),
        _ => toml::Table::new(),
    };
    merge(&mut tare, over);
    description.insert(TARE_EXCITATION_TABLE.into(), toml::Value::Table(tare));
}

/// The table of the tare run's own excitation.
pub const TARE_EXCITATION_TABLE: &str = "tare_excitation";

/// The platform's form (`config::PlatformConfig`): a file that gives the joints' points
/// replaces the embedded default's radii form, and a file may not give both forms.
fn platform_form(user: &toml::Table, merged: &mut toml::Table) -> Result<(), (String, String)> {
    use crate::config::{JOINT_KEYS, RADII_KEYS};
    let Some(toml::Value::Table(platform)) = user.get("platform") else {
        return Ok(());
    };
    let Some(points) = JOINT_KEYS.iter().find(|k| platform.contains_key(**k)) else {
        return Ok(());
    };
    if let Some(radius) = RADII_KEYS.iter().find(|k| platform.contains_key(**k)) {
        return Err((
            format!("platform.{radius}"),
            format!(
                "the platform is given twice: by its joints' points (platform.{points}) and by                  the radii form (platform.{radius}); give either the six base and six plate                  points, or the radii and pair separations"
            ),
        ));
    }
    if let Some(toml::Value::Table(default)) = merged.get_mut("platform") {
        for key in RADII_KEYS {
            default.remove(key);
        }
    }
    Ok(())
}

/// An IMU channel's noise the user's file gives in one form (density or per-sample rms)
/// replaces the embedded default's, given in the other; a file that gives both is refused by
/// validation at the key.
fn noise_forms(user: &toml::Table, merged: &mut toml::Table) {
    let pairs = [
        ("gyro", "noise_density_rad_s_sqrt_hz", "noise_rms_rad_s"),
        (
            "accelerometer",
            "noise_density_m_s2_sqrt_hz",
            "noise_rms_m_s2",
        ),
    ];
    let table = |t: &toml::Table, name: &str| -> Option<toml::Table> {
        match t.get("sensors") {
            Some(toml::Value::Table(s)) => match s.get(name) {
                Some(toml::Value::Table(c)) => Some(c.clone()),
                _ => None,
            },
            _ => None,
        }
    };
    for (name, density, rms) in pairs {
        let Some(given) = table(user, name) else {
            continue;
        };
        let drop = match (given.contains_key(density), given.contains_key(rms)) {
            (true, false) => rms,
            (false, true) => density,
            _ => continue,
        };
        if let Some(toml::Value::Table(s)) = merged.get_mut("sensors") {
            if let Some(toml::Value::Table(c)) = s.get_mut(name) {
                c.remove(drop);
            }
        }
    }
}

/// Lays `over` onto `base`: tables merge recursively, anything else replaces.
fn merge(base: &mut toml::Table, over: toml::Table) {
    for (key, value) in over {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}

/// Rewrites serde's messages into what a user can act on, and for an unknown key returns the
/// key itself (serde's path stops at its table) with a hint at the known key it resembles.
fn explain_serde_error(path: &str, message: &str) -> (String, String) {
    if let Some(rest) = message.strip_prefix("unknown field `") {
        let (field, expected) = rest.split_once('`').unwrap_or((rest, ""));
        let known: Vec<&str> = expected
            .split('`')
            .enumerate()
            .filter(|(i, _)| i % 2 == 1)
            .map(|(_, s)| s)
            .collect();
        // serde_path_to_error already ends the path with the unknown key.
        let key = if path.ends_with(field) {
            path.to_string()
        } else if path.is_empty() {
            field.to_string()
        } else {
            format!("{path}.{field}")
        };
        let mut problem = "unknown key".to_string();
        if let Some(suggestion) = suggest(field, &known) {
            if stem(suggestion) == stem(field) && suggestion != field {
                problem.push_str(&format!(
                    "; the unit is part of the key's name: did you mean `{suggestion}`?"
                ));
            } else {
                problem.push_str(&format!("; did you mean `{suggestion}`?"));
            }
        }
        if !known.is_empty() {
            problem.push_str(&format!(" (known keys here: {})", known.join(", ")));
        }
        return (key, problem);
    }
    if let Some(rest) = message.strip_prefix("missing field `") {
        let field = rest.split('`').next().unwrap_or(rest);
        let key = if path.is_empty() {
            field.to_string()
        } else {
            format!("{path}.{field}")
        };
        return (key, "missing (required key)".to_string());
    }
    if message.starts_with("invalid type") || message.starts_with("invalid length") {
        return (path.to_string(), format!("wrong type: {message}"));
    }
    (path.to_string(), message.to_string())
}

/// The part of a key before its unit suffix: `mass_kg` → `mass`, `com_m` → `com`.
fn stem(key: &str) -> &str {
    const UNITS: [&str; 21] = [
        "_kg_m2",
        "_n_s_per_m",
        "_n_per_m_s",
        "_n_per_m",
        "_rad_s",
        "_m_s2",
        "_m_s",
        "_deg",
        "_rad",
        "_hz",
        "_kg",
        "_m",
        "_s",
        "_n",
        "_nm",
        "_lb",
        "_in",
        "_mm",
        "_ms",
        "_g",
        "_ft",
    ];
    UNITS
        .iter()
        .find_map(|u| key.strip_suffix(u))
        .unwrap_or(key)
}

/// The known key closest to `field`: same stem first (a wrong unit), else smallest edit distance
/// if it is small.
fn suggest<'a>(field: &str, known: &[&'a str]) -> Option<&'a str> {
    if let Some(k) = known.iter().find(|k| stem(k) == stem(field)) {
        return Some(k);
    }
    known
        .iter()
        .map(|k| (edit_distance(field, k), *k))
        .filter(|(d, _)| *d <= 3)
        .min_by_key(|(d, _)| *d)
        .map(|(_, k)| k)
}

fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != *cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

/// 1-based line of byte offset `pos` in `text`.
fn line_of(text: &str, pos: usize) -> usize {
    text.as_bytes()
        .iter()
        .take(pos)
        .filter(|b| **b == b'\n')
        .count()
        + 1
}

/// 1-based line where dotted `key` (e.g. `payload.com_m[2]`) is written in `text`, if it is.
pub fn locate_key(text: &str, key: &str) -> Option<usize> {
    if key.is_empty() {
        return None;
    }
    let root = toml::de::DeTable::parse(text).ok()?;
    let mut table = Some(root.get_ref());
    let mut span = None;
    for part in key.split('.') {
        let (name, indices) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        let (k, mut value) = table?.iter().find(|(k, _)| k.get_ref() == name)?;
        span = Some(k.span());
        for index in indices
            .split(['[', ']'])
            .filter(|s| !s.is_empty())
            .filter_map(|s| s.parse::<usize>().ok())
        {
            match value.get_ref() {
                toml::de::DeValue::Array(a) => {
                    value = a.get(index)?;
                    span = Some(value.span());
                }
                _ => break,
            }
        }
        table = match value.get_ref() {
            toml::de::DeValue::Table(t) => Some(t),
            _ => None,
        };
    }
    span.map(|s| line_of(text, s.start))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_default_loads() {
        let loaded = load(None).expect("default config must be valid");
        assert_eq!(loaded.source, DEFAULT_CONFIG_NAME);
        assert!(loaded.config.sensors.sample_rate_hz > 0.0);
    }

    #[test]
    fn file_sets_tells_the_users_keys_from_the_defaults() {
        let loaded = load_str("[calibration]\nmeasure_imu = true\n", "x.toml").unwrap();
        assert!(loaded.file_sets("calibration.measure_imu"));
        assert!(!loaded.file_sets("calibration.measure_load_cells"));
        assert!(!loaded.file_sets("platform.base_radius_m"));
        assert!(!load(None).unwrap().file_sets("calibration.measure_imu"));
    }

    #[test]
    fn an_estimate_checks_only_the_keys_that_act_on_it() {
        // A lab's description with a park the tool would refuse to run: an estimate from its
        // data does not park.
        let text = "[run]\npark_s = 0.0\n[control]\nsettle_ramp_s = 0.0\n";
        let everything = load_str(text, "lab.toml").unwrap_err();
        let keys: Vec<&str> = everything.issues.iter().map(|i| i.key.as_str()).collect();
        assert_eq!(
            keys,
            ["control.settle_ramp_s", "run.park_s"],
            "{everything}"
        );
        assert!(load_str_scoped(text, "lab.toml", Scope::Estimation).is_ok());
        // What the estimate reads is still checked, the brake hold (the weighing's rest) too.
        for (text, key) in [
            ("[run]\nbrake_hold_s = -1.0\n", "run.brake_hold_s"),
            (
                "[sensors]\nsample_rate_hz = -1.0\n",
                "sensors.sample_rate_hz",
            ),
        ] {
            let e = load_str_scoped(text, "lab.toml", Scope::Estimation).unwrap_err();
            assert_eq!(e.issues[0].key, key, "{e}");
        }
    }

    #[test]
    fn an_imus_noise_is_a_density_or_a_per_sample_rms() {
        let default = load(None).unwrap().config.sensors;
        let d = default.gyro.noise_density_rad_s_sqrt_hz.unwrap();
        assert_eq!(
            default.gyro_noise_rad_s(),
            d * default.sample_rate_hz.sqrt()
        );
        // The rms replaces the default's density; the recorded description reads back.
        let text = "[sensors.gyro]\nnoise_rms_rad_s = 2.0e-3\n[sensors.accelerometer]\nnoise_rms_m_s2 = 0.02\n";
        let loaded = load_str(text, "lab.toml").unwrap();
        let s = loaded.config.sensors.clone();
        assert_eq!(s.gyro.noise_density_rad_s_sqrt_hz, None);
        assert_eq!((s.gyro_noise_rad_s(), s.accel_noise_m_s2()), (2.0e-3, 0.02));
        assert_eq!(
            s.gyro_density_rad_s_sqrt_hz(),
            2.0e-3 / s.sample_rate_hz.sqrt()
        );
        let again = load_str(&loaded.effective_toml(), "log").unwrap();
        assert_eq!(again.config.sensors, s);
        // Both in one file: refused at the key, with the way out.
        let both = "[sensors.gyro]\nnoise_rms_rad_s = 2.0e-3\nnoise_density_rad_s_sqrt_hz = 5e-5\n";
        let e = load_str(both, "lab.toml").unwrap_err();
        assert_eq!(e.issues[0].key, "sensors.gyro.noise_rms_rad_s", "{e}");
        assert_eq!(e.issues[0].line, Some(2), "{e}");
        assert!(e.issues[0].problem.contains("give one"), "{e}");
    }

    #[test]
    fn partial_file_inherits_the_default() {
        let loaded = load_str("[platform]\nbase_radius_m = 1.6\n", "x.toml").unwrap();
        let default = load(None).unwrap();
        assert_eq!(loaded.config.platform.base_radius_m, Some(1.6));
        assert_eq!(
            loaded.config.platform.plate_radius_m,
            default.config.platform.plate_radius_m
        );
        assert_eq!(loaded.config.sensors, default.config.sensors);
    }

    #[test]
    fn unknown_key_names_file_line_key_and_the_right_unit() {
        let err = load_str("[platform]\n\nbase_radius_in = 60.0\n", "car.toml").unwrap_err();
        let issue = &err.issues[0];
        assert_eq!(issue.file, "car.toml");
        assert_eq!(issue.key, "platform.base_radius_in");
        assert_eq!(issue.line, Some(3));
        assert!(issue.problem.contains("unknown key"), "{issue}");
        assert!(issue.problem.contains("base_radius_m"), "{issue}");
    }

    #[test]
    fn unknown_section_is_refused() {
        let err = load_str("[platfrom]\nbase_radius_m = 1.0\n", "car.toml").unwrap_err();
        assert_eq!(err.issues[0].key, "platfrom");
        assert!(err.issues[0].problem.contains("platform"), "{}", err);
    }

    #[test]
    fn wrong_type_names_the_key() {
        let err = load_str("[platform]\nbase_radius_m = \"1.5 m\"\n", "car.toml").unwrap_err();
        let issue = &err.issues[0];
        assert_eq!(issue.key, "platform.base_radius_m");
        assert_eq!(issue.line, Some(2));
        assert!(issue.problem.contains("wrong type"), "{issue}");
    }

    #[test]
    fn wrong_array_length_names_the_key() {
        let err = load_str("[sensors.imu]\nposition_m = [0.1, 0.2]\n", "car.toml").unwrap_err();
        assert_eq!(err.issues[0].key, "sensors.imu.position_m");
    }

    #[test]
    fn syntax_error_gives_the_line() {
        let err = load_str("[platform]\nbase_radius_m = = 3\n", "car.toml").unwrap_err();
        assert_eq!(err.issues[0].line, Some(2));
        assert!(err.to_string().contains("car.toml:2"), "{err}");
    }

    #[test]
    fn out_of_range_value_is_refused_with_its_line() {
        let err = load_str("[platform]\n\nbase_radius_m = -1.5\n", "car.toml").unwrap_err();
        let issue = err
            .issues
            .iter()
            .find(|i| i.key == "platform.base_radius_m")
            .expect("radius issue");
        assert_eq!(issue.line, Some(3));
        assert!(issue.problem.contains("positive"), "{issue}");
    }

    #[test]
    fn keys_of_the_older_format_say_where_they_moved() {
        let text = "[payload]\nmass_kg = 900.0\n[sensors]\nnoise = \"harsh\"\n[run]\nseed = 3\n";
        let err = load_str(text, "old.toml").unwrap_err();
        let keys: Vec<&str> = err.issues.iter().map(|i| i.key.as_str()).collect();
        assert_eq!(keys, ["payload", "sensors.noise", "run.seed"]);
        assert!(err.issues[0].problem.contains("[world.payload]"), "{err}");
        assert_eq!(err.issues[2].line, Some(6));
        assert!(err.issues[2].problem.contains("world.seed"), "{err}");
    }

    #[test]
    fn the_world_table_is_left_to_its_own_layer() {
        #[derive(serde::Deserialize)]
        struct World {
            seed: u64,
        }
        let loaded = load_str("[world]\nseed = 7\n", "w.toml").unwrap();
        let w: World = loaded.section("world").unwrap();
        assert_eq!(w.seed, 7);
        // The rig description itself ignores the table: a scenario's world does not reach it.
        assert_eq!(loaded.config, load(None).unwrap().config);
    }

    #[test]
    fn locate_finds_array_elements() {
        let text = "[a]\nb = [\n  [1, 2],\n  [3, 4],\n]\n";
        assert_eq!(locate_key(text, "a.b[1][0]"), Some(4));
        assert_eq!(locate_key(text, "a.b"), Some(2));
        assert_eq!(locate_key(text, "a.c"), None);
    }

    #[test]
    fn stems_strip_units() {
        assert_eq!(stem("mass_kg"), "mass");
        assert_eq!(stem("inertia_com_kg_m2"), "inertia_com");
        assert_eq!(edit_distance("payloda", "payload"), 2);
    }

    /// A 50 MB bad value is echoed abbreviated, not whole.
    #[test]
    fn a_huge_bad_value_is_echoed_abbreviated() {
        let value = "x".repeat(1_000_000);
        let text = format!("[platform]\nbase_radius_m = \"{value}\"\n");
        let err = load_str(&text, "big.toml").unwrap_err().to_string();
        assert!(err.len() < 1_000, "{} bytes", err.len());
        assert!(err.contains("platform.base_radius_m"), "{err}");
        assert!(
            err.contains("(9999") && err.contains("more characters)"),
            "{err}"
        );
        let key = "k".repeat(100_000);
        let err = load_str(&format!("[{key}]\n"), "big.toml")
            .unwrap_err()
            .to_string();
        assert!(err.len() < 1_000, "{} bytes", err.len());
        // Prose and short values pass untouched.
        assert_eq!(abbreviate_echo("a b  c"), "a b  c");
        assert_eq!(
            abbreviate_echo(&format!(" {} z", "é".repeat(81))),
            format!(" {}… (1 more characters) z", "é".repeat(80))
        );
    }
}
