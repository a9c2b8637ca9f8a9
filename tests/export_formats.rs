//! `stewart export` on the report that `stewart simulate --report` wrote: every format is
//! written, and read back by a parser of its format, gives the report's mass, centre of mass
//! and J_C (the round trips of each format in detail are `inertial-export`'s tests).

use crate::support;

use inertial_export::Format;
use ops::export::{run, ExportOptions};

/// |a − b| ≤ 1e-9·max(|b|, scale).
fn assert_close(what: &str, got: &[f64], want: &[f64], scale: f64) {
    for (g, w) in got.iter().zip(want) {
        assert!(
            (g - w).abs() <= 1e-9 * scale.max(w.abs()),
            "{what}: {got:?} vs {want:?}"
        );
    }
}

fn numbers(text: &str) -> Vec<f64> {
    text.split_whitespace()
        .map(|t| t.parse().expect("a number"))
        .collect()
}

#[test]
fn a_simulated_report_exports_to_every_format() {
    let scratch = support::Scratch::new(support::SHORT);
    let report_path = scratch.path("report.json");
    let args = support::simulate_args(Some(scratch.config.clone()), scratch.path("run.mcap"));
    let outcome = support::run_simulate(&args).expect("the run");
    std::fs::write(&report_path, outcome.report_json().expect("a report")).unwrap();
    let report: measure::Report =
        serde_json::from_str(&std::fs::read_to_string(&report_path).expect("the report"))
            .expect("a report");
    let e = report.estimate;
    let j = e.inertia_com;
    let six = [j[0][0], j[1][1], j[2][2], j[0][1], j[0][2], j[1][2]];
    let scale = j[2][2];

    for format in Format::ALL {
        let output = scratch.path(&format!("payload.{}", format.name()));
        run(&ExportOptions {
            report: report_path.clone(),
            format,
            output: Some(output.clone()),
            principal_axes: false,
        })
        .unwrap_or_else(|err| panic!("{format:?}: {err}"));
        let text = std::fs::read_to_string(&output).expect("the export");
        let (mass, com, inertia): (f64, Vec<f64>, Vec<f64>) = match format {
            Format::Urdf => {
                let robot = urdf_rs::read_from_string(&text).expect("urdf-rs reads it");
                let i = &robot.links[0].inertial;
                let t = &i.inertia;
                (
                    i.mass.value,
                    i.origin.xyz.to_vec(),
                    vec![t.ixx, t.iyy, t.izz, t.ixy, t.ixz, t.iyz],
                )
            }
            Format::Sdf => {
                let doc = roxmltree::Document::parse(&text).expect("XML");
                let value = |tag: &str| -> Vec<f64> {
                    numbers(
                        doc.descendants()
                            .find(|n| n.has_tag_name(tag))
                            .and_then(|n| n.text())
                            .unwrap_or_else(|| panic!("<{tag}>")),
                    )
                };
                let inertia = ["ixx", "iyy", "izz", "ixy", "ixz", "iyz"].map(|t| value(t)[0]);
                (
                    value("mass")[0],
                    value("pose")[..3].to_vec(),
                    inertia.to_vec(),
                )
            }
            Format::Mjcf => {
                let doc = roxmltree::Document::parse(&text).expect("XML");
                let i = doc
                    .descendants()
                    .find(|n| n.has_tag_name("inertial"))
                    .expect("<inertial>");
                let attr = |name: &str| numbers(i.attribute(name).expect(name));
                (attr("mass")[0], attr("pos"), attr("fullinertia"))
            }
            Format::Csv => {
                let mut reader = csv::Reader::from_reader(text.as_bytes());
                let header = reader.headers().expect("a header").clone();
                let row = reader.records().next().expect("a row").expect("a record");
                let get = |name: &str| -> f64 {
                    let k = header.iter().position(|h| h == name).expect(name);
                    row[k].parse().expect("a number")
                };
                let inertia = ["ixx", "iyy", "izz", "ixy", "ixz", "iyz"]
                    .map(|c| get(&format!("{c}_kg_m2")))
                    .to_vec();
                let com = ["x", "y", "z"].map(|a| get(&format!("com_{a}_m"))).to_vec();
                (get("mass_kg"), com, inertia)
            }
        };
        let what = format.name();
        assert_close(what, &[mass], &[e.mass], 0.0);
        assert_close(what, &com, &e.com, 0.0);
        assert_close(what, &inertia, &six, scale);
        assert_eq!(inertia.len(), 6, "{what}");
    }
}
