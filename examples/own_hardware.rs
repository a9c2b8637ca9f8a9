//! Your own hardware under the measurement procedure: implement `Backend` for its driver,
//! `Station` for the payload change and `Observer` for your display, then run a whole sequence
//! (tare, payload on, loaded run, report). A simulator stands in for the hardware here.
//!
//! `cargo run --release --example own_hardware`
use std::sync::atomic::AtomicBool;

use anyhow::Context;
use measure::observer::{Observer, TickEvent};
use measure::sequence::{self, Job, SequencePlan, Station, TarePlan};
use measure::{setup, MeasureOutcome};
use stewart_types::{Backend, CommandFrame, SensorFrame};

/// Your rig's driver: reads the sensors, writes the leg forces.
struct MyRig {
    hardware: sim::Simulator,
    payload: sim::BodyProperties,
}

impl Backend for MyRig {
    type Error = sim::SimError; // your driver's own error type
    fn read(&mut self) -> Result<SensorFrame, Self::Error> {
        self.hardware.read()
    }
    fn write(&mut self, command: &CommandFrame) -> Result<(), Self::Error> {
        self.hardware.write(command)
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
        self.hardware.set_payload(Some(self.payload))?;
        Ok(true)
    }
}

/// Your display: one line a second.
struct Display;

impl Observer for Display {
    fn tick(&mut self, e: &TickEvent<'_>) -> anyhow::Result<()> {
        if e.index.is_multiple_of(1000) {
            let mass = e.estimator.map(|est| est.estimate().parameters.mass_kg);
            let (run, phase, t) = (e.measurement.name(), e.phase.name(), e.frame.time_s);
            println!("{run:>6} {t:>5.1} s {phase:<7} on the plate: {mass:.1?} kg");
        }
        Ok(())
    }
}

fn main() -> anyhow::Result<()> {
    // The rig description: the embedded default with a shorter excitation.
    let rig = rig_description::load::load_str(
        "[run]\nduration_s = 20.0\ntare_duration_s = 20.0\n",
        "mine",
    )?;
    let geometry = setup::geometry(&rig)?;
    let controller = |s, m| {
        setup::trajectory(&rig, &geometry, s).and_then(|t| setup::controller(&rig, &geometry, t, m))
    };
    // The stand-in hardware: the default scenario's simulated world, empty fixture first.
    let world = sim::scenario::Scenario::new(rig.clone(), None, None)?;
    let (hardware, payload) = (
        world.simulator(geometry, false)?,
        world.world.payload.to_sim(),
    );
    let plan = SequencePlan {
        config: &rig,
        geometry,
        tare: TarePlan::Measure(Box::new(controller(
            rig.config.run.tare_duration_s,
            measure::Measurement::Tare,
        )?)),
        loaded: Some(controller(
            rig.config.run.duration_s,
            measure::Measurement::Loaded,
        )?),
        save_tare: None,
        backend: "mine",
    };
    let mut station = MyRig { hardware, payload };
    let outcome = sequence::run(plan, &mut station, &mut Display, &AtomicBool::new(false))?;
    let report = outcome
        .report(&rig.config, Default::default(), None)
        .with_context(|| format!("no report: the sequence ended {:?}", outcome.end))?;
    let (e, s) = (&report.estimate, &report.sigma);
    println!(
        "payload {:.2} ± {:.2} kg, com {:.4?} ± {:.4?} m",
        e.mass, s.mass, e.com, s.com
    );
    println!(
        "J_C {:.1?} kg·m², truth {:.1?}",
        e.inertia_com, payload.inertia_com_kg_m2
    );
    Ok(())
}
