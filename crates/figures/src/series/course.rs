//! The payload's predicted sigma over the excitation, beside the sigma the run achieved: what
//! `stewart plan` predicts for the whole run ([`ops::plan::configured_prediction`]), with the
//! information accumulated only up to each time t ([`planner::Planner::predict_until`]).

use planner::Planner;
use rig_description::LoadedConfig;
use runlog::read::LogContents;

/// Points of the predicted course: the excitation's length split evenly.
pub const COURSE_POINTS: usize = 24;

/// The predicted one sigma of the payload's ten quantities (mass, com x/y/z, J_C xx … yz) at
/// each time from the excitation's start.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PredictedCourse {
    /// Time from the excitation's start, s.
    pub time_s: Vec<f64>,
    /// One sigma of each quantity at each time (NaN where the motion so far does not yet
    /// determine θ).
    pub sigma: [Vec<f64>; 10],
}

/// The predicted course of the rig description's own excitation, `points` times evenly over
/// its loaded run (the last one the whole run); `None` when the rig description cannot be
/// planned for (six parameters, a geometry or excitation that cannot be built).
pub fn predicted_course(loaded: &LoadedConfig, points: usize) -> Option<PredictedCourse> {
    let planner = Planner::new(loaded).ok()?;
    let duration_s = loaded.config.run.duration_s;
    let (trajectory, tare) = ops::plan::configured_trajectories(loaded, &planner, duration_s)?;
    let n = points.max(1);
    let times: Vec<f64> = (1..=n).map(|k| duration_s * k as f64 / n as f64).collect();
    let course = planner.predicted_course(&trajectory, &tare, &times);
    let mut out = PredictedCourse {
        time_s: times,
        ..PredictedCourse::default()
    };
    for (_, prediction) in &course {
        let flat = prediction
            .as_ref()
            .map_or([f64::NAN; 10], |p| p.sigma.flat());
        for (series, v) in out.sigma.iter_mut().zip(flat) {
            series.push(v);
        }
    }
    Some(out)
}

/// The predicted course of the excitation a log recorded: its effective rig description
/// (`/run/metadata` `config_toml`), which holds the excitation it ran. `None` without one, or
/// when it cannot be planned for.
pub fn course_of_log(log: &LogContents) -> Option<PredictedCourse> {
    let metadata = log.metadata.as_ref()?;
    let loaded =
        rig_description::load::load_str(&metadata.config_toml, "the log's rig description").ok()?;
    predicted_course(&loaded, COURSE_POINTS)
}

/// The course as CSV, one row per predicted time: `time_s`, then for each quantity (mass, com
/// x/y/z in m, J_C xx … yz in kg·m²) its predicted sigma and the achieved one, the last
/// `/estimate` sigma at or before that time (empty where there is none).
pub fn course_csv(course: &PredictedCourse, achieved: &[super::ParameterSeries]) -> String {
    let mut out = String::from("time_s");
    for (stem, _, _) in super::NAMES {
        out.push_str(&format!(",{stem}_predicted,{stem}_achieved"));
    }
    out.push('\n');
    for (i, t) in course.time_s.iter().enumerate() {
        out.push_str(&format!("{t}"));
        for k in 0..10 {
            let got = achieved.get(k).and_then(|p| {
                let n = p.time_s.iter().take_while(|s| **s <= *t + 1e-9).count();
                n.checked_sub(1).and_then(|j| p.sigma.get(j).copied())
            });
            out.push_str(&format!(
                ",{},{}",
                course.sigma[k][i],
                got.map_or(String::new(), |v| v.to_string())
            ));
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At the whole run the course is `stewart plan`'s own figure for the configured
    /// excitation (the same code), and it falls with the excitation time.
    #[test]
    fn the_course_ends_at_the_plans_figure_and_falls() {
        let loaded = rig_description::load::load(None)
            .expect("default")
            .with_overrides(&rig_description::load::Overrides {
                duration_s: Some(8.0),
                params: None,
            })
            .expect("8 s");
        let planner = Planner::new(&loaded).expect("planner");
        let plan = ops::plan::configured_prediction(&loaded, &planner, 8.0).expect("predicts");
        let course = predicted_course(&loaded, 4).expect("course");
        assert_eq!(course.time_s, vec![2.0, 4.0, 6.0, 8.0]);
        let last: [f64; 10] = core::array::from_fn(|k| course.sigma[k][3]);
        assert_eq!(last, plan.sigma.flat());
        let csv = course_csv(&course, &[]);
        assert_eq!(csv.lines().count(), 5);
        assert!(csv.starts_with("time_s,mass_predicted,mass_achieved,com_x_predicted"));
        for (k, s) in course.sigma.iter().enumerate() {
            let known: Vec<f64> = s.iter().copied().filter(|v| v.is_finite()).collect();
            assert!(known.len() >= 3, "quantity {k}: {s:?}");
            assert!(known.windows(2).all(|w| w[1] < w[0]), "quantity {k}: {s:?}");
        }
    }
}
