//! The linear least-squares problems of the calibrations: equations smoothed alike on both
//! sides, solved with a sandwich covariance over blocks of the record.

use nalgebra::{DMatrix, DVector, SVector};

/// Entries per block of the sandwich covariance: 0.4 s at the record's 100 Hz, long against
/// the derivatives' stencils and the smoothing's reach, short against a 20 s run.
pub const BLOCK_ENTRIES: usize = 40;

/// Passes of the moving average [`smooth`] applies.
const SMOOTHING_PASSES: usize = 3;

/// Width of each pass, entries: three passes of five are close to a Gaussian of 2.4 entries
/// (24 ms at 100 Hz), which keeps the excitation (gain 0.96 at 1.9 Hz, alike on both sides of
/// every equation) and removes the second derivative's noise near the record's Nyquist rate.
const SMOOTHING_WIDTH: usize = 5;

/// One linear least-squares problem, one equation φᵀ x = y per record entry and component.
/// Entries whose indices are not consecutive are a break in the record (no smoothing across
/// it), and blocks of the covariance are [`BLOCK_ENTRIES`] consecutive indices.
///
/// Every equation is linear in the signals, so a moving average applied alike to y and to
/// every column of φ keeps it exact; it takes out of the regressors the noise of the
/// kinematics' second derivative (blue, most of it far above the excitation), which would
/// otherwise bias the fit towards zero (errors in variables).
pub(crate) struct Normal<const P: usize> {
    /// (record entry, component, φ, y).
    rows: Vec<(usize, usize, SVector<f64, P>, f64)>,
}

/// The moving average of `SMOOTHING_PASSES` passes over consecutive entries of one
/// component; entries within the averages' reach of a break in the record are dropped.
fn smooth<const P: usize>(
    rows: &[(usize, SVector<f64, P>, f64)],
) -> Vec<(usize, SVector<f64, P>, f64)> {
    let mut out = Vec::new();
    let mut start = 0;
    while start < rows.len() {
        let mut end = start + 1;
        while end < rows.len() && rows[end].0 == rows[end - 1].0 + 1 {
            end += 1;
        }
        let mut run: Vec<(usize, SVector<f64, P>, f64)> = rows[start..end].to_vec();
        for _ in 0..SMOOTHING_PASSES {
            if run.len() < SMOOTHING_WIDTH {
                run.clear();
                break;
            }
            run = run
                .windows(SMOOTHING_WIDTH)
                .map(|w| {
                    let n = w.len() as f64;
                    let phi = w.iter().map(|r| r.1).sum::<SVector<f64, P>>() / n;
                    let y = w.iter().map(|r| r.2).sum::<f64>() / n;
                    (w[w.len() / 2].0, phi, y)
                })
                .collect();
        }
        out.extend(run);
        start = end;
    }
    out
}

impl<const P: usize> Normal<P> {
    pub(crate) fn new() -> Self {
        Self { rows: Vec::new() }
    }

    /// One equation φᵀ x = y of record entry `entry`, component `component`.
    pub(crate) fn push(&mut self, entry: usize, component: usize, phi: SVector<f64, P>, y: f64) {
        self.rows.push((entry, component, phi, y));
    }

    /// The solution, the sandwich covariance and the residual rms of the smoothed equations;
    /// `None` when singular.
    pub(crate) fn solve(&self) -> Option<(DVector<f64>, DMatrix<f64>, f64)> {
        let mut rows: Vec<(usize, SVector<f64, P>, f64)> = Vec::new();
        let components = self.rows.iter().map(|r| r.1 + 1).max().unwrap_or(0);
        for component in 0..components {
            let one: Vec<(usize, SVector<f64, P>, f64)> = self
                .rows
                .iter()
                .filter(|r| r.1 == component)
                .map(|r| (r.0, r.2, r.3))
                .collect();
            rows.extend(smooth(&one));
        }
        rows.sort_by_key(|r| r.0);
        let mut info = DMatrix::<f64>::zeros(P, P);
        let mut rhs = DVector::<f64>::zeros(P);
        for (_, phi, y) in &rows {
            info += phi * phi.transpose();
            rhs += phi * *y;
        }
        let scale = DVector::from_iterator(
            P,
            (0..P).map(|i| {
                let d = info[(i, i)];
                if d > 0.0 {
                    1.0 / d.sqrt()
                } else {
                    0.0
                }
            }),
        );
        let s = DMatrix::from_diagonal(&scale);
        let scaled = &s * &info * &s;
        let eig = scaled.clone().symmetric_eigen();
        let (lo, hi) = eig
            .eigenvalues
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(l, h), &v| (l.min(v), h.max(v)));
        // NaN in the information fails this too.
        if lo.partial_cmp(&(1e-10 * hi)) != Some(core::cmp::Ordering::Greater) {
            return None;
        }
        let inv = &s * scaled.try_inverse()? * &s;
        let x = &inv * &rhs;
        let xs = SVector::<f64, P>::from_iterator(x.iter().copied());
        let mut scores = DMatrix::zeros(P, P);
        let mut block = DVector::zeros(P);
        let mut current = None;
        let mut blocks = 0usize;
        let mut sum_sq = 0.0;
        for (entry, phi, y) in &rows {
            let r = y - phi.dot(&xs);
            sum_sq += r * r;
            let b = entry / BLOCK_ENTRIES;
            if current != Some(b) {
                scores += &block * block.transpose();
                block.fill(0.0);
                current = Some(b);
                blocks += 1;
            }
            for (k, p) in phi.iter().enumerate() {
                block[k] += p * r;
            }
        }
        scores += &block * block.transpose();
        // Blocks' scores scatter about the fitted θ, not the true one: n/(n − p) undoes it.
        let dof = blocks.saturating_sub(P).max(1) as f64;
        let cov = &inv * scores * &inv * (blocks as f64 / dof);
        let rms = (sum_sq / rows.len().max(1) as f64).sqrt();
        Some((x, cov, rms))
    }
}
