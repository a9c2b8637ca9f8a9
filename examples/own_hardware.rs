//! Your own hardware under the measurement procedure: implement `Backend` for its driver,
//! `Station` for the payload change and `Observer` for your display, then run a whole session
//! (tare, payload on, loaded run, report). A simulator stands in for the hardware here.
//!
//! `cargo run --release --example own_hardware`
use std::sync::atomic::AtomicBool;

use anyhow::Context;
use measure::observer::{Observer, TickEvent};
use measure::session::{self, Job, SessionPlan, Station, TarePlan};
use measure::{setup, MeasureOutcome};
use stewart_types::{Backend, CommandFrame, SensorFrame};

/// Your rig's driver: reads the sensors, writes the leg forces.
struct MyRig {
    hardware: sim::Simulator,
    payload: sim::BodyProperties,
}

impl Backend for MyRig {
    type Error = String;
    fn read(&mut self) -> Result<SensorFrame, String> {
        self.hardware.read().map_err(|e| e.to_string())
    }
    fn write(&mut self, command: &CommandFrame) -> Result<(), String> {
        self.hardware.write(command).map_err(|e| e.to_string())
    }
    fn sample_period_s(&self) -> f64 {
        self.hardware.sample_period_s()
    }
}

impl Station for MyRig {
    fn measure<O: Observer>(&mut self, job: Job<'_>, o: &mut O) -> anyhow::Result<MeasureOutcome> {
        job.run(self, o)
    }
    fn load_payload<O: Observer>(&mut self, _: &mut O, _: &AtomicBool) -> anyhow::Result<bool> {
        println!("tare done: the crane puts the car on");
        self.hardware
            .set_payload(Some(self.payload))
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        Ok(true)
    }
}

/// Your display: one line a second.
struct Display;

impl Observer for Display {
    fn tick(&mut self, e: &TickEvent<'_>) -> anyhow::Result<()> {
        if e.index % 1000 == 0 {
            let mass = e.estimator.map(|est| est.estimate().parameters.mass_kg);
            println!(
                "{:>6} {:>7.1} s  {:<7} on the plate: {mass:.1?} kg",
                e.measurement.name(),
                e.frame.time_s,
                e.phase.name()
            );
        }
        Ok(())
    }
}

fn main() -> anyhow::Result<()> {
    // The rig description: the embedded default with a shorter excitation.
    let rig =
        measure::load::load_str("[run]\nduration_s = 20.0\ntare_duration_s = 20.0\n", "mine")?;
    let geometry = setup::geometry(&rig)?;
    let controller = |s| {
        setup::trajectory(&rig, &geometry, s).and_then(|t| setup::controller(&rig, &geometry, t))
    };
    let fixture = sim::BodyProperties {
        mass_kg: 400.0,
        com_m: [0.0, 0.0, 0.05],
        inertia_com_kg_m2: [[240.0, 0.0, 0.0], [0.0, 240.0, 0.0], [0.0, 0.0, 450.0]],
    };
    let payload = sim::BodyProperties {
        mass_kg: 1500.0,
        com_m: [0.15, -0.08, 0.5],
        inertia_com_kg_m2: [
            [600.0, -25.0, 60.0],
            [-25.0, 2500.0, -15.0],
            [60.0, -15.0, 2700.0],
        ],
    };
    let settings = sim::SimConfig {
        substeps: 1,
        ..sim::SimConfig::default()
    };
    let hardware = sim::Simulator::new(geometry, fixture, None, &settings, 1)?;
    let plan = SessionPlan {
        config: &rig,
        geometry,
        tare: TarePlan::Measure(controller(rig.config.run.tare_duration_s)?),
        loaded: Some(controller(rig.config.run.duration_s)?),
        save_tare: None,
        backend: "mine",
    };
    let outcome = session::run(
        plan,
        &mut MyRig { hardware, payload },
        &mut Display,
        &AtomicBool::new(false),
    )?;
    let report = outcome
        .report(&rig.config, Default::default(), None)
        .context("no report")?;
    let (e, s) = (&report.estimate, &report.sigma);
    println!(
        "payload: {:.2} ± {:.2} kg, centre of mass {:.4?} ± {:.4?} m",
        e.mass, s.mass, e.com, s.com
    );
    println!(
        "inertia about the centre of mass (kg·m²): {:.1?}",
        e.inertia_com
    );
    Ok(())
}
