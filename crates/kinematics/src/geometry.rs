//! The platform's design: joint positions and leg stroke, validated on construction.

use crate::real::{self, Real};
use crate::{KinematicsError, Pose, LEG_COUNT, SINGULARITY_THRESHOLD};
use nalgebra::Vector3;

/// Minimum and maximum leg length (joint centre to joint centre), metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrokeLimits<T = f64> {
    /// Shortest allowed leg length, m.
    pub min_length_m: T,
    /// Longest allowed leg length, m.
    pub max_length_m: T,
}

impl<T: Real> StrokeLimits<T> {
    /// Middle of the stroke, m.
    pub fn mid_m(&self) -> T {
        T::lit(0.5) * (self.min_length_m + self.max_length_m)
    }

    /// The same limits in another precision.
    pub fn cast<U: Real>(&self) -> StrokeLimits<U> {
        StrokeLimits {
            min_length_m: U::lit(self.min_length_m.to_f64()),
            max_length_m: U::lit(self.max_length_m.to_f64()),
        }
    }
}

/// A validated 6-6 Stewart platform design.
///
/// Leg i joins base joint bᵢ (in B) to plate joint pᵢ (in P). Construction refuses designs
/// that are degenerate or singular at their home pose, so every `Geometry` can be moved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry<T = f64> {
    base_joints_m: [Vector3<T>; LEG_COUNT],
    plate_joints_m: [Vector3<T>; LEG_COUNT],
    stroke: StrokeLimits<T>,
    /// Length that makes torque columns of the Jacobian comparable with force columns.
    characteristic_length_m: T,
    home_height_m: T,
    /// The home height was given ([`Geometry::with_home_height_m`]), not solved for.
    home_given: bool,
}

/// Joints closer than this are treated as coincident, m (8 units in the last place of a
/// 1.5 m coordinate in f32, so the check means the same in both precisions).
const MIN_JOINT_SPACING_M: f64 = 1e-6;

impl<T: Real> Geometry<T> {
    /// The usual design: joints in three pairs on each circle, the plate's pairs turned 60°
    /// against the base's (the paper's Eq. 1–2 as printed put both at the same angles, which is
    /// architecturally singular).
    ///
    /// Base pair k is centred at 120°·k, plate pair k at 120°·k + 60°; the joints of a pair are
    /// `*_pair_separation_rad` apart. Leg 2k+1 joins the base joint at 120°k + s_b/2 to the
    /// plate joint at 120°k + 60° − s_p/2, leg 2k the base joint at 120°k − s_b/2 to the plate
    /// joint at 120°k − 60° + s_p/2: each leg reaches to the nearest joint of the neighbouring
    /// plate pair, which gives the inclined legs that make the mechanism stiff in yaw.
    pub fn from_radii(
        base_radius_m: T,
        plate_radius_m: T,
        base_pair_separation_rad: T,
        plate_pair_separation_rad: T,
        stroke: StrokeLimits<T>,
    ) -> Result<Self, KinematicsError> {
        positive("base radius must be positive and finite", base_radius_m)?;
        positive("plate radius must be positive and finite", plate_radius_m)?;
        separation(
            "base pair separation must lie in (0°, 120°)",
            base_pair_separation_rad,
        )?;
        separation(
            "plate pair separation must lie in (0°, 120°)",
            plate_pair_separation_rad,
        )?;
        let on_circle = |radius: T, angle: T| {
            Vector3::new(
                radius * real::cos(angle),
                radius * real::sin(angle),
                T::zero(),
            )
        };
        let pi = real::pi::<T>();
        let third = T::lit(2.0) * pi / T::lit(3.0);
        // Leg i belongs to pair k = i/2; even legs take the pair's first joints, odd legs its
        // second.
        let centre = |i: usize| third * T::lit((i / 2) as f64);
        let half = T::lit(0.5);
        let base = core::array::from_fn(|i| {
            let half = half * base_pair_separation_rad;
            let offset = if i % 2 == 0 { -half } else { half };
            on_circle(base_radius_m, centre(i) + offset)
        });
        let plate = core::array::from_fn(|i| {
            let angle = if i % 2 == 0 {
                centre(i) - pi / T::lit(3.0) + half * plate_pair_separation_rad
            } else {
                centre(i) + pi / T::lit(3.0) - half * plate_pair_separation_rad
            };
            on_circle(plate_radius_m, angle)
        });
        Self::from_points(base, plate, stroke)
    }

    /// A design from six explicit joint positions on each body (base joints in B, plate joints
    /// in P), for rigs that are not perfectly symmetric.
    pub fn from_points(
        base_joints_m: [Vector3<T>; LEG_COUNT],
        plate_joints_m: [Vector3<T>; LEG_COUNT],
        stroke: StrokeLimits<T>,
    ) -> Result<Self, KinematicsError> {
        if !all_finite(&base_joints_m) {
            return Err(KinematicsError::NonFinite {
                what: "base joint positions",
            });
        }
        if !all_finite(&plate_joints_m) {
            return Err(KinematicsError::NonFinite {
                what: "plate joint positions",
            });
        }
        if !(stroke.min_length_m.is_finite()
            && stroke.max_length_m.is_finite()
            && stroke.min_length_m > T::zero()
            && stroke.min_length_m < stroke.max_length_m)
        {
            return Err(KinematicsError::InvalidStroke {
                min_length_m: stroke.min_length_m.to_f64(),
                max_length_m: stroke.max_length_m.to_f64(),
            });
        }
        distinct(&base_joints_m, true)?;
        distinct(&plate_joints_m, false)?;
        let mean_radius = |joints: &[Vector3<T>; LEG_COUNT]| {
            joints.iter().map(|p| p.xy().norm()).sum::<T>() / T::lit(LEG_COUNT as f64)
        };
        let plate_radius_m = mean_radius(&plate_joints_m);
        if plate_radius_m < T::lit(MIN_JOINT_SPACING_M) {
            return Err(KinematicsError::InvalidDimension {
                what: "plate joints must not all lie on the plate's z axis",
                value: plate_radius_m.to_f64(),
            });
        }
        // The rig's size, not the plate's alone: a plate far smaller than the base resolves
        // rotations by leg-length changes that scale with the plate's radius, and the
        // conditioning measure must see that (a 1 mm plate on a 1.5 m base is singular for
        // every purpose, although its Jacobian scaled by its own radius looks well conditioned).
        let characteristic_length_m = plate_radius_m.max(mean_radius(&base_joints_m));
        let mut geometry = Self {
            base_joints_m,
            plate_joints_m,
            stroke,
            characteristic_length_m,
            home_height_m: T::zero(),
            home_given: false,
        };
        geometry.home_height_m = geometry.solve_home_height()?;
        let inverse_condition = geometry
            .inverse_condition_number(&geometry.home_pose())
            .to_f64();
        if inverse_condition.is_nan() || inverse_condition < SINGULARITY_THRESHOLD {
            return Err(KinematicsError::ArchitecturallySingular { inverse_condition });
        }
        Ok(geometry)
    }

    /// Base joint positions bᵢ, in B, m.
    pub fn base_joints_m(&self) -> &[Vector3<T>; LEG_COUNT] {
        &self.base_joints_m
    }

    /// Plate joint positions pᵢ, in P, m.
    pub fn plate_joints_m(&self) -> &[Vector3<T>; LEG_COUNT] {
        &self.plate_joints_m
    }

    /// Leg stroke limits.
    pub fn stroke(&self) -> StrokeLimits<T> {
        self.stroke
    }

    /// Length used to scale rotations against translations, m: the larger of the mean base and
    /// mean plate joint radius (the rig's size).
    pub fn characteristic_length_m(&self) -> T {
        self.characteristic_length_m
    }

    /// The same design with its home at height `z_m` above B (level and centred), as a rig's
    /// owner measures it, instead of the pose whose mean leg length is mid-stroke. Refused when
    /// a leg cannot reach it ([`KinematicsError::LegTooShort`], [`KinematicsError::LegTooLong`])
    /// or the design is singular there.
    pub fn with_home_height_m(mut self, z_m: T) -> Result<Self, KinematicsError> {
        if !z_m.is_finite() {
            return Err(KinematicsError::NonFinite {
                what: "home height",
            });
        }
        self.home_height_m = z_m;
        self.home_given = true;
        self.check_reachable(&self.home_pose())?;
        let inverse_condition = self.inverse_condition_number(&self.home_pose()).to_f64();
        if inverse_condition.is_nan() || inverse_condition < SINGULARITY_THRESHOLD {
            return Err(KinematicsError::ArchitecturallySingular { inverse_condition });
        }
        Ok(self)
    }

    /// The same design with its joints at `base_joints_m` and `plate_joints_m` (a survey's,
    /// or the built rig's): the stroke kept, and the home height when it was given, else
    /// solved again.
    pub fn with_joints(
        &self,
        base_joints_m: [Vector3<T>; LEG_COUNT],
        plate_joints_m: [Vector3<T>; LEG_COUNT],
    ) -> Result<Self, KinematicsError> {
        let g = Self::from_points(base_joints_m, plate_joints_m, self.stroke)?;
        if self.home_given {
            g.with_home_height_m(self.home_height_m)
        } else {
            Ok(g)
        }
    }

    /// Whether the home height was given ([`Geometry::with_home_height_m`]).
    pub fn home_is_given(&self) -> bool {
        self.home_given
    }

    /// The home pose: level and centred, at the given height ([`Geometry::with_home_height_m`])
    /// or else at the one whose mean leg length is mid-stroke.
    pub fn home_pose(&self) -> Pose<T> {
        Pose::new(
            Vector3::new(T::zero(), T::zero(), self.home_height_m),
            nalgebra::Rotation3::identity(),
        )
    }

    /// Height z of the level, centred pose whose mean leg length is the mid-stroke length.
    ///
    /// Mean length is monotonic in z for z above every joint, so bisection is exact and safe.
    fn solve_home_height(&self) -> Result<T, KinematicsError> {
        let target = self.stroke.mid_m();
        let mean_length = |z: T| {
            let offset = Vector3::new(T::zero(), T::zero(), z);
            let mut sum = T::zero();
            for (b, p) in self.base_joints_m.iter().zip(self.plate_joints_m.iter()) {
                sum += (offset + p - b).norm();
            }
            sum / T::lit(LEG_COUNT as f64)
        };
        let lowest = self
            .base_joints_m
            .iter()
            .zip(self.plate_joints_m.iter())
            .map(|(b, p)| b.z - p.z)
            .fold(T::lit(f64::NEG_INFINITY), T::max);
        let mut lo = lowest;
        if mean_length(lo) > target {
            return Err(KinematicsError::HomeUnreachable);
        }
        let mut hi = lowest + target + T::one();
        for _ in 0..200 {
            let mid = T::lit(0.5) * (lo + hi);
            if mean_length(mid) < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Ok(T::lit(0.5) * (lo + hi))
    }

    /// The same design in another precision: the joints and the stroke converted (rounded to
    /// nearest into f32), the home height (unless given) and the conditioning recomputed in `U`.
    pub fn cast<U: Real>(&self) -> Result<Geometry<U>, KinematicsError> {
        let convert =
            |joints: &[Vector3<T>; LEG_COUNT]| joints.map(|p| p.map(|v| U::lit(v.to_f64())));
        let g = Geometry::from_points(
            convert(&self.base_joints_m),
            convert(&self.plate_joints_m),
            self.stroke.cast(),
        )?;
        if self.home_given {
            g.with_home_height_m(U::lit(self.home_height_m.to_f64()))
        } else {
            Ok(g)
        }
    }
}

fn positive<T: Real>(what: &'static str, value: T) -> Result<(), KinematicsError> {
    if value.is_finite() && value > T::zero() {
        Ok(())
    } else {
        Err(KinematicsError::InvalidDimension {
            what,
            value: value.to_f64(),
        })
    }
}

fn separation<T: Real>(what: &'static str, value: T) -> Result<(), KinematicsError> {
    if value.is_finite() && value > T::zero() && value < T::lit(2.0) * real::pi() / T::lit(3.0) {
        Ok(())
    } else {
        Err(KinematicsError::InvalidDimension {
            what,
            value: value.to_f64(),
        })
    }
}

fn all_finite<T: Real>(points: &[Vector3<T>; LEG_COUNT]) -> bool {
    points.iter().all(|p| p.iter().all(|v| v.is_finite()))
}

fn distinct<T: Real>(
    points: &[Vector3<T>; LEG_COUNT],
    on_base: bool,
) -> Result<(), KinematicsError> {
    for (first, a) in points.iter().enumerate() {
        for (second, b) in points.iter().enumerate().skip(first + 1) {
            if (a - b).norm() < T::lit(MIN_JOINT_SPACING_M) {
                return Err(KinematicsError::CoincidentJoints {
                    on_base,
                    first,
                    second,
                });
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ErrorKind;
    use core::f64::consts::PI;

    fn stroke() -> StrokeLimits {
        StrokeLimits {
            min_length_m: 1.5,
            max_length_m: 2.3,
        }
    }

    #[test]
    fn home_pose_puts_every_leg_at_mid_stroke() {
        let g = Geometry::from_radii(1.5, 1.2, 0.35, 0.35, stroke()).unwrap();
        let lengths = g.leg_lengths(&g.home_pose());
        for l in lengths.iter() {
            assert!((l - 1.9).abs() < 1e-12, "leg length {l}");
        }
    }

    #[test]
    fn a_given_home_height_is_the_home_and_one_out_of_stroke_is_refused() {
        let solved = Geometry::from_radii(1.5, 1.2, 0.35, 0.35, stroke()).unwrap();
        let z = solved.home_pose().position_m.z + 0.1;
        let given = solved.with_home_height_m(z).unwrap();
        assert!(given.home_is_given() && !solved.home_is_given());
        assert_eq!(given.home_pose().position_m, Vector3::new(0.0, 0.0, z));
        // 10 cm higher: every leg longer than mid-stroke, within the stroke.
        for l in given.leg_lengths(&given.home_pose()).iter() {
            assert!(*l > 1.9 && *l < 2.3, "leg length {l}");
        }
        // The f32 design keeps the given home.
        let single = given.cast::<f32>().unwrap();
        assert!((f64::from(single.home_pose().position_m.z) - z).abs() < 1e-6);
        assert!(matches!(
            solved.with_home_height_m(z + 1.0),
            Err(KinematicsError::LegTooLong { .. })
        ));
        assert!(matches!(
            solved.with_home_height_m(0.2),
            Err(KinematicsError::LegTooShort { .. })
        ));
        assert!(matches!(
            solved.with_home_height_m(f64::NAN),
            Err(KinematicsError::NonFinite { .. })
        ));
    }

    #[test]
    fn paper_printed_angles_are_refused_as_singular() {
        // Eq. 1–2 as printed: the same six angles, spread over 150°, on both circles.
        let mut base = [Vector3::zeros(); LEG_COUNT];
        let mut plate = [Vector3::zeros(); LEG_COUNT];
        for i in 0..LEG_COUNT {
            let a = i as f64 * PI / 6.0;
            base[i] = Vector3::new(1.5 * a.cos(), 1.5 * a.sin(), 0.0);
            plate[i] = Vector3::new(1.2 * a.cos(), 1.2 * a.sin(), 0.0);
        }
        let err = Geometry::from_points(base, plate, stroke()).unwrap_err();
        assert!(
            matches!(err, KinematicsError::ArchitecturallySingular { .. }),
            "{err:?}"
        );
        assert_eq!(err.kind(), ErrorKind::InvalidGeometry);
    }

    #[test]
    fn degenerate_designs_say_why() {
        assert!(matches!(
            Geometry::from_radii(-1.0, 1.2, 0.3, 0.3, stroke()),
            Err(KinematicsError::InvalidDimension { .. })
        ));
        assert!(matches!(
            Geometry::from_radii(1.5, 1.2, 0.0, 0.3, stroke()),
            Err(KinematicsError::InvalidDimension { .. })
        ));
        assert!(matches!(
            Geometry::from_radii(
                1.5,
                1.2,
                0.3,
                0.3,
                StrokeLimits {
                    min_length_m: 2.0,
                    max_length_m: 1.0
                }
            ),
            Err(KinematicsError::InvalidStroke { .. })
        ));
        assert!(matches!(
            Geometry::from_radii(f64::NAN, 1.2, 0.3, 0.3, stroke()),
            Err(KinematicsError::InvalidDimension { .. })
        ));
        // Circles far apart compared with the stroke: no pose reaches mid-stroke.
        assert_eq!(
            Geometry::from_radii(10.0, 1.0, 0.3, 0.3, stroke()),
            Err(KinematicsError::HomeUnreachable)
        );
        let mut base = [Vector3::zeros(); LEG_COUNT];
        for (i, b) in base.iter_mut().enumerate() {
            *b = Vector3::new(i as f64, 0.0, 0.0);
        }
        let mut plate = base;
        plate[3] = plate[1];
        assert!(matches!(
            Geometry::from_points(base, plate, stroke()),
            Err(KinematicsError::CoincidentJoints {
                on_base: false,
                first: 1,
                second: 3
            })
        ));
        let message = format!(
            "{}",
            Geometry::from_points(base, plate, stroke()).unwrap_err()
        );
        assert!(message.contains("plate joints 2 and 4"), "{message}");
    }
}
