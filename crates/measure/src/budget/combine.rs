//! The payload's share of each source: the same physical error acts in the tare run and in the
//! loaded run, so the payload (loaded − tare) moves by dₖ = δθₖ(loaded) − δθₖ(tare) for each
//! elementary error k, and the source adds Σₖ dₖ dₖᵀ. A source whose errors are each run's own
//! in both runs ([`super::SourceEffects::per_run`]: an offset measured on each run) adds
//! Σ lₖ lₖᵀ + Σ tₖ tₖᵀ instead. The statistical part is the two runs'
//! covariances, split by each run's shares ([`super::statistical`]).

use estimator::{ParameterCovariance, ParameterVector};

use super::RunBudget;
use rig_description::sources::ErrorSource;

/// One source's covariance of the payload's θ.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceCovariance {
    /// The source.
    pub source: ErrorSource,
    /// Its covariance of θ.
    pub covariance: ParameterCovariance,
}

/// Σₖ dₖ dₖᵀ with dₖ = loaded[k] − tare[k] (a missing tare entry counts as zero).
pub fn difference_covariance(loaded: &[[f64; 10]], tare: &[[f64; 10]]) -> ParameterCovariance {
    let mut c = ParameterCovariance::zeros();
    for (k, l) in loaded.iter().enumerate() {
        let t = tare.get(k).copied().unwrap_or([0.0; 10]);
        let d = ParameterVector::from_fn(|i, _| l[i] - t[i]);
        if d.iter().all(|v| v.is_finite()) {
            c += d * d.transpose();
        }
    }
    c
}

/// Every source's covariance of the payload, in [`ErrorSource::ALL`]'s order, from the
/// loaded run's budget and covariance and the tare's (`None`: the tare's effects and shares
/// unknown, counted as zero and said so in the notes). The covariances add up to the
/// payload's whole covariance.
pub fn payload_covariances(
    loaded: &RunBudget,
    loaded_cov: &ParameterCovariance,
    tare: Option<&RunBudget>,
    tare_cov: &ParameterCovariance,
) -> (Vec<SourceCovariance>, Vec<String>) {
    let mut notes = Vec::new();
    let empty = RunBudget::default();
    let t = match tare {
        Some(t) => t,
        None => {
            notes.push(
                "the tare carries no error-budget effects (a tare file of an older version): \
                 its share of each systematic source counts as zero, which overstates those \
                 sources; all of its covariance counts as noise"
                    .to_string(),
            );
            &empty
        }
    };
    let shares = |b: &RunBudget| {
        let loss = b.loss_share().clamp(0.0, 1.0);
        let jitter = b.jitter_share.clamp(0.0, 1.0 - loss);
        (loss, jitter, 1.0 - loss - jitter)
    };
    let (ll, lj, ln) = shares(loaded);
    let (tl, tj, tn) = shares(t);
    let out = ErrorSource::ALL
        .into_iter()
        .map(|source| {
            let covariance = match source {
                ErrorSource::Noise => loaded_cov * ln + tare_cov * tn,
                ErrorSource::FrameLoss => loaded_cov * ll + tare_cov * tl,
                ErrorSource::TimestampJitter => loaded_cov * lj + tare_cov * tj,
                // Each run's own errors: independent, their covariances add.
                s if loaded.per_run(s) && t.per_run(s) => {
                    difference_covariance(loaded.effects_of(s), &[])
                        + difference_covariance(t.effects_of(s), &[])
                }
                s => difference_covariance(loaded.effects_of(s), t.effects_of(s)),
            };
            SourceCovariance { source, covariance }
        })
        .collect();
    (out, notes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::budget::SourceEffects;

    fn budget(mass_shift: f64) -> RunBudget {
        let mut e = [0.0; 10];
        e[0] = mass_shift;
        RunBudget {
            effects: vec![SourceEffects {
                per_run: false,
                source: "accel_bias".into(),
                effects: vec![e, [0.0; 10], [0.0; 10]],
            }],
            used: 900,
            lost: 100,
            jitter_share: 0.05,
            rigid_body: None,
        }
    }

    /// Identical runs cancel; the statistical parts add back to the two covariances; the
    /// payload's share is loaded − tare.
    #[test]
    fn shares_add_up_and_identical_runs_cancel() {
        let cov = ParameterCovariance::identity() * 2.0;
        let (same, notes) = payload_covariances(&budget(0.3), &cov, Some(&budget(0.3)), &cov);
        assert!(notes.is_empty());
        let total: ParameterCovariance = same.iter().map(|s| s.covariance).sum();
        assert!((total - cov * 2.0).norm() < 1e-12);
        let of = |v: &[SourceCovariance], s: ErrorSource| {
            v.iter().find(|c| c.source == s).unwrap().covariance
        };
        assert_eq!(
            of(&same, ErrorSource::AccelBias),
            ParameterCovariance::zeros()
        );
        assert!((of(&same, ErrorSource::FrameLoss)[(0, 0)] - 0.4).abs() < 1e-12);
        assert!((of(&same, ErrorSource::TimestampJitter)[(0, 0)] - 0.2).abs() < 1e-12);
        let (diff, _) = payload_covariances(&budget(0.3), &cov, Some(&budget(0.1)), &cov);
        assert!((of(&diff, ErrorSource::AccelBias)[(0, 0)] - 0.04).abs() < 1e-12);
        let (none, notes) = payload_covariances(&budget(0.3), &cov, None, &cov);
        assert_eq!(notes.len(), 1);
        assert!((of(&none, ErrorSource::AccelBias)[(0, 0)] - 0.09).abs() < 1e-12);
        // Without the tare's shares, its whole covariance is noise.
        assert!((of(&none, ErrorSource::Noise)[(0, 0)] - (2.0 * 0.85 + 2.0)).abs() < 1e-12);
    }
}
