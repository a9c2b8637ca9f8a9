//! `--plot DIR` writes non-empty, valid SVG and PNG figures: from a `simulate` log (what
//! `simulate --plot` and `rig --plot` call) and from `estimate --plot`.

mod log_support;

use std::path::Path;

use stewart_cli::estimate::EstimateArgs;
use stewart_cli::plot::{FIGURE_SIZE, OVERVIEW_SIZE};

const STEMS: [&str; 13] = [
    "parameters",
    "mass",
    "com_x",
    "com_y",
    "com_z",
    "J_xx",
    "J_yy",
    "J_zz",
    "J_xy",
    "J_xz",
    "J_yz",
    "tracking_error",
    "excitation",
];

/// Decodes a PNG: its size, and how many pixels are not white.
fn decode_png(path: &Path) -> ((u32, u32), usize) {
    let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    let channels = info.color_type.samples();
    let inked = buf[..info.buffer_size()]
        .chunks(channels)
        .filter(|px| px.iter().take(3).any(|c| *c < 250))
        .count();
    ((info.width, info.height), inked)
}

fn check_dir(dir: &Path) {
    for stem in STEMS {
        let svg = std::fs::read_to_string(dir.join(format!("{stem}.svg")))
            .unwrap_or_else(|e| panic!("{stem}.svg: {e}"));
        assert!(svg.starts_with("<svg"), "{stem}.svg");
        assert!(svg.trim_end().ends_with("</svg>"), "{stem}.svg");
        assert!(
            svg.contains("xmlns=\"http://www.w3.org/2000/svg\""),
            "{stem}.svg"
        );
        assert!(
            svg.contains("<polyline") || svg.contains("<path"),
            "{stem}.svg draws lines"
        );
        assert!(svg.contains("<text"), "{stem}.svg has labels");
        let ((w, h), inked) = decode_png(&dir.join(format!("{stem}.png")));
        let expect = match stem {
            "parameters" => OVERVIEW_SIZE,
            "excitation" => (FIGURE_SIZE.0, 700),
            _ => FIGURE_SIZE,
        };
        assert_eq!((w, h), expect, "{stem}.png size");
        assert!(
            inked > (w * h / 100) as usize,
            "{stem}.png is blank ({inked} pixels)"
        );
    }
}

#[test]
fn simulate_and_estimate_plots_are_valid_svg_and_png() {
    let run = log_support::simulate();
    let from_log = run.dir.path().join("figures-run");
    let files = stewart_cli::plot::plot_log(&run.log, &from_log).unwrap();
    assert_eq!(files.len(), 2 * STEMS.len());
    check_dir(&from_log);
    // The truth line is drawn when the log knows the truth.
    let mass = std::fs::read_to_string(from_log.join("mass.svg")).unwrap();
    assert!(mass.contains("truth"));

    let from_estimate = run.dir.path().join("figures-estimate");
    let outcome = stewart_cli::estimate::estimate(&EstimateArgs {
        log: run.log.clone(),
        plot: Some(from_estimate.clone()),
        quiet: true,
        ..EstimateArgs::default()
    })
    .unwrap();
    assert_eq!(outcome.figures.len(), 2 * STEMS.len());
    check_dir(&from_estimate);
}
