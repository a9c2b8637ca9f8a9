//! The one rule that turns a sensor frame into the estimator's [`Sample`], used alike by the
//! online measurement ([`crate::measurement`]), the replay of a log ([`crate::replay`]), the
//! benches and the zero-allocation test.
//!
//! - **Pose**: forward kinematics of the measured leg lengths, warm-started from the previous
//!   frame's solution (the first frame of a measurement from the home pose). A frame whose
//!   forward kinematics fails gives no sample and leaves the warm start where it was. While the
//!   controller runs, it has solved exactly this (same options, same warm start, set from here
//!   with [`control::controller::Controller::set_pose_guess`]): its pose is taken with
//!   [`Feed::accept`] instead of solving twice.
//! - **IMU axes**: the gyro's rate and the accelerometer's specific force are turned from the
//!   IMU's axes into P by the rig description's mounting rotation (`sensors.imu.orientation_deg`;
//!   none when it is zero, so an aligned IMU's numbers pass bit for bit).
//! - **IMU alignment** (when the rig description applies a calibration,
//!   [`rig_description::calibration::imu`]): the readings in P are taken back through the fitted
//!   matrices, ω = G⁻¹ ω_m and f = A⁻¹ f_m, and moved forward by the IMU's delay τ to first
//!   order from the previous frame, x(t) ≈ x_k + (τ/T)(x_k − x_{k−1}) (the frame after a lost
//!   one, more than 1.5 T after its predecessor, keeps its reading).
//! - **Load-cell gains** (when the rig description applies a calibration,
//!   [`rig_description::calibration::load_cells`]): each cell's reading is divided by its fitted
//!   1 + ĝ_i, t_i = f_i / (1 + ĝ_i). Only the estimator's sample is corrected: the controller
//!   reads the frame itself, and its force feed-forward and the supervisor's force limits do
//!   not need 0.05 % (the position loop takes up the rest).
//! - Otherwise leg forces and time pass unchanged, and so does the frame's sequence counter, which places
//!   the sample on the conditioning's grid (a late frame keeps its place, a gap in the counter
//!   is a lost frame: `estimator::timebase`).

use control::io::SensorFrame;
use estimator::Sample;
use kinematics::{FkOptions, Geometry, Matrix3, Pose, Rotation3, Vector3, Vector6};

use rig_description::calibration::ImuAlignment;
use rig_description::config::ImuMounting;

/// A fitted IMU alignment as the feed applies it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Alignment {
    gyro_inverse: Matrix3<f64>,
    accel_inverse: Matrix3<f64>,
    /// τ / T.
    delay_periods: f64,
    /// T, s.
    period_s: f64,
    /// The previous frame's time and its rate and specific force in P, aligned.
    previous: Option<(f64, Vector3<f64>, Vector3<f64>)>,
}

/// The frame-to-sample rule's state: the warm start of forward kinematics and the IMU's
/// mounting. Plain `Copy` data.
#[derive(Clone, Copy, Debug)]
pub struct Feed {
    geometry: Geometry,
    fk: FkOptions,
    guess: Pose,
    /// A pose has been found: the warm start is the plate's, not the home pose.
    found: bool,
    imu_to_p: Option<Rotation3<f64>>,
    alignment: Option<Alignment>,
    /// 1 / (1 + ĝ_i) per cell, when load-cell gains are applied.
    force_scale: Option<Vector6<f64>>,
}

impl Feed {
    /// A feed for `geometry` starting from its home pose, with the controller's forward
    /// kinematics options and the IMU's mounting.
    pub fn new(geometry: Geometry, fk: FkOptions, imu: &ImuMounting) -> Self {
        let aligned = imu.orientation_deg.iter().all(|a| *a == 0.0);
        Self {
            geometry,
            fk,
            guess: geometry.home_pose(),
            found: false,
            imu_to_p: (!aligned).then(|| imu.rotation()),
            alignment: None,
            force_scale: None,
        }
    }

    /// Applies fitted load-cell gains (none: the readings as they are): each reading divided
    /// by 1 + ĝ_i. Gains that are not finite or not above −1 leave the readings as they are (a
    /// calibration file's gains are checked when it is read).
    pub fn with_load_cell_gains(
        mut self,
        gains: Option<&rig_description::calibration::LoadCellGains>,
    ) -> Self {
        self.force_scale = gains.and_then(|c| {
            let scale = Vector6::from(c.gains).map(|g| 1.0 / (1.0 + g));
            scale
                .iter()
                .all(|s| s.is_finite() && *s > 0.0)
                .then_some(scale)
        });
        self
    }

    /// Applies a fitted IMU alignment (none: the described mounting alone), at the sample
    /// period `sample_period_s`. A singular matrix leaves the readings as they are (a
    /// calibration file's matrices are checked when it is read).
    pub fn aligned(mut self, alignment: Option<&ImuAlignment>, sample_period_s: f64) -> Self {
        self.alignment = alignment.and_then(|a| {
            let delay_periods = a.imu_delay_s / sample_period_s;
            Some(Alignment {
                gyro_inverse: a.gyro().try_inverse()?,
                accel_inverse: a.accel().try_inverse()?,
                delay_periods: if delay_periods.is_finite() {
                    delay_periods
                } else {
                    0.0
                },
                period_s: sample_period_s,
                previous: None,
            })
        });
        self
    }

    /// The warm start of the next forward kinematics (the last pose found).
    pub fn pose_guess(&self) -> Pose {
        self.guess
    }

    /// The pose of `frame` by forward kinematics from the warm start, which it then becomes;
    /// `None` (warm start kept) when the solver finds no trustworthy pose. Until a first pose
    /// is found there is no warm start to trust (the plate may rest anywhere: a stroke end, a
    /// tilt), so the first solve is the cold one ([`Geometry::forward_kinematics_cold`]).
    pub fn solve(&mut self, frame: &SensorFrame) -> Option<Pose> {
        let lengths = Vector6::from(frame.leg_lengths_m);
        let solution = if self.found {
            self.geometry
                .forward_kinematics(&lengths, &self.guess, &self.fk)
                .ok()?
        } else {
            self.geometry
                .forward_kinematics_cold(&lengths, &self.fk)
                .ok()?
        };
        self.accept(solution.pose);
        Some(solution.pose)
    }

    /// Takes a pose the controller solved for the current frame from the same warm start.
    pub fn accept(&mut self, pose: Pose) {
        self.guess = pose;
        self.found = true;
    }

    /// The estimator's input of `frame` at `pose`, the IMU's readings turned into P (and
    /// aligned, when a calibration is applied).
    pub fn sample(&mut self, frame: &SensorFrame, pose: Pose) -> Sample {
        let gyro = Vector3::from(frame.gyro_rad_s);
        let accel = Vector3::from(frame.accel_m_s2);
        let (gyro_rad_s, accel_m_s2) = match &self.imu_to_p {
            Some(r) => (r * gyro, r * accel),
            None => (gyro, accel),
        };
        let (gyro_rad_s, accel_m_s2) = match &mut self.alignment {
            Some(a) => {
                let w = a.gyro_inverse * gyro_rad_s;
                let f = a.accel_inverse * accel_m_s2;
                // The previous frame is the one a period before (by time, so that frames without
                // a counter are corrected alike); after a lost frame the reading stays.
                let step = frame.time_s - a.previous.map_or(f64::NAN, |p| p.0);
                let shifted = match a.previous {
                    Some((_, w0, f0)) if (step - a.period_s).abs() < 0.5 * a.period_s => (
                        w + (w - w0) * a.delay_periods,
                        f + (f - f0) * a.delay_periods,
                    ),
                    _ => (w, f),
                };
                a.previous = Some((frame.time_s, w, f));
                shifted
            }
            None => (gyro_rad_s, accel_m_s2),
        };
        Sample {
            time_s: frame.time_s,
            sequence: Some(frame.sequence),
            pose,
            leg_forces_n: match &self.force_scale {
                Some(k) => Vector6::from(frame.leg_forces_n).component_mul(k),
                None => Vector6::from(frame.leg_forces_n),
            },
            gyro_rad_s,
            accel_m_s2,
        }
    }

    /// [`Feed::solve`] then [`Feed::sample`]: the sample of a frame nobody solved yet.
    pub fn next(&mut self, frame: &SensorFrame) -> Option<Sample> {
        self.solve(frame).map(|pose| self.sample(frame, pose))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::testkit::geometry;

    fn frame_at(g: &Geometry, pose: &Pose) -> SensorFrame {
        let lengths = g.leg_lengths(pose);
        SensorFrame {
            time_s: 0.5,
            leg_lengths_m: lengths.into(),
            leg_forces_n: [1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
            gyro_rad_s: [0.1, 0.0, 0.0],
            accel_m_s2: [0.0, 0.0, 9.80665],
            ..SensorFrame::default()
        }
    }

    #[test]
    fn an_aligned_imu_passes_its_readings_bit_for_bit() {
        let g = geometry();
        let mut feed = Feed::new(g, FkOptions::default(), &ImuMounting::default());
        let mut pose = g.home_pose();
        pose.position_m.x += 0.01;
        let frame = frame_at(&g, &pose);
        let s = feed.next(&frame).expect("pose found");
        assert!((s.pose.position_m - pose.position_m).norm() < 1e-9);
        assert_eq!(s.gyro_rad_s, Vector3::new(0.1, 0.0, 0.0));
        assert_eq!(s.accel_m_s2, Vector3::new(0.0, 0.0, 9.80665));
        assert_eq!(s.leg_forces_n, Vector6::from(frame.leg_forces_n));
        assert_eq!(feed.pose_guess().position_m, s.pose.position_m);
    }

    /// Applied gains divide each cell's reading by 1 + ĝ_i; the pose and the IMU are untouched.
    #[test]
    fn calibrated_gains_divide_each_reading() {
        let g = geometry();
        let gains = crate::testkit::gains_with([1e-3, -2e-3, 0.0, 5e-4, 0.01, -0.01]);
        let mut feed = Feed::new(g, FkOptions::default(), &ImuMounting::default())
            .with_load_cell_gains(Some(&gains));
        let frame = frame_at(&g, &g.home_pose());
        let s = feed.next(&frame).expect("pose found");
        for i in 0..6 {
            let expected = frame.leg_forces_n[i] / (1.0 + gains.gains[i]);
            assert!((s.leg_forces_n[i] - expected).abs() < 1e-12, "cell {i}");
        }
        assert_eq!(s.gyro_rad_s, Vector3::new(0.1, 0.0, 0.0));
    }

    #[test]
    fn a_turned_imu_is_read_in_platform_axes() {
        let g = geometry();
        // Yawed 90°: the IMU's x axis is P's y axis.
        let imu = ImuMounting {
            position_m: [0.0; 3],
            orientation_deg: [0.0, 0.0, 90.0],
            ..ImuMounting::default()
        };
        let mut feed = Feed::new(g, FkOptions::default(), &imu);
        let s = feed
            .next(&frame_at(&g, &g.home_pose()))
            .expect("pose found");
        assert!((s.gyro_rad_s - Vector3::new(0.0, 0.1, 0.0)).norm() < 1e-15);
        assert!((s.accel_m_s2 - Vector3::new(0.0, 0.0, 9.80665)).norm() < 1e-15);
    }

    #[test]
    fn a_frame_without_a_pose_keeps_the_warm_start() {
        let g = geometry();
        let mut feed = Feed::new(g, FkOptions::default(), &ImuMounting::default());
        let before = feed.pose_guess();
        let bad = SensorFrame {
            leg_lengths_m: [f64::NAN; 6],
            ..SensorFrame::default()
        };
        assert!(feed.next(&bad).is_none());
        assert_eq!(feed.pose_guess().position_m, before.position_m);
    }

    /// A log (or a rig) whose first frame rests further from home than
    /// `fk_max_jump_m` (here: the plate on its lower end stops) is posed; without a pose every
    /// sample of the run would be rejected and the report a table of NaN.
    #[test]
    fn a_first_frame_far_from_home_is_posed() {
        let g = geometry();
        let fk = FkOptions {
            max_jump_m: 0.05,
            max_jump_rad: 0.05,
            ..FkOptions::default()
        };
        let mut feed = Feed::new(g, fk, &ImuMounting::default());
        let mut rest = g.home_pose();
        rest.position_m.z -= 0.3;
        rest.position_m.x += 0.1;
        let s = feed.next(&frame_at(&g, &rest)).expect("first pose found");
        assert!((s.pose.position_m - rest.position_m).norm() < 1e-9);
        // From there on the warm start is the plate's, with the jump check.
        let mut next = rest;
        next.position_m.z += 0.001;
        let s = feed.next(&frame_at(&g, &next)).expect("warm pose");
        assert!((s.pose.position_m - next.position_m).norm() < 1e-9);
        assert!(
            feed.next(&frame_at(&g, &g.home_pose())).is_none(),
            "a 0.3 m jump is refused"
        );
    }
}
