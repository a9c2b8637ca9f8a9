//! `--plot DIR` writes non-empty, valid SVG and PNG figures: from a `simulate` log (what
//! `simulate --plot` and `rig --plot` call) and from `estimate --plot`.

use crate::support;

use std::path::Path;

use figures::{COURSE_SIZE, FIGURE_SIZE, OVERVIEW_SIZE};

const STEMS: [&str; 14] = [
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
    "sigma_course",
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
            "sigma_course" => COURSE_SIZE,
            _ => FIGURE_SIZE,
        };
        assert_eq!((w, h), expect, "{stem}.png size");
        assert!(
            inked > (w * h / 100) as usize,
            "{stem}.png is blank ({inked} pixels)"
        );
    }
}

fn stewart(args: &[&std::ffi::OsStr]) -> String {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_stewart"))
        .args(args)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "stewart {args:?}: {}\n{stdout}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// Through the binary: `simulate --plot DIR`, then `estimate LOG --plot DIR`.
#[test]
fn simulate_and_estimate_plot_valid_svg_and_png() {
    let dir = support::scratch_dir();
    let d = dir.path();
    let config = d.join("short.toml");
    std::fs::write(&config, support::SHORT).unwrap();
    let log = d.join("run.mcap");
    let run_figures = d.join("figures-run");
    let stdout = stewart(&[
        "simulate".as_ref(),
        "--quiet".as_ref(),
        "--config".as_ref(),
        config.as_os_str(),
        "--log".as_ref(),
        log.as_os_str(),
        "--plot".as_ref(),
        run_figures.as_os_str(),
    ]);
    assert!(stdout.contains("figures:"), "{stdout}");
    check_dir(&run_figures);
    // The truth line is drawn when the log knows the truth.
    let mass = std::fs::read_to_string(run_figures.join("mass.svg")).unwrap();
    assert!(mass.contains("truth"));

    let estimate_figures = d.join("figures-estimate");
    let stdout = stewart(&[
        "estimate".as_ref(),
        log.as_os_str(),
        "--plot".as_ref(),
        estimate_figures.as_os_str(),
    ]);
    // The table, then where the figures went.
    assert!(
        stdout.contains("J_C xy") && stdout.contains("figures:"),
        "{stdout}"
    );
    check_dir(&estimate_figures);

    // The library call the rig command uses writes the same set, and the course's numbers.
    let again = d.join("figures-again");
    let files = figures::plot_log(&log, &again).unwrap();
    assert_eq!(files.len(), 2 * STEMS.len() + 1);
    let csv = std::fs::read_to_string(again.join("sigma_course.csv")).unwrap();
    assert!(
        csv.starts_with("time_s,mass_predicted,mass_achieved"),
        "{csv}"
    );
}
