//! A bounded record of one run: the estimator's samples, averaged over blocks of about 10 ms
//! (100 Hz), for the error budget's offline fit ([`crate::budget::fit`]) and the IMU
//! calibration ([`rig_description::calibration::imu`]).
//!
//! **Why averaging, not striding.** The rigid-body equations are linear in ω̇, the products
//! ωᵢωⱼ, the specific force and the wrench ([`estimator::regressor`]); a block mean of each of
//! those (the products formed per sample before averaging, the wrench from each sample's own
//! pose) keeps `mean wrench = Φ(mean signals) θ` exact, and the derivative of the mean rate is
//! the mean of the derivative. Striding would keep each sample's full noise and alias
//! everything above 50 Hz; the mean divides white noise's variance by the samples in the block.
//! The pose (needed for the geometry's and the legs' perturbations, which are smooth in it) is
//! the block's mean position and normalised mean quaternion.
//!
//! **Bounded.** At most [`RunRecord::CAPACITY`] entries: when full, neighbouring entries are
//! merged pairwise (weighted by their samples) and the block length doubles, as
//! [`crate::report::ThetaHistory`] does. Memory is reserved up front for the expected run, so
//! pushing does not allocate in the per-sample loop.

use estimator::Sample;
use kinematics::{Geometry, Pose};
use nalgebra::{Quaternion, UnitQuaternion, Vector3, Vector6};

pub mod derivative;

use derivative::products;

/// One entry: the mean of a block of consecutive samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Entry {
    /// Mean time, s.
    pub time_s: f64,
    /// Samples averaged.
    pub samples: u32,
    /// Mean position of the P origin in B, m.
    pub position_m: Vector3<f64>,
    /// Sum of the rotation's quaternions (signs aligned); normalised by [`Entry::pose`].
    pub quaternion: Quaternion<f64>,
    /// Mean axial leg forces, N.
    pub leg_forces_n: Vector6<f64>,
    /// Mean wrench on the plate about the P origin in P axes, [F; τ] (each sample's own pose).
    pub wrench: Vector6<f64>,
    /// Mean gyro rate in P, rad/s.
    pub gyro_rad_s: Vector3<f64>,
    /// Mean of the products [ωx², ωy², ωz², ωxωy, ωxωz, ωyωz], rad²/s².
    pub products: Vector6<f64>,
    /// Mean specific force at the accelerometer, in P, m/s².
    pub accel_m_s2: Vector3<f64>,
}

impl Entry {
    /// The mean pose (mean position, normalised mean quaternion).
    pub fn pose(&self) -> Pose {
        let q = UnitQuaternion::from_quaternion(self.quaternion);
        Pose::new(self.position_m, q.to_rotation_matrix())
    }

    fn of(sample: &Sample, geometry: &Geometry) -> Self {
        let w = geometry.wrench_in_platform(&sample.pose, &sample.leg_forces_n);
        Self {
            time_s: sample.time_s,
            samples: 1,
            position_m: sample.pose.position_m,
            quaternion: *UnitQuaternion::from_rotation_matrix(&sample.pose.rotation).quaternion(),
            leg_forces_n: sample.leg_forces_n,
            wrench: estimator::wrench::to_vector(&w),
            gyro_rad_s: sample.gyro_rad_s,
            products: products(&sample.gyro_rad_s),
            accel_m_s2: sample.accel_m_s2,
        }
    }

    /// The weighted mean of `self` and `other` (quaternion signs aligned to `self`'s).
    fn merge(&self, other: &Entry) -> Entry {
        if self.samples == 0 {
            return *other;
        }
        let (a, b) = (self.samples as f64, other.samples as f64);
        let n = a + b;
        let mean = |x: f64, y: f64| (a * x + b * y) / n;
        let q_other = if self.quaternion.coords.dot(&other.quaternion.coords) < 0.0 {
            -other.quaternion
        } else {
            other.quaternion
        };
        let qa = self.quaternion.normalize();
        let qb = q_other.normalize();
        Entry {
            time_s: mean(self.time_s, other.time_s),
            samples: self.samples + other.samples,
            position_m: self.position_m.zip_map(&other.position_m, mean),
            quaternion: Quaternion::from(qa.coords * a + qb.coords * b),
            leg_forces_n: self.leg_forces_n.zip_map(&other.leg_forces_n, mean),
            wrench: self.wrench.zip_map(&other.wrench, mean),
            gyro_rad_s: self.gyro_rad_s.zip_map(&other.gyro_rad_s, mean),
            products: self.products.zip_map(&other.products, mean),
            accel_m_s2: self.accel_m_s2.zip_map(&other.accel_m_s2, mean),
        }
    }
}

/// The record of one run. See the [module docs](self).
#[derive(Clone, Debug)]
pub struct RunRecord {
    geometry: Geometry,
    entries: Vec<Entry>,
    open: Entry,
    /// Samples per entry.
    stride: u32,
    /// Samples pushed.
    count: u64,
    capacity: usize,
}

impl RunRecord {
    /// Entries kept at most: 1311 s at 100 Hz before the first doubling, an hour at 25 Hz
    /// (35 MB). The budget's fit holds about five times the record (its regressors, motions
    /// and one perturbed copy per thread), which this bounds for a run of any length. Its
    /// fourth-order derivative on the entries' grid h errs by about (ωh)⁴/30 of the rate's
    /// derivative ([`derivative::d1`]): at the excitation's highest line (under 2 Hz)
    /// 1.6e-3 at h = 40 ms, 0.42 at 160 ms (the spacing 2¹⁵ entries give an hour's run, whose
    /// rigid payload the rigid-body check reads at 13 times the predicted residual).
    pub const CAPACITY: usize = 1 << 17;

    /// Rate of the entries before any doubling, Hz.
    pub const RATE_HZ: f64 = 100.0;

    /// An empty record for samples of period `sample_period_s` on `geometry` (the wrench's
    /// map), with room reserved for `samples` samples.
    pub fn new(geometry: Geometry, sample_period_s: f64, samples: usize) -> Self {
        Self::with_capacity(geometry, sample_period_s, samples, Self::CAPACITY)
    }

    /// [`Self::new`] with another entry capacity (at least 2; tests).
    pub fn with_capacity(
        geometry: Geometry,
        sample_period_s: f64,
        samples: usize,
        capacity: usize,
    ) -> Self {
        let per = 1.0 / (Self::RATE_HZ * sample_period_s);
        let stride = if per.is_finite() && per >= 1.0 {
            per.round().min(1e6) as u32
        } else {
            1
        };
        let capacity = capacity.max(2);
        Self {
            geometry,
            entries: Vec::with_capacity((samples / stride as usize + 2).min(capacity)),
            open: Entry::default(),
            stride,
            count: 0,
            capacity,
        }
    }

    /// One more sample the estimator used.
    pub fn push(&mut self, sample: &Sample) {
        let e = Entry::of(sample, &self.geometry);
        self.open = self.open.merge(&e);
        self.count += 1;
        if self.open.samples >= self.stride {
            self.close();
        }
    }

    fn close(&mut self) {
        if self.open.samples == 0 {
            return;
        }
        self.entries.push(self.open);
        self.open = Entry::default();
        if self.entries.len() >= self.capacity {
            // Pairwise in place: the per-sample loop never allocates.
            let n = self.entries.len();
            for i in 0..n.div_ceil(2) {
                self.entries[i] = match self.entries.get(2 * i + 1) {
                    Some(next) => self.entries[2 * i].merge(next),
                    None => self.entries[2 * i],
                };
            }
            self.entries.truncate(n.div_ceil(2));
            self.stride = self.stride.saturating_mul(2);
        }
    }

    /// The entries, the block still open included when it holds at least half a block.
    pub fn entries(&self) -> Vec<Entry> {
        let open =
            (self.open.samples * 2 >= self.stride && self.open.samples > 0).then_some(self.open);
        // Sized exactly: a clone and a push would double a long record's copy.
        let mut v = Vec::with_capacity(self.entries.len() + 1);
        v.extend_from_slice(&self.entries);
        v.extend(open);
        v
    }

    /// Samples per entry.
    pub fn stride(&self) -> u32 {
        self.stride
    }

    /// Samples pushed.
    pub fn len(&self) -> u64 {
        self.count
    }

    /// True before the first sample.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The geometry the wrench was computed with.
    pub fn geometry(&self) -> &Geometry {
        &self.geometry
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testkit;

    /// Averages are exact for what is linear (time, forces), the products are averaged per
    /// sample (not the product of means), and the memory stays bounded with the stride doubling.
    #[test]
    fn averages_blocks_and_stays_bounded() {
        let g = testkit::geometry();
        let mut r = RunRecord::with_capacity(g, 1e-3, 0, 8);
        assert_eq!(r.stride(), 10);
        let pose = g.home_pose();
        for k in 0..200 {
            let w = if k % 2 == 0 { 1.0 } else { -1.0 };
            r.push(&Sample {
                time_s: k as f64 * 1e-3,
                sequence: Some(k),
                pose,
                leg_forces_n: Vector6::from_element(k as f64),
                gyro_rad_s: Vector3::new(w, 0.0, 0.0),
                accel_m_s2: Vector3::new(0.0, 0.0, 9.8),
            });
        }
        let e = r.entries();
        assert!(e.len() < 8, "{}", e.len());
        assert_eq!(r.stride(), 40);
        assert!((e[0].time_s - 0.0195).abs() < 1e-12, "{}", e[0].time_s);
        assert!((e[0].leg_forces_n[0] - 19.5).abs() < 1e-12);
        // Mean rate 0, mean square 1.
        assert!(e[0].gyro_rad_s.x.abs() < 1e-12);
        assert!((e[0].products[0] - 1.0).abs() < 1e-12);
        assert!((e[0].pose().position_m - pose.position_m).norm() < 1e-12);
    }

    /// The entries' spacing the record keeps for a run of `seconds` at 1 kHz, s: the first
    /// stride doubled until the blocks fit the capacity, as [`RunRecord::push`] does.
    fn spacing_after(seconds: f64) -> f64 {
        let g = testkit::geometry();
        let r = RunRecord::new(g, 1e-3, 0);
        let mut stride = u64::from(r.stride());
        let samples = (seconds * 1e3) as u64;
        while samples / stride >= RunRecord::CAPACITY as u64 {
            stride *= 2;
        }
        stride as f64 * 1e-3
    }

    /// The bug: an hour's record of 2¹⁵ entries merges them down to 160 ms, where the budget's
    /// derivative of the rate errs by 42 % at the excitation's highest line (1.875 Hz) and
    /// the rigid-body check flags a rigid payload. An hour keeps 40 ms entries (an error
    /// of 1.6e-3), ten minutes the first 10 ms.
    #[test]
    fn an_hours_record_keeps_entries_close_enough_for_the_budgets_derivative() {
        let error = |h: f64| (2.0 * core::f64::consts::PI * 1.875 * h).powi(4) / 30.0;
        let hour = spacing_after(3600.0);
        assert!(hour <= 0.040 + 1e-12, "{hour} s");
        assert!(error(hour) < 2e-3, "{}", error(hour));
        assert!((spacing_after(600.0) - 0.010).abs() < 1e-12);
    }
}
