//! The elementary errors of each systematic source, each applied to a run's recorded data as
//! the physical error would act, one datasheet sigma at a time ([`Scalar::residual_change`]).
//! The budget's effect of each is then [`super::fit::Fit::effect`] of the residual's change:
//! right to first order by construction, with no hand linearisation of the estimator.
//!
//! The list is fixed (every source has the same number of scalars whatever the figures, a zero
//! figure giving a zero effect), so the tare run's and the loaded run's effects pair up by
//! index ([`super::combine`]).

use std::sync::OnceLock;

use kinematics::{Geometry, Pose};
use nalgebra::{Matrix3, Matrix6, Rotation3, Vector3, Vector6, LU, U6};

use estimator::legs::PlateMotion;

pub use super::calibrated::{CalibratedGains, CalibratedImu};
use super::fit::{Data, Fit};
use super::legs::{self as leg_model, LegEffects};
use super::Figures;
use crate::record::derivative::d1;
use rig_description::sources::ErrorSource;

/// One elementary error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scalar {
    /// Accelerometer bias along P's axis (0..3), `bias_m_s2`.
    AccelBias(usize),
    /// Zero offset of a load cell (leg 0..6), `zero_offset_n`.
    Offset(usize),
    /// Zero drift of a load cell, linear in time from the run's start, `zero_drift_n_per_min`.
    Drift(usize),
    /// Gain error of a load cell, `gain_error`.
    Gain(usize),
    /// One principal direction of calibrated load-cell gains' covariance
    /// ([`CalibratedGains::modes`]): every cell's gain off by σ times its share.
    GainMode(usize),
    /// A load cell's reading of the transverse force through it along its direction (0, 1),
    /// `transverse_sensitivity`.
    Crosstalk(usize, usize),
    /// The IMU's axes turned about P's axis, `misalignment_deg`.
    Misalignment(usize),
    /// A gyro axis's scale error, `scale_error`.
    GyroScale(usize),
    /// An accelerometer axis's scale error, `scale_error`.
    AccelScale(usize),
    /// The accelerometer's position off along P's axis, `position_tolerance_m`.
    LeverArm(usize),
    /// The IMU's channels late by `imu_skew_s` (or by the calibrated delay's sigma).
    TimeSkew,
    /// One principal direction of a calibrated gyro matrix's covariance
    /// ([`CalibratedImu::gyro_modes`]), turning the accelerometer by its rotation too.
    GyroMode(usize),
    /// One principal direction of a calibrated accelerometer position's covariance.
    LeverArmMode(usize),
    /// A joint coordinate off the drawing: plate joint (else base), leg, coordinate;
    /// `joint_position_tolerance_m`. With calibrated gains that give their joints'
    /// sensitivity, the applied gains move with the joint
    /// ([`CalibratedGains::joint_change`]).
    Joint(bool, usize, usize),
    /// The legs' mass and inertia, the whole predicted effect: the error when the estimator
    /// does not compensate the legs.
    LegDynamics,
    /// The joints' friction, the whole predicted effect, likewise.
    JointFriction,
    /// One `[legs]` figure ([`leg_model::FIGURES`]) off by its tolerance: the error when the
    /// estimator compensates the legs with the described figures.
    LegFigure(usize),
}

impl Scalar {
    /// The source it belongs to.
    pub fn source(&self) -> ErrorSource {
        match self {
            Scalar::AccelBias(_) => ErrorSource::AccelBias,
            Scalar::Offset(_) | Scalar::Drift(_) => ErrorSource::LoadCellOffset,
            Scalar::Gain(_) | Scalar::GainMode(_) => ErrorSource::LoadCellScale,
            Scalar::Crosstalk(..) => ErrorSource::LoadCellCrosstalk,
            Scalar::Misalignment(_)
            | Scalar::GyroScale(_)
            | Scalar::AccelScale(_)
            | Scalar::GyroMode(_) => ErrorSource::ImuMisalignment,
            Scalar::LeverArm(_) | Scalar::LeverArmMode(_) => ErrorSource::ImuLeverArm,
            Scalar::TimeSkew => ErrorSource::TimeSkew,
            Scalar::Joint(..) => ErrorSource::Geometry,
            Scalar::LegDynamics => ErrorSource::LegDynamics,
            Scalar::JointFriction => ErrorSource::JointFriction,
            Scalar::LegFigure(k) if *k >= 6 => ErrorSource::JointFriction,
            Scalar::LegFigure(_) => ErrorSource::LegDynamics,
        }
    }

    /// Whether its residual change is a smooth function of the motion (the pose, the legs'
    /// model, time, the mean forces): the IMU's errors act through the noisy recorded rates
    /// and accelerations, so their residual changes carry that noise, which a fit of their
    /// amplitudes would absorb ([`super::rigid`] leaves them out).
    pub fn is_smooth(&self) -> bool {
        !matches!(
            self,
            Scalar::Misalignment(_)
                | Scalar::GyroScale(_)
                | Scalar::AccelScale(_)
                | Scalar::LeverArm(_)
                | Scalar::TimeSkew
                | Scalar::GyroMode(_)
                | Scalar::LeverArmMode(_)
        )
    }

    /// One sigma of this error from the rig description's figures.
    pub fn sigma(&self, f: &Figures) -> f64 {
        let s = &f.sensors;
        match self {
            Scalar::AccelBias(_) => s.accelerometer.bias_m_s2,
            Scalar::Offset(_) => s.load_cell.zero_offset_n,
            Scalar::Drift(_) => s.load_cell.zero_drift_n_per_min,
            Scalar::Gain(_) => s.load_cell.gain_error,
            Scalar::GainMode(k) => f
                .load_cells
                .as_ref()
                .and_then(|c| c.modes.get(*k))
                .map_or(0.0, |m| m.0),
            Scalar::Crosstalk(..) => s.load_cell.transverse_sensitivity,
            Scalar::Misalignment(_) => s.imu.misalignment_deg.to_radians(),
            Scalar::GyroScale(_) => s.gyro.scale_error,
            Scalar::AccelScale(_) => s.accelerometer.scale_error,
            Scalar::LeverArm(_) => s.imu.position_tolerance_m,
            Scalar::TimeSkew => f
                .imu
                .as_ref()
                .map_or(s.timing.imu_skew_s, |c| c.delay_sigma_s),
            Scalar::GyroMode(k) => f
                .imu
                .as_ref()
                .and_then(|c| c.gyro_modes.get(*k))
                .map_or(0.0, |m| m.0),
            Scalar::LeverArmMode(k) => f
                .imu
                .as_ref()
                .and_then(|c| c.lever_modes.get(*k))
                .map_or(0.0, |m| m.0),
            Scalar::Joint(..) => f.joint_tolerance_m,
            Scalar::LegDynamics | Scalar::JointFriction => {
                if f.legs_compensated {
                    0.0
                } else {
                    1.0
                }
            }
            Scalar::LegFigure(k) => {
                if f.legs_compensated {
                    leg_model::tolerance(&f.legs, *k)
                } else {
                    0.0
                }
            }
        }
    }
}

/// Every scalar of `source`, in a fixed order for given figures (empty for the statistical
/// sources): with a calibrated IMU, its gyro's nine principal errors and the accelerometer's
/// three datasheet scales, and its position's three principal errors; with calibrated load
/// cells, the six principal errors of their gains.
pub fn scalars(source: ErrorSource, figures: &super::Figures) -> Vec<Scalar> {
    let axes = 0..3;
    let legs = 0..6;
    let calibrated = figures.imu.is_some();
    match source {
        ErrorSource::ImuMisalignment if calibrated => (0..9)
            .map(Scalar::GyroMode)
            .chain(axes.map(Scalar::AccelScale))
            .collect(),
        ErrorSource::ImuLeverArm if calibrated => (0..3).map(Scalar::LeverArmMode).collect(),
        ErrorSource::LoadCellScale if figures.load_cells.is_some() => {
            (0..6).map(Scalar::GainMode).collect()
        }
        ErrorSource::AccelBias => axes.map(Scalar::AccelBias).collect(),
        ErrorSource::LoadCellOffset => legs
            .clone()
            .map(Scalar::Offset)
            .chain(legs.map(Scalar::Drift))
            .collect(),
        ErrorSource::LoadCellScale => legs.map(Scalar::Gain).collect(),
        ErrorSource::LoadCellCrosstalk => legs
            .flat_map(|l| [Scalar::Crosstalk(l, 0), Scalar::Crosstalk(l, 1)])
            .collect(),
        ErrorSource::ImuMisalignment => axes
            .clone()
            .map(Scalar::Misalignment)
            .chain(axes.clone().map(Scalar::GyroScale))
            .chain(axes.map(Scalar::AccelScale))
            .collect(),
        ErrorSource::ImuLeverArm => axes.map(Scalar::LeverArm).collect(),
        ErrorSource::TimeSkew => vec![Scalar::TimeSkew],
        ErrorSource::Geometry => [false, true]
            .into_iter()
            .flat_map(|plate| {
                (0..6).flat_map(move |l| (0..3).map(move |c| Scalar::Joint(plate, l, c)))
            })
            .collect(),
        ErrorSource::LegDynamics => core::iter::once(Scalar::LegDynamics)
            .chain((0..6).map(Scalar::LegFigure))
            .collect(),
        ErrorSource::JointFriction => vec![
            Scalar::JointFriction,
            Scalar::LegFigure(6),
            Scalar::LegFigure(7),
        ],
        _ => Vec::new(),
    }
}

/// What the perturbations read besides the scalar: the base data and fit, the legs' model.
pub struct Context<'a> {
    /// The record's data.
    pub data: &'a Data,
    /// Its fit.
    pub fit: &'a Fit,
    /// The described legs' effects at each entry.
    pub legs: &'a LegEffects,
    /// The described legs.
    pub described: &'a rig_description::config::LegsConfig,
    /// The plate's motion at each entry ([`leg_model::motions`]).
    pub motions: &'a [Option<PlateMotion>],
    /// The calibrated IMU, when one is applied.
    pub imu: Option<&'a CalibratedImu>,
    /// The calibrated load-cell gains, when applied.
    pub load_cells: Option<&'a CalibratedGains>,
    /// Gravity, m/s², when the run measured the accelerometer's vertical offset at rest
    /// ([`estimator::hold`]): that measurement takes up the static part of an accelerometer
    /// error along z as well, so the error's effect is what is left of it in motion.
    pub rest_gravity_m_s2: Option<f64>,
    /// The described geometry's leg lengths, leg wrench and factored Jacobian at each
    /// interior entry, which every joint coordinate's perturbation compares against and
    /// solves with: computed once, by the first that needs them.
    pub joint_baseline: OnceLock<Vec<JointBaseline>>,
    /// The leg-force → wrench map (wrench about the P origin in P axes per newton of each
    /// leg, one column per leg) at each interior entry, which every load-cell error's
    /// wrench is a multiple of: computed once, by the first that needs it.
    pub leg_maps: OnceLock<Vec<Matrix6<f64>>>,
}

/// The described geometry at one interior entry of the record ([`Context::joint_baseline`]).
#[derive(Clone, Debug)]
pub struct JointBaseline {
    /// Leg lengths at the recorded pose, m.
    lengths_m: Vector6<f64>,
    /// The leg forces' wrench at the recorded pose ([`leg_wrench`]).
    wrench: Vector6<f64>,
    /// The Jacobian at the recorded pose, factored: a joint a fraction of a millimetre off
    /// changes it by as little, so its Newton step solves with this one (the step is first
    /// order in the joint's error either way).
    jacobian: LU<f64, U6, U6>,
}

impl Context<'_> {
    /// [`Context::leg_maps`]: column j is [`leg_wrench`] of a unit force on leg j.
    fn leg_maps(&self) -> &[Matrix6<f64>] {
        self.leg_maps.get_or_init(|| {
            let g = &self.data.model.geometry;
            self.fit
                .idx
                .iter()
                .map(|&i| {
                    let pose = &self.data.poses[i];
                    let columns: [Vector6<f64>; 6] =
                        core::array::from_fn(|leg| leg_wrench(g, pose, &Vector6::ith(leg, 1.0)));
                    Matrix6::from_columns(&columns)
                })
                .collect()
        })
    }

    /// [`Context::joint_baseline`]: the described geometry at each interior entry.
    fn joint_baseline(&self) -> &[JointBaseline] {
        self.joint_baseline.get_or_init(|| {
            let g = &self.data.model.geometry;
            self.fit
                .idx
                .iter()
                .map(|&i| {
                    let pose = self.data.poses[i];
                    let f = self.data.entries[i].leg_forces_n;
                    JointBaseline {
                        lengths_m: g.leg_lengths(&pose),
                        wrench: leg_wrench(g, &pose, &f),
                        jacobian: g.jacobian(&pose).lu(),
                    }
                })
                .collect()
        })
    }
}

/// The IMU's readings through M and N, less what the offset measured at rest takes out: at the
/// level rest pose the specific force is (0, 0, g), and the hold's vertical offset moves by
/// (N (0, 0, g))_z − g, subtracted from every reading's z.
fn transform_imu_after_rest(data: &mut Data, m: &Matrix3<f64>, n: &Matrix3<f64>, g: Option<f64>) {
    transform_imu(data, m, n);
    if let Some(g) = g {
        let offset = (n[(2, 2)] - 1.0) * g;
        for e in &mut data.entries {
            e.accel_m_s2.z -= offset;
        }
    }
}

/// M Q Mᵀ for the products Q (entries of ω ωᵀ) of ω' = M ω.
fn transform_products(q: &Vector6<f64>, m: &Matrix3<f64>) -> Vector6<f64> {
    #[rustfmt::skip]
    let full = Matrix3::new(
        q[0], q[3], q[4],
        q[3], q[1], q[5],
        q[4], q[5], q[2],
    );
    let t = m * full * m.transpose();
    Vector6::new(
        t[(0, 0)],
        t[(1, 1)],
        t[(2, 2)],
        t[(0, 1)],
        t[(0, 2)],
        t[(1, 2)],
    )
}

/// The IMU's readings through M (gyro, products) and N (accelerometer).
fn transform_imu(data: &mut Data, m: &Matrix3<f64>, n: &Matrix3<f64>) {
    for e in &mut data.entries {
        e.gyro_rad_s = m * e.gyro_rad_s;
        e.products = transform_products(&e.products, m);
        e.accel_m_s2 = n * e.accel_m_s2;
    }
}

/// The wrench of leg forces `df` at `pose` (P axes, about the P origin).
fn leg_wrench(g: &Geometry, pose: &Pose, df: &Vector6<f64>) -> Vector6<f64> {
    estimator::wrench::to_vector(&g.wrench_in_platform(pose, df))
}

impl Scalar {
    /// The change of the fit's residual at its interior entries when `sigma` of this error is
    /// applied to the recorded data.
    pub fn residual_change(&self, ctx: &Context<'_>, sigma: f64) -> Vec<Vector6<f64>> {
        let fit = ctx.fit;
        let base = ctx.data;
        let model = &base.model;
        let t0 = base.entries.first().map_or(0.0, |e| e.time_s);
        // A change of the leg forces or of the wrench only: Δr = Δy.
        let wrench_only = |dy: &dyn Fn(usize) -> Vector6<f64>| -> Vec<Vector6<f64>> {
            fit.idx.iter().map(|&i| model.map_wrench(&dy(i))).collect()
        };
        // The wrench is linear in the leg forces: a load-cell error's is its force change
        // through the entry's leg map.
        let through_legs = |df: &dyn Fn(usize) -> Vector6<f64>| -> Vec<Vector6<f64>> {
            fit.idx
                .iter()
                .zip(ctx.leg_maps())
                .map(|(&i, map)| model.map_wrench(&(map * df(i))))
                .collect()
        };
        let leg_force =
            |leg: usize, df: &dyn Fn(usize) -> f64| through_legs(&|i| Vector6::ith(leg, df(i)));
        let with_data = |change: &dyn Fn(&mut Data)| {
            let mut d = base.clone();
            change(&mut d);
            fit.residual_change(&d)
        };
        match *self {
            Scalar::Offset(leg) => leg_force(leg, &|_| sigma),
            Scalar::Drift(leg) => leg_force(leg, &|i| sigma * (base.entries[i].time_s - t0) / 60.0),
            Scalar::Gain(leg) => leg_force(leg, &|i| sigma * base.entries[i].leg_forces_n[leg]),
            Scalar::GainMode(k) => {
                let Some((_, dir)) = ctx.load_cells.and_then(|c| c.modes.get(k)) else {
                    return vec![Vector6::zeros(); fit.idx.len()];
                };
                through_legs(&|i| base.entries[i].leg_forces_n.component_mul(dir) * sigma)
            }
            Scalar::Crosstalk(leg, dir) => {
                leg_force(leg, &|i| sigma * ctx.legs.transverse[i][leg][dir])
            }
            Scalar::LegDynamics => wrench_only(&|i| ctx.legs.dynamics[i] * sigma),
            Scalar::JointFriction => wrench_only(&|i| ctx.legs.friction[i] * sigma),
            Scalar::LegFigure(k) => {
                // The built legs carry the figure off by σ; the compensation the described one.
                let off = leg_model::moved(ctx.described, k, sigma);
                let e = leg_model::totals(base, ctx.motions, &off);
                wrench_only(&|i| e[i] - ctx.legs.dynamics[i] - ctx.legs.friction[i])
            }
            Scalar::Joint(plate, leg, coord) => joint_change(ctx, plate, leg, coord, sigma),
            Scalar::AccelBias(axis) => with_data(&|d| {
                for e in &mut d.entries {
                    e.accel_m_s2[axis] += sigma;
                }
            }),
            Scalar::Misalignment(axis) => {
                // The IMU turned by a small rotation about P's axis: both sensors alike.
                let r = *Rotation3::new(Vector3::ith(axis, sigma)).matrix();
                with_data(&|d| transform_imu_after_rest(d, &r, &r, ctx.rest_gravity_m_s2))
            }
            Scalar::GyroScale(axis) => {
                let mut m = Matrix3::identity();
                m[(axis, axis)] += sigma;
                with_data(&|d| transform_imu(d, &m, &Matrix3::identity()))
            }
            Scalar::AccelScale(axis) => {
                let mut n = Matrix3::identity();
                n[(axis, axis)] += sigma;
                with_data(&|d| {
                    transform_imu_after_rest(d, &Matrix3::identity(), &n, ctx.rest_gravity_m_s2)
                })
            }
            Scalar::LeverArm(axis) => with_data(&|d| d.model.lever_m[axis] += sigma),
            Scalar::GyroMode(k) => {
                let Some((_, dir)) = ctx.imu.and_then(|c| c.gyro_modes.get(k)) else {
                    return vec![Vector6::zeros(); fit.idx.len()];
                };
                // The gyro's matrix off by σ·dir; the accelerometer turned by its rotation.
                let m = Matrix3::identity() + dir * sigma;
                let n = rig_description::calibration::imu::rotation_of(&m);
                with_data(&|d| transform_imu_after_rest(d, &m, &n, ctx.rest_gravity_m_s2))
            }
            Scalar::LeverArmMode(k) => {
                let Some((_, dir)) = ctx.imu.and_then(|c| c.lever_modes.get(k)) else {
                    return vec![Vector6::zeros(); fit.idx.len()];
                };
                with_data(&|d| d.model.lever_m += dir * sigma)
            }
            Scalar::TimeSkew => with_data(&|d| skew(d, fit.h, sigma)),
        }
    }
}

/// The IMU's channels (rate, products, specific force) read `s` late: x(t − s) ≈ x − s ẋ with
/// the zero-phase derivative; the entries within two of the record's ends keep their values.
fn skew(d: &mut Data, h: f64, s: f64) {
    let n = d.entries.len();
    if n < 5 {
        return;
    }
    let gyro: Vec<Vector3<f64>> = d.entries.iter().map(|e| e.gyro_rad_s).collect();
    let prod: Vec<Vector6<f64>> = d.entries.iter().map(|e| e.products).collect();
    let acc: Vec<Vector3<f64>> = d.entries.iter().map(|e| e.accel_m_s2).collect();
    for i in 2..n - 2 {
        let e = &mut d.entries[i];
        e.gyro_rad_s -= d1(&gyro, i, h) * s;
        e.products -= d1(&prod, i, h) * s;
        e.accel_m_s2 -= d1(&acc, i, h) * s;
    }
}

/// A joint coordinate off by `sigma`: the same leg lengths give another pose (one Newton step
/// of forward kinematics from the described pose, J' Δx = l − l'(pose)) and other leg
/// directions; the wrench changes by L'(pose') f − L(pose) f.
///
/// With calibrated gains, the calibration's fit made on the rig with this joint moved would
/// have given gains s (its [`CalibratedGains::joint_change`]) more: both changes are "the
/// built rig in place of the drawing", one for the calibration, one for the measurement.
/// The cells' readings, divided by the applied gains, then read s_i f_i less, so the wrench
/// changes by L'(pose') f − L(pose) f − Σ_i s_i f_i L_i(pose) (the gains' part to first
/// order).
fn joint_change(
    ctx: &Context<'_>,
    plate: bool,
    leg: usize,
    coord: usize,
    sigma: f64,
) -> Vec<Vector6<f64>> {
    let base = ctx.data;
    let model = &base.model;
    let g = &model.geometry;
    let zero = vec![Vector6::zeros(); ctx.fit.idx.len()];
    if sigma == 0.0 {
        return zero;
    }
    let mut b = *g.base_joints_m();
    let mut p = *g.plate_joints_m();
    if plate {
        p[leg][coord] += sigma;
    } else {
        b[leg][coord] += sigma;
    }
    let Ok(built) = g.with_joints(b, p) else {
        return zero;
    };
    let gain_change = ctx
        .load_cells
        .map_or_else(Vector6::zeros, |c| c.joint_change(plate, leg, coord, sigma));
    ctx.fit
        .idx
        .iter()
        .zip(ctx.joint_baseline())
        .map(|(&i, described)| {
            let pose = base.poses[i];
            let dl = described.lengths_m - built.leg_lengths(&pose);
            let Some(dx) = described.jacobian.solve(&dl) else {
                return Vector6::zeros();
            };
            let moved = Pose::new(
                pose.position_m + Vector3::new(dx[0], dx[1], dx[2]),
                Rotation3::new(Vector3::new(dx[3], dx[4], dx[5])) * pose.rotation,
            );
            let f = base.entries[i].leg_forces_n;
            let gains = leg_wrench(g, &pose, &f.component_mul(&gain_change));
            model.map_wrench(&(leg_wrench(&built, &moved, &f) - described.wrench - gains))
        })
        .collect()
}

/// The poses that the lengths of `poses` (legs of the described `geometry`) give on a rig
/// whose joint `leg` (plate's, else base's) is off by `delta_m` along `coord`: one Newton step
/// of forward kinematics from each pose. `None` when the moved geometry is not a platform.
pub fn moved_poses(
    geometry: &Geometry,
    poses: &[Pose],
    plate: bool,
    leg: usize,
    coord: usize,
    delta_m: f64,
) -> Option<Vec<Pose>> {
    let mut b = *geometry.base_joints_m();
    let mut p = *geometry.plate_joints_m();
    let joint = if plate {
        p.get_mut(leg)?
    } else {
        b.get_mut(leg)?
    };
    *joint.get_mut(coord)? += delta_m;
    let built = geometry.with_joints(b, p).ok()?;
    poses
        .iter()
        .map(|pose| {
            let dl = geometry.leg_lengths(pose) - built.leg_lengths(pose);
            let dx = built.jacobian(pose).lu().solve(&dl)?;
            Some(Pose::new(
                pose.position_m + Vector3::new(dx[0], dx[1], dx[2]),
                Rotation3::new(Vector3::new(dx[3], dx[4], dx[5])) * pose.rotation,
            ))
        })
        .collect()
}
