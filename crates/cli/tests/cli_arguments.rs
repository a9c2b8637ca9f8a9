//! The command line's interface: every flag parses, bad values are refused, no argument is
//! needed, and each command's `--help` lists only the options that act on it.

use std::path::PathBuf;

use clap::Parser;
use stewart_cli::{Cli, Command};

#[test]
fn parses_every_simulate_flag() {
    let cli = Cli::try_parse_from([
        "stewart",
        "simulate",
        "--config",
        "c.toml",
        "--duration",
        "12.5",
        "--seed",
        "7",
        "--noise",
        "harsh",
        "--params",
        "6",
        "--tare",
        "t.json",
        "--save-tare",
        "s.json",
        "--log",
        "l.mcap",
        "--report",
        "r.json",
        "--quiet",
    ])
    .unwrap();
    let Command::Simulate(a) = cli.command else {
        panic!("not simulate")
    };
    assert_eq!(a.measure.duration, Some(12.5));
    assert_eq!(a.seed, Some(7));
    assert_eq!(a.noise, Some(sim::NoisePreset::Harsh));
    assert_eq!(a.measure.shared.params.as_deref(), Some("6"));
    assert!(a.measure.shared.quiet);
    assert_eq!(a.measure.shared.log, Some(PathBuf::from("l.mcap")));
}

#[test]
fn refuses_bad_values() {
    assert!(Cli::try_parse_from(["stewart", "simulate", "--params", "7"]).is_err());
    assert!(Cli::try_parse_from(["stewart", "simulate", "--noise", "loud"]).is_err());
    assert!(Cli::try_parse_from(["stewart", "simulate", "--bogus"]).is_err());
}

#[test]
fn no_arguments_is_enough() {
    let cli = Cli::try_parse_from(["stewart", "simulate"]).unwrap();
    let Command::Simulate(a) = cli.command else {
        panic!("not simulate")
    };
    assert!(a.measure.shared.config.is_none() && a.measure.duration.is_none());
}

/// Each command's `--help` lists only the options that act on it.
#[test]
fn each_command_offers_only_its_own_options() {
    use clap::CommandFactory;
    let cli = Cli::command();
    let long = |name: &str| -> Vec<String> {
        let mut c = cli.find_subcommand(name).expect("subcommand").clone();
        c.build();
        c.get_arguments()
            .filter_map(|a| a.get_long().map(str::to_string))
            .collect()
    };
    let rig = long("rig");
    for simulator_only in ["seed", "noise", "runs", "jobs"] {
        assert!(
            !rig.iter().any(|l| l == simulator_only),
            "rig offers --{simulator_only}"
        );
    }
    assert!(rig.iter().any(|l| l == "connect"));
    let simulate = long("simulate");
    for rig_only in ["connect", "key", "no-prompt", "link-silence-ms"] {
        assert!(
            !simulate.iter().any(|l| l == rig_only),
            "simulate offers --{rig_only}"
        );
    }
    assert!(simulate.iter().any(|l| l == "seed"));
    let estimate = long("estimate");
    assert!(estimate.iter().any(|l| l == "rig"));
    assert!(!estimate.iter().any(|l| l == "seed"));
    let mode = |name: &str| -> Vec<String> {
        let rig = cli.find_subcommand("rig").expect("rig");
        let mut c = rig.find_subcommand(name).expect("mode").clone();
        c.build();
        c.get_arguments()
            .filter_map(|a| a.get_long().map(str::to_string))
            .collect()
    };
    let tare = mode("tare");
    for loaded_only in ["tare", "save-tare", "report", "duration", "seed", "noise"] {
        assert!(
            !tare.iter().any(|l| l == loaded_only),
            "rig tare offers --{loaded_only}"
        );
    }
    assert!(tare.iter().any(|l| l == "out"));
    let measure = mode("measure");
    assert!(
        !measure.iter().any(|l| l == "save-tare"),
        "rig measure offers --save-tare"
    );
    assert!(measure.iter().any(|l| l == "tare"));
}

#[test]
fn parses_import_and_estimate_save_tare() {
    let cli = Cli::try_parse_from([
        "stewart", "import", "--rig", "r.toml", "d.csv", "-o", "l.mcap", "--tare", "t.json",
    ])
    .unwrap();
    let Command::Import(a) = cli.command else {
        panic!("not import")
    };
    assert_eq!(a.csv, PathBuf::from("d.csv"));
    assert_eq!(a.rig, PathBuf::from("r.toml"));
    assert_eq!(a.out, Some(PathBuf::from("l.mcap")));
    assert_eq!(a.tare, Some(PathBuf::from("t.json")));
    // The rig description is what the estimator may know: there is no default for another rig.
    assert!(Cli::try_parse_from(["stewart", "import", "d.csv"]).is_err());
    let cli =
        Cli::try_parse_from(["stewart", "estimate", "l.mcap", "--save-tare", "t.json"]).unwrap();
    let Command::Estimate(a) = cli.command else {
        panic!("not estimate")
    };
    assert_eq!(a.save_tare, Some(PathBuf::from("t.json")));
    assert!(Cli::try_parse_from([
        "stewart",
        "estimate",
        "l.mcap",
        "--save-tare",
        "t.json",
        "--tare",
        "u.json"
    ])
    .is_err());
}

#[test]
fn live_takes_an_address_or_the_default_and_not_a_campaign() {
    let parse = |args: &[&str]| {
        let cli = Cli::try_parse_from(args).unwrap();
        let Command::Simulate(a) = cli.command else {
            panic!("not simulate")
        };
        a.measure.shared.live
    };
    assert_eq!(parse(&["stewart", "simulate"]), None);
    assert_eq!(
        parse(&["stewart", "simulate", "--live"]),
        Some("127.0.0.1:8765".parse().unwrap())
    );
    assert_eq!(
        parse(&["stewart", "simulate", "--live", "0.0.0.0:9000", "--quiet"]),
        Some("0.0.0.0:9000".parse().unwrap())
    );
    assert!(Cli::try_parse_from(["stewart", "simulate", "--live", "localhost"]).is_err());
    assert!(Cli::try_parse_from(["stewart", "simulate", "--runs", "3", "--live"]).is_err());
    for rig in [
        &["stewart", "rig", "--live"][..],
        &["stewart", "rig", "tare", "--out", "t.json", "--live"],
        &[
            "stewart",
            "rig",
            "measure",
            "--tare",
            "t.json",
            "--live",
            "[::1]:8765",
        ],
    ] {
        assert!(Cli::try_parse_from(rig).is_ok(), "{rig:?}");
    }
}

/// `--html FILE` is offered where a report of one measurement is written (`simulate`, `rig`,
/// `rig measure`, `estimate`, `report`), not by `rig tare` (no report), and `report` needs it.
#[test]
fn html_is_offered_by_every_command_that_writes_a_report() {
    use clap::CommandFactory;
    for args in [
        &["stewart", "simulate", "--html", "p.html"][..],
        &["stewart", "rig", "--html", "p.html"],
        &[
            "stewart", "rig", "measure", "--tare", "t.json", "--html", "p.html",
        ],
        &["stewart", "estimate", "l.mcap", "--html", "p.html"],
        &["stewart", "report", "r.json", "--html", "p.html"],
    ] {
        assert!(Cli::try_parse_from(args).is_ok(), "{args:?}");
    }
    assert!(Cli::try_parse_from(["stewart", "report", "r.json"]).is_err());
    let cli = Cli::command();
    let mut tare = cli
        .find_subcommand("rig")
        .and_then(|r| r.find_subcommand("tare"))
        .expect("rig tare")
        .clone();
    tare.build();
    assert!(!tare.get_arguments().any(|a| a.get_long() == Some("html")));
}

/// `--cutoff-hz -1` and `nan` were taken as "no filter": refused, saying how to ask for none.
#[test]
fn cutoff_hz_refuses_negative_and_non_finite_values_and_takes_none() {
    for bad in ["-1", "nan", "inf", "x"] {
        let err = Cli::try_parse_from(["stewart", "estimate", "a.mcap", "--cutoff-hz", bad])
            .err()
            .unwrap_or_else(|| panic!("{bad} accepted"))
            .to_string();
        assert!(err.contains("0 or `none`"), "{bad}: {err}");
    }
    for (good, hz) in [("none", 0.0), ("0", 0.0), ("12.5", 12.5)] {
        assert_eq!(ops::estimate::parse_cutoff_hz(good), Ok(hz));
    }
}
