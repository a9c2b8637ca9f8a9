//! The calibrations fitted on a measurement's runs: the IMU's alignment on the empty fixture's run
//! ([`rig_description::calibration::imu`]) and the load cells' gains on a tare run and a loaded run with
//! the reference body ([`calibrate::load_cells`]), on the simulator or on a rig alike.

use std::path::Path;

use calibrate::load_cells::{self as reference_mass, Run, Setup};
use measure::sequence::{SequenceOutcome, TareSource};
use nalgebra::Vector3;
use rig_description::calibration::LoadCellFile;
use rig_description::load::{ConfigError, LoadedConfig};

/// The reference's mass the rig description gives (`calibration.reference_mass_kg`), or the
/// refusal naming the key.
pub fn reference_mass_kg(loaded: &LoadedConfig) -> Result<f64, ConfigError> {
    loaded.config.calibration.reference_mass_kg.ok_or_else(|| {
        ConfigError::single(loaded.issue(
            "calibration.reference_mass_kg",
            "the load-cell calibration needs the reference body's mass: set \
                 calibration.reference_mass_kg (and reference_mass_tolerance_kg, its \
                 certificate's sigma)",
        ))
    })
}

/// Readies `loaded` for the load-cell calibration's runs (a tare run, then the reference body
/// in the payload's place): the reference's mass must be given ([`reference_mass_kg`]); no
/// load-cell calibration is applied (the gains are fitted on the raw readings); and the loaded
/// run's feed-forward ([`measure::setup::feedforward_load`]) takes the reference as its owner
/// knows it instead of `[plan.payload]`: its certified mass, centred on the plate, with the
/// inertia of a steel cube of that mass (its centre of mass and inertia need not be known; what
/// the guess misses is left to the leg loops).
pub fn prepare_reference_runs(loaded: &mut LoadedConfig) -> Result<(), ConfigError> {
    let mass_kg = reference_mass_kg(loaded)?;
    let c = &mut loaded.config;
    c.calibration.load_cells = None;
    c.calibration.load_cells_file = None;
    const STEEL_KG_M3: f64 = 7850.0;
    let side_m = (mass_kg / STEEL_KG_M3).cbrt();
    let moment = mass_kg * side_m * side_m / 6.0;
    c.plan.payload = rig_description::config::BodyPrior {
        mass_kg,
        com_m: [0.0, 0.0, side_m / 2.0],
        inertia_com_kg_m2: [[moment, 0.0, 0.0], [0.0, moment, 0.0], [0.0, 0.0, moment]],
    };
    Ok(())
}

/// The gains fitted on `outcome` (a tare run, then the loaded run with the reference body), as
/// the calibration file of `backend` with the rig description `loaded`, dated by `start_ns`.
pub fn load_cell_calibration(
    outcome: &SequenceOutcome,
    loaded: &LoadedConfig,
    backend: &str,
    start_ns: u64,
    log_path: &Path,
) -> anyhow::Result<LoadCellFile> {
    let (tare_record, tare_offset) = match &outcome.tare {
        Some(TareSource::Measured(_, effects)) => {
            (effects.record.as_ref(), effects.accel_offset_m_s2)
        }
        _ => (None, None),
    };
    let tare_record = tare_record
        .ok_or_else(|| anyhow::anyhow!("the calibration's tare run recorded no excitation"))?;
    let run = outcome
        .loaded
        .as_ref()
        .ok_or_else(|| anyhow::anyhow!("the calibration's loaded run did not run"))?;
    let loaded_record = run
        .record
        .as_ref()
        .ok_or_else(|| anyhow::anyhow!("the calibration's loaded run recorded no excitation"))?;
    let config = &loaded.config;
    let geometry = measure::setup::geometry(loaded).map_err(|e| anyhow::anyhow!("{e}"))?;
    let estimator =
        measure::setup::estimator_config(config, &geometry, measure::Measurement::Loaded, 0.0, 1.0);
    let legs = measure::setup::leg_model(config).map(|_| &config.legs);
    let setup = Setup {
        geometry,
        lever_m: measure::setup::accelerometer_position(config),
        equation_sigma: estimator.equation_sigma,
        legs,
        joint_tolerance_m: config.platform.joint_position_tolerance_m,
        zero_drift_n_per_min: config.sensors.load_cell.zero_drift_n_per_min,
        reference_mass_kg: reference_mass_kg(loaded).map_err(|e| anyhow::anyhow!("{e}"))?,
        reference_mass_tolerance_kg: config.calibration.reference_mass_tolerance_kg,
        prior_gain_sigma: config.sensors.load_cell.gain_error,
    };
    let offset = |o: Option<[f64; 3]>| o.map_or_else(Vector3::zeros, Vector3::from);
    let tare_entries = tare_record.entries();
    let loaded_entries = loaded_record.entries();
    let gains = reference_mass::fit(
        &Run {
            entries: &tare_entries,
            accel_offset_m_s2: offset(tare_offset),
        },
        &Run {
            entries: &loaded_entries,
            accel_offset_m_s2: offset(run.accel_offset_m_s2),
        },
        &setup,
    )
    .map_err(|e| anyhow::anyhow!("load-cell calibration: {e}"))?;
    let mut file = LoadCellFile::new(gains, start_ns / 1_000_000_000, &loaded.source, backend);
    file.provenance.log = Some(log_path.display().to_string());
    Ok(file)
}

/// The IMU alignment fitted on the tare run of `outcome` (a tare-only measurement), as the
/// calibration file of `backend` with the rig description `loaded`, dated by `start_ns`.
pub fn imu_calibration(
    outcome: &measure::sequence::SequenceOutcome,
    loaded: &LoadedConfig,
    backend: &str,
    start_ns: u64,
    log_path: &Path,
) -> anyhow::Result<rig_description::calibration::CalibrationFile> {
    let record = match &outcome.tare {
        Some(measure::sequence::TareSource::Measured(_, effects)) => effects.record.as_ref(),
        _ => None,
    }
    .ok_or_else(|| anyhow::anyhow!("the calibration run recorded no excitation to fit"))?;
    let g = loaded
        .config
        .estimator
        .local_gravity_m_s2
        .filter(|g| *g > 0.0)
        .unwrap_or(stewart_types::STANDARD_GRAVITY_M_S2);
    let geometry = measure::setup::geometry(loaded).map_err(|e| anyhow::anyhow!("{e}"))?;
    let alignment = calibrate::imu::fit(
        &record.entries(),
        &nalgebra::Vector3::new(0.0, 0.0, -g),
        &geometry,
        loaded.config.platform.joint_position_tolerance_m,
    )
    .map_err(|e| anyhow::anyhow!("IMU calibration: {e}"))?;
    let mut file = rig_description::calibration::CalibrationFile::new(
        alignment,
        start_ns / 1_000_000_000,
        &loaded.source,
        backend,
    );
    file.provenance.log = Some(log_path.display().to_string());
    Ok(file)
}

/// What a load-cell calibration found, with one sigma, in lines for the operator.
pub fn load_cell_lines(file: &LoadCellFile) -> Vec<String> {
    let c = &file.load_cells;
    let mut lines = Vec::new();
    let list = |v: &[f64; 6]| {
        v.iter()
            .map(|x| format!("{:+.2e}", x))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let sigma: [f64; 6] = core::array::from_fn(|i| c.sigma(i));
    let fitted: [f64; 6] = core::array::from_fn(|i| {
        c.fitted_covariance
            .get(i)
            .and_then(|r| r.get(i))
            .map_or(f64::NAN, |v| v.max(0.0).sqrt())
    });
    lines.push(format!(
        "load-cell gains: [{}]   (with the datasheet's ±{:.1e} as prior)",
        list(&c.gains),
        c.prior_sigma
    ));
    lines.push(format!("         ± 1σ:  [{}]", list(&sigma)));
    lines.push(format!("  the fit alone: [{}]", list(&c.fitted_gains)));
    lines.push(format!("         ± 1σ:  [{}]", list(&fitted)));
    lines.push(format!(
        "  the fit's σ parts: noise [{}], joints [{}], legs [{}], drift [{}], reference mass [{}]",
        list(&c.noise_sigma),
        list(&c.joints_sigma),
        list(&c.legs_sigma),
        list(&c.drift_sigma),
        list(&c.mass_sigma),
    ));
    let mean = c.gains.iter().sum::<f64>() / 6.0;
    let ones = nalgebra::DVector::from_element(6, 1.0 / 6.0);
    let mean_sigma = (ones.transpose() * c.covariance_matrix() * &ones)[(0, 0)]
        .max(0.0)
        .sqrt();
    let com = c.reference_com_m;
    lines.push(format!(
        "mean gain {mean:+.2e} ± {mean_sigma:.1e}; reference {} kg ± {} kg, its centre of \
         mass found at [{:.4}, {:.4}, {:.4}] m; fixture {:.2} kg; residual {:.2} σ ({} \
         entries)",
        c.reference_mass_kg,
        c.reference_mass_tolerance_kg,
        com[0],
        com[1],
        com[2],
        c.fixture_mass_kg,
        c.residual_rms,
        c.entries
    ));
    lines
}

/// What an IMU calibration found, with one sigma, in lines for the operator.
pub fn imu_lines(file: &rig_description::calibration::CalibrationFile) -> Vec<String> {
    let a = &file.imu;
    let mut lines = Vec::new();
    let g = a.gyro();
    // G ≈ I + S + [θ×], S symmetric: the reading's axes turned by −θ against P's.
    let turned = nalgebra::Vector3::new(
        0.5 * (g[(1, 2)] - g[(2, 1)]),
        0.5 * (g[(2, 0)] - g[(0, 2)]),
        0.5 * (g[(0, 1)] - g[(1, 0)]),
    );
    lines.push(format!(
        "IMU axes turned by [{:+.4}, {:+.4}, {:+.4}]° (gyro and accelerometer, one package)",
        turned.x.to_degrees(),
        turned.y.to_degrees(),
        turned.z.to_degrees(),
    ));
    lines.push(format!(
        "gyro scale errors: [{:+.2e}, {:+.2e}, {:+.2e}] ± [{:.1e}, {:.1e}, {:.1e}] \
         (accelerometer scales not fitted: the datasheet's stay in the budget)",
        g[(0, 0)] - 1.0,
        g[(1, 1)] - 1.0,
        g[(2, 2)] - 1.0,
        a.gyro_sigma(0),
        a.gyro_sigma(4),
        a.gyro_sigma(8),
    ));
    let r = a.accelerometer_position_m;
    lines.push(format!(
        "accelerometer position: [{:.5}, {:.5}, {:.5}] m ± [{:.1e}, {:.1e}, {:.1e}]",
        r[0],
        r[1],
        r[2],
        a.position_sigma(0),
        a.position_sigma(1),
        a.position_sigma(2)
    ));
    lines.push(format!(
        "IMU delay: {:.1} µs ± {:.1} µs   residual rms: gyro {:.2e} rad/s, accelerometer \
         {:.2e} m/s² ({} entries; sigmas count noise and {} mm joints)",
        a.imu_delay_s * 1e6,
        a.gyro_sigma(9) * 1e6,
        a.residual_rms[0],
        a.residual_rms[1],
        a.entries,
        a.joint_tolerance_m * 1e3
    ));
    lines
}

#[cfg(test)]
mod tests {
    /// The reference runs' feed-forward load: the fixture plus a 1000 kg steel cube (side
    /// 0.503 m, m s²/6 = 42.2 kg·m² about each axis) centred on the plate, a consistent body; a
    /// description without the reference's mass is refused naming the key.
    #[test]
    fn the_reference_runs_feed_forward_a_steel_cube_of_the_certified_mass() {
        let mut loaded = rig_description::load::load_str("", "default").unwrap();
        super::prepare_reference_runs(&mut loaded).unwrap();
        let c = &loaded.config;
        let load = measure::setup::feedforward_load(c, measure::Measurement::Loaded, None)
            .expect("a load");
        let expected = c.plan.fixture.mass_kg + 1000.0;
        assert!((load.mass_kg - expected).abs() < 1e-9, "{}", load.mass_kg);
        let cube = c.plan.payload.parameters();
        assert!(cube.consistency().is_consistent());
        let moment = cube.inertia_com_kg_m2().expect("a body")[(0, 0)];
        assert!((moment - 1000.0 * (1000.0f64 / 7850.0).cbrt().powi(2) / 6.0).abs() < 1e-9);
        assert!((moment - 42.2).abs() < 0.1, "{moment}");
        assert!(c.calibration.load_cells.is_none());

        let mut without = rig_description::load::load_str("", "default").unwrap();
        without.config.calibration.reference_mass_kg = None;
        let err = super::prepare_reference_runs(&mut without).unwrap_err();
        assert!(
            err.to_string().contains("calibration.reference_mass_kg"),
            "{err}"
        );
    }
}
