//! `/commands` in blocks ([`CommandBlock`]): the commands of one measurement, ten a message,
//! forces in mN and times in ns, delta-coded as `/sensors` is (see [the module](super)).

use control::io::CommandFrame;
use serde::Serialize;

use super::{push_column, raw_pairs, undelta, values, FORCE_PER_N, TAG, TIME_PER_S};
use crate::proto::{Encode, Encoder};

/// One `/commands` frame as logged: the command and the time of the sensor frame it answers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CommandRecord {
    /// Time of the sensor frame this command answers, s.
    pub time_s: f64,
    /// The command.
    pub command: CommandFrame,
}

/// `stewart.CommandBlock` on `/commands`: up to [`BLOCK_FRAMES`] consecutive commands of one
/// measurement, in counts.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct CommandBlock {
    /// Measurement.
    pub run: &'static str,
    /// Time of the sensor frame each command answers, ns, delta-coded.
    pub time_ns: Vec<i64>,
    /// Host command counters, delta-coded.
    pub sequence: Vec<i64>,
    /// Sensor sequence each command was computed from, delta-coded.
    pub sensor_sequence: Vec<i64>,
    /// Axial force commands, mN, 6 a frame, delta-coded.
    pub leg_forces_mn: Vec<i64>,
    /// Actuators enabled (false: brake), one a frame.
    pub enable: Vec<bool>,
    /// Positions (time 0..n, forces n..7n) of the values without a count.
    pub raw_index: Vec<u32>,
    /// Those values, exactly.
    pub raw_value: Vec<f64>,
}

/// The previous command's counts.
#[derive(Clone, Copy, Debug, Default)]
pub struct CommandCounts {
    time: [i64; 1],
    sequence: i64,
    sensor_sequence: i64,
    forces: [i64; 6],
}

impl CommandBlock {
    /// An empty block of measurement `run`.
    pub fn new(run: &'static str) -> Self {
        Self {
            run,
            ..Self::default()
        }
    }

    /// Commands held.
    pub fn len(&self) -> usize {
        self.enable.len()
    }

    /// No command held.
    pub fn is_empty(&self) -> bool {
        self.enable.is_empty()
    }

    /// Appends command `c`, answering the sensor frame of time `time_s`.
    pub fn push(&mut self, time_s: f64, c: &CommandFrame, last: &mut CommandCounts) {
        let n = self.len();
        let delta = |v: i64, prev: &mut i64| {
            let d = if n == 0 { v } else { v.wrapping_sub(*prev) };
            *prev = v;
            d
        };
        self.sequence
            .push(delta(c.sequence as i64, &mut last.sequence));
        self.sensor_sequence
            .push(delta(c.sensor_sequence as i64, &mut last.sensor_sequence));
        let (ri, rv) = (&mut self.raw_index, &mut self.raw_value);
        push_column(
            &mut self.time_ns,
            (ri, rv),
            0,
            n,
            &[time_s],
            TIME_PER_S,
            &mut last.time,
        );
        let forces = &c.leg_forces_n;
        push_column(
            &mut self.leg_forces_mn,
            (ri, rv),
            TAG,
            n,
            forces,
            FORCE_PER_N,
            &mut last.forces,
        );
        self.enable.push(c.enable);
    }

    /// Fixes the raw values' positions for the block's command count (once, before writing).
    pub fn finish(&mut self) {
        let n = self.len();
        for i in &mut self.raw_index {
            let (tag, k) = ((*i >> 24) as usize, (*i & 0xff_ffff) as usize);
            *i = (if tag == 0 { k } else { n + k }) as u32;
        }
    }

    /// Empties the block for measurement `run`, keeping its buffers.
    pub fn clear(&mut self, run: &'static str) {
        self.run = run;
        self.time_ns.clear();
        self.sequence.clear();
        self.sensor_sequence.clear();
        self.leg_forces_mn.clear();
        self.enable.clear();
        self.raw_index.clear();
        self.raw_value.clear();
    }
}

impl Encode for CommandBlock {
    const NAME: &'static str = "stewart.CommandBlock";
    fn encode(&self, e: &mut Encoder<'_>) {
        e.string(1, self.run);
        e.sints(2, &self.time_ns);
        e.sints(3, &self.sequence);
        e.sints(4, &self.sensor_sequence);
        e.sints(5, &self.leg_forces_mn);
        e.bools(6, &self.enable);
        e.uints(7, &self.raw_index);
        e.doubles(8, &self.raw_value);
    }
}

/// The commands of a decoded `stewart.CommandBlock`, or why it does not fit its schema.
pub fn command_frames(p: &crate::proto::CommandBlock) -> Result<Vec<CommandRecord>, String> {
    let n = p.enable.len();
    let seq = undelta("sequence", &p.sequence, 1, n)?;
    let sensor_seq = undelta("sensor_sequence", &p.sensor_sequence, 1, n)?;
    let raw = raw_pairs(&p.raw_index, &p.raw_value, 7 * n)?;
    let time = values(&undelta("time_ns", &p.time_ns, 1, n)?, TIME_PER_S, 0, &raw);
    let force = values(
        &undelta("leg_forces_mn", &p.leg_forces_mn, 6, n)?,
        FORCE_PER_N,
        n,
        &raw,
    );
    Ok((0..n)
        .map(|k| CommandRecord {
            time_s: time[k],
            command: CommandFrame {
                sequence: seq[k] as u64,
                sensor_sequence: sensor_seq[k] as u64,
                leg_forces_n: core::array::from_fn(|j| force[6 * k + j]),
                enable: p.enable[k],
            },
        })
        .collect())
}
