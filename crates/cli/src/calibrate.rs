//! What is printed of a calibration: the IMU's alignment and the load cells' gains found, with
//! one sigma, and where they were written.

use std::path::Path;

use measure::calibration::LoadCellFile;

/// Prints what a load-cell calibration found, with one sigma, and where it was written.
pub fn print_load_cell_calibration(file: &LoadCellFile, path: &Path, quiet: bool) {
    let c = &file.load_cells;
    if !quiet {
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
        println!(
            "load-cell gains: [{}]   (with the datasheet's ±{:.1e} as prior)",
            list(&c.gains),
            c.prior_sigma
        );
        println!("         ± 1σ:  [{}]", list(&sigma));
        println!("  the fit alone: [{}]", list(&c.fitted_gains));
        println!("         ± 1σ:  [{}]", list(&fitted));
        println!(
            "  the fit's σ parts: noise [{}], joints [{}], legs [{}], drift [{}], reference mass [{}]",
            list(&c.noise_sigma),
            list(&c.joints_sigma),
            list(&c.legs_sigma),
            list(&c.drift_sigma),
            list(&c.mass_sigma),
        );
        let mean = c.gains.iter().sum::<f64>() / 6.0;
        let ones = nalgebra::DVector::from_element(6, 1.0 / 6.0);
        let mean_sigma = (ones.transpose() * c.covariance_matrix() * &ones)[(0, 0)]
            .max(0.0)
            .sqrt();
        let com = c.reference_com_m;
        println!(
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
        );
    }
    println!("load-cell calibration: {}", path.display());
}

/// Prints what an IMU calibration found, with one sigma, and where it was written.
pub fn print_imu_calibration(
    file: &measure::calibration::CalibrationFile,
    path: &Path,
    quiet: bool,
) {
    let a = &file.imu;
    if !quiet {
        let g = a.gyro();
        // G ≈ I + S + [θ×], S symmetric: the reading's axes turned by −θ against P's.
        let turned = nalgebra::Vector3::new(
            0.5 * (g[(1, 2)] - g[(2, 1)]),
            0.5 * (g[(2, 0)] - g[(0, 2)]),
            0.5 * (g[(0, 1)] - g[(1, 0)]),
        );
        println!(
            "IMU axes turned by [{:+.4}, {:+.4}, {:+.4}]° (gyro and accelerometer, one package)",
            turned.x.to_degrees(),
            turned.y.to_degrees(),
            turned.z.to_degrees(),
        );
        println!(
            "gyro scale errors: [{:+.2e}, {:+.2e}, {:+.2e}] ± [{:.1e}, {:.1e}, {:.1e}] \
             (accelerometer scales not fitted: the datasheet's stay in the budget)",
            g[(0, 0)] - 1.0,
            g[(1, 1)] - 1.0,
            g[(2, 2)] - 1.0,
            a.gyro_sigma(0),
            a.gyro_sigma(4),
            a.gyro_sigma(8),
        );
        let r = a.accelerometer_position_m;
        println!(
            "accelerometer position: [{:.5}, {:.5}, {:.5}] m ± [{:.1e}, {:.1e}, {:.1e}]",
            r[0],
            r[1],
            r[2],
            a.position_sigma(0),
            a.position_sigma(1),
            a.position_sigma(2)
        );
        println!(
            "IMU delay: {:.1} µs ± {:.1} µs   residual rms: gyro {:.2e} rad/s, accelerometer \
             {:.2e} m/s² ({} entries; sigmas count noise and {} mm joints)",
            a.imu_delay_s * 1e6,
            a.gyro_sigma(9) * 1e6,
            a.residual_rms[0],
            a.residual_rms[1],
            a.entries,
            a.joint_tolerance_m * 1e3
        );
    }
    println!("IMU calibration: {}", path.display());
}
