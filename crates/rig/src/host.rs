//! The host's side of the link: [`RigBackend`], a `control::io::Backend` that talks to a rig.
//!
//! The rig's sensor frames pace the loop: [`Backend::read`] blocks until the next valid frame
//! from the rig, or fails after the link silence limit. Anything else that arrives (late,
//! duplicate, reordered, corrupt, unauthenticated or foreign frames) is counted in
//! [`LinkStats`] and never reaches the cores. Commands are clamped to the rig's force limits,
//! whatever the caller asks.

use std::time::{Duration, Instant};

use control::io::{Backend, CommandFrame, SensorFrame, Status, LEG_COUNT};

use crate::codec::{self, Auth, CodecError, MAX_FRAME_LEN};
use crate::error::RigError;
use crate::key::Key;
use crate::stats::LinkStats;
use crate::transport::{self, Address, Peer, Recv, Transport};
use crate::wire::{
    identity_str, Command, Fault, FaultCode, Hello, HelloAck, Limits, Message, Sensor,
    SensorLayout, NO_LEG, PROTOCOL_VERSION,
};

/// Most frames looked at in one read while skipping to the newest. A caller that paused for a
/// while (say 100 ms, 100 frames at 1 kHz) must get the newest frame in one read: a second
/// read would jump as far again, and a supervisor would see that jump as a gap between
/// samples. The bound (and [`DRAIN_PERIODS`] sample periods of draining at most) caps the work
/// a flood of datagrams can cause per tick.
const MAX_DRAIN: usize = 4096;

/// Longest time one read spends skipping to the newest frame, in sample periods.
const DRAIN_PERIODS: f64 = 10.0;

/// How the host talks to the rig. `Default` gives the documented defaults.
#[derive(Clone, Debug)]
pub struct RigOptions {
    /// Longest time without a valid sensor frame before [`Backend::read`] fails (50 ms).
    pub link_silence: Duration,
    /// How long to wait for the rig's answer to `Hello` (2 s); a rig busy with another
    /// session is asked again until then.
    pub handshake_timeout: Duration,
    /// `Hello` is repeated at this interval until answered (100 ms).
    pub hello_interval: Duration,
    /// Shared key: tag every frame and accept only tagged frames (`None`: no key).
    pub key: Option<Key>,
    /// Refuse a rig without an IMU (true: the estimator needs gyro and accelerometer).
    pub require_imu: bool,
    /// Where the host's configuration puts the accelerometer (P frame, m); `None` accepts the
    /// rig's.
    pub accel_position_m: Option<[f64; 3]>,
    /// Largest accepted difference between the configured and the rig's accelerometer
    /// position, metres (1 mm).
    pub accel_position_tolerance_m: f64,
    /// The sample period the host's configuration expects, seconds; `None` accepts the rig's.
    pub sample_period_s: Option<f64>,
    /// The host's own force cap, newtons (magnitude); commands are clamped to the tighter of
    /// this and the rig's limits.
    pub force_limit_n: Option<f64>,
    /// A measured leg length further than this outside the rig's stroke fails the read, metres
    /// (5 mm: sensor noise at the end stops must not trip it).
    pub stroke_tolerance_m: f64,
    /// Skip to the newest frame when several are waiting (true): the cores never act on a
    /// sample older than one period. The skipped frames count as `late`.
    pub skip_stale: bool,
}

impl Default for RigOptions {
    fn default() -> Self {
        Self {
            link_silence: Duration::from_millis(50),
            handshake_timeout: Duration::from_secs(2),
            hello_interval: Duration::from_millis(100),
            key: None,
            require_imu: true,
            accel_position_m: None,
            accel_position_tolerance_m: 1e-3,
            sample_period_s: None,
            force_limit_n: None,
            stroke_tolerance_m: 5e-3,
            skip_stale: true,
        }
    }
}

/// What the rig said about itself in the handshake.
#[derive(Clone, Debug, PartialEq)]
pub struct RigInfo {
    /// The rig's address as given to [`RigBackend::connect`].
    pub address: String,
    /// The rig's identity string.
    pub identity: String,
    /// The session number the rig chose.
    pub session_id: u64,
    /// The rig's sensors.
    pub layout: SensorLayout,
    /// Time between sensor frames, seconds.
    pub sample_period_s: f64,
    /// The rig's command watchdog.
    pub watchdog: Duration,
    /// The rig's hard limits.
    pub limits: Limits,
}

/// A rig behind a link, as a `control::io::Backend`.
pub struct RigBackend {
    transport: Box<dyn Transport>,
    peer: Peer,
    options: RigOptions,
    info: RigInfo,
    stats: LinkStats,
    force_min_n: f64,
    force_max_n: f64,
    /// Highest sensor sequence seen from the rig in this session (0: none yet).
    last_sequence: u64,
    last_valid_at: Instant,
    next_command_sequence: u64,
    /// The closing safe stop was sent ([`RigBackend::close`]): dropping sends no other.
    closed: bool,
    /// One byte more than a frame may have, so that an oversized datagram shows as such.
    buf: [u8; MAX_FRAME_LEN + 1],
}

/// What one received frame turned out to be.
enum Class {
    Sensor(Sensor),
    Fault(Fault),
    Rejected,
}

impl RigBackend {
    /// Connects to the rig at `address` (`udp://HOST:PORT` or `serial:///dev/X?baud=N`) and
    /// completes the handshake.
    ///
    /// Fails with a message naming the cause when the address is malformed, the rig does not
    /// answer, speaks another protocol version, refuses the key, or reports a sensor layout or
    /// limits that do not fit `options`. No command is sent before the handshake succeeds.
    pub fn connect(address: &str, options: RigOptions) -> Result<Self, RigError> {
        let parsed: Address = address.parse()?;
        let (transport, peer) = transport::open_client(&parsed)?;
        Self::connect_over(transport, peer, address.to_string(), options)
    }

    /// Like [`connect`](Self::connect) over an already opened transport.
    pub fn connect_over(
        mut transport: Box<dyn Transport>,
        peer: Peer,
        address: String,
        options: RigOptions,
    ) -> Result<Self, RigError> {
        let mut stats = LinkStats::default();
        let mut buf = [0u8; MAX_FRAME_LEN + 1];
        let ack = exchange_hello(
            transport.as_mut(),
            &peer,
            &address,
            &options,
            &mut stats,
            &mut buf,
        )?;
        let info = validate_ack(&ack, &address, &options)?;
        let (force_min_n, force_max_n) = force_range(&info, &options);
        Ok(Self {
            transport,
            peer,
            options,
            info,
            stats,
            force_min_n,
            force_max_n,
            last_sequence: 0,
            last_valid_at: Instant::now(),
            next_command_sequence: 1,
            closed: false,
            buf,
        })
    }

    /// Ends the current session and opens a new one with the same rig over the same link
    /// (safe stop, then a fresh handshake). The rig starts the new session braked, with its
    /// sequences from 1 and any latched fault cleared; a rig that changes something between
    /// sessions (an emulator loading the payload) does it in between. The counters continue.
    ///
    /// On failure the backend is left without a usable session: drop it.
    pub fn restart_session(&mut self) -> Result<(), RigError> {
        let _ = self.safe_stop();
        let ack = exchange_hello(
            self.transport.as_mut(),
            &self.peer,
            &self.info.address,
            &self.options,
            &mut self.stats,
            &mut self.buf,
        )?;
        let info = validate_ack(&ack, &self.info.address, &self.options)?;
        let (force_min_n, force_max_n) = force_range(&info, &self.options);
        self.info = info;
        self.force_min_n = force_min_n;
        self.force_max_n = force_max_n;
        self.last_sequence = 0;
        self.last_valid_at = Instant::now();
        self.next_command_sequence = 1;
        Ok(())
    }

    /// What the rig said in the handshake.
    pub fn info(&self) -> &RigInfo {
        &self.info
    }

    /// The host's local socket address (UDP), e.g. to aim test traffic at it.
    pub fn local_addr(&self) -> Option<std::net::SocketAddr> {
        self.transport.local_addr()
    }

    /// Sequence of the last sensor frame seen from the rig (0: none yet).
    pub fn last_sequence(&self) -> u64 {
        self.last_sequence
    }

    /// The link counters so far.
    pub fn stats(&self) -> &LinkStats {
        &self.stats
    }

    /// The force range every command is clamped to, newtons: the rig's limits, tightened by
    /// [`RigOptions::force_limit_n`].
    pub fn force_limits_n(&self) -> (f64, f64) {
        (self.force_min_n, self.force_max_n)
    }

    /// Sends the safe-stop command (brake, zero force) and returns it, for the record. The rig
    /// also brakes by itself, with a WATCHDOG fault, when driving commands stop for longer
    /// than its watchdog.
    pub fn safe_stop(&mut self) -> Result<Command, RigError> {
        let command = Command {
            sequence: self.next_command_sequence,
            sensor_sequence: self.last_sequence,
            leg_forces_n: [0.0; LEG_COUNT],
            enable: false,
        };
        self.send_command(&command)?;
        Ok(command)
    }

    fn auth(&self) -> Option<Auth<'_>> {
        self.options.key.as_ref().map(|key| Auth {
            key: key.bytes(),
            session_id: self.info.session_id,
        })
    }

    fn send_command(&mut self, command: &Command) -> Result<(), RigError> {
        let mut out = [0u8; MAX_FRAME_LEN];
        let n = codec::encode(&Message::Command(*command), self.auth().as_ref(), &mut out)
            .map_err(RigError::Encode)?;
        self.transport.send(&out[..n], &self.peer)?;
        self.next_command_sequence = command.sequence + 1;
        self.stats.commands_sent += 1;
        Ok(())
    }

    /// Sorts out one received frame; counts everything that is not for the cores.
    fn classify(&mut self, len: usize, from: Peer) -> Class {
        self.stats.received += 1;
        if from != self.peer {
            self.stats.foreign_sender += 1;
            return Class::Rejected;
        }
        let Some(frame) = self.buf.get(..len) else {
            self.stats.corrupt += 1;
            return Class::Rejected;
        };
        let auth = self.options.key.as_ref().map(|key| Auth {
            key: key.bytes(),
            session_id: self.info.session_id,
        });
        match codec::decode(frame, auth.as_ref()) {
            Err(e) => {
                // A HelloAck is tagged for session 0 (protocol section 3): a repeat of this
                // session's is a duplicate, not an authentication failure.
                let handshake = self.options.key.as_ref().map(|key| Auth {
                    key: key.bytes(),
                    session_id: 0,
                });
                match codec::decode(frame, handshake.as_ref()) {
                    Ok(Message::HelloAck(ack))
                        if handshake.is_some() && ack.session_id == self.info.session_id =>
                    {
                        self.stats.duplicate += 1
                    }
                    _ => self.stats.count_codec_error(&e),
                }
                Class::Rejected
            }
            Ok(Message::Sensor(sensor)) => {
                if sensor.sequence == self.last_sequence {
                    self.stats.duplicate += 1;
                    Class::Rejected
                } else if sensor.sequence < self.last_sequence {
                    self.stats.out_of_sequence += 1;
                    Class::Rejected
                } else {
                    self.stats.lost += sensor.sequence - self.last_sequence - 1;
                    self.last_sequence = sensor.sequence;
                    Class::Sensor(sensor)
                }
            }
            Ok(Message::Fault(fault)) => Class::Fault(fault),
            // The rig answers every repeat of the session's Hello with the same HelloAck; one
            // that arrives after the handshake (the host had asked again while the first answer
            // was on its way) is a duplicate, not a stray.
            Ok(Message::HelloAck(ack)) if ack.session_id == self.info.session_id => {
                self.stats.duplicate += 1;
                Class::Rejected
            }
            Ok(_) => {
                self.stats.unexpected += 1;
                Class::Rejected
            }
        }
    }

    /// Looks at the frames already waiting, without waiting for more: the first valid sensor
    /// frame, a fault report (as the error), or `None` when nothing valid is waiting.
    fn poll_waiting(&mut self) -> Result<Option<Sensor>, RigError> {
        for _ in 0..MAX_DRAIN {
            match self.transport.recv(&mut self.buf, Duration::ZERO)? {
                Recv::Timeout => return Ok(None),
                Recv::Garbled => {
                    self.stats.received += 1;
                    self.stats.corrupt += 1;
                }
                Recv::Frame { len, from } => match self.classify(len, from) {
                    Class::Sensor(sensor) => return Ok(Some(sensor)),
                    Class::Fault(fault) => return Err(rig_fault(&fault)),
                    Class::Rejected => {}
                },
            }
        }
        Ok(None)
    }

    /// Best effort: the link may be the thing that failed.
    fn fail(&mut self, error: RigError) -> RigError {
        let _ = self.safe_stop();
        error
    }

    fn check_sensor(&self, s: &Sensor) -> Result<(), RigError> {
        let invalid = |reason: String| RigError::SensorInvalid {
            sequence: s.sequence,
            reason,
        };
        let channels: [(&str, &[f64]); 4] = [
            ("leg length", &s.leg_lengths_m),
            ("leg force", &s.leg_forces_n),
            ("gyro", &s.gyro_rad_s),
            ("accelerometer", &s.accel_m_s2),
        ];
        for (name, values) in channels {
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                return Err(invalid(format!("{name} [{i}] is {}", values[i])));
            }
        }
        // Backstop for a lost fault report: the status bits say it too.
        let status = Status(s.status);
        if status.has(Status::ESTOP) || status.has(Status::FAULT) {
            let code = if status.has(Status::ESTOP) {
                FaultCode::ESTOP
            } else {
                FaultCode(0)
            };
            return Err(RigError::RigFault {
                code,
                leg: NO_LEG,
                value: 0.0,
                command_sequence: 0,
            });
        }
        let limits = &self.info.limits;
        let tol = self.options.stroke_tolerance_m;
        for (leg, &length) in s.leg_lengths_m.iter().enumerate() {
            if length < limits.stroke_min_m - tol || length > limits.stroke_max_m + tol {
                return Err(invalid(format!(
                    "leg {leg} length {length:.4} m is outside the stroke [{}, {}] m",
                    limits.stroke_min_m, limits.stroke_max_m
                )));
            }
        }
        Ok(())
    }
}

impl Backend for RigBackend {
    type Error = RigError;

    fn read(&mut self) -> Result<SensorFrame, RigError> {
        let deadline = self.last_valid_at + self.options.link_silence;
        // Look before timing out: after a long pause of the caller, frames may be waiting.
        let mut newest = loop {
            let wait = deadline.saturating_duration_since(Instant::now());
            let received = self.transport.recv(&mut self.buf, wait);
            match received {
                Err(e) => return Err(self.fail(e)),
                Ok(Recv::Frame { len, from }) => match self.classify(len, from) {
                    Class::Sensor(sensor) => break sensor,
                    Class::Fault(fault) => return Err(self.fail(rig_fault(&fault))),
                    Class::Rejected => {}
                },
                Ok(Recv::Timeout) => {}
                Ok(Recv::Garbled) => {
                    self.stats.received += 1;
                    self.stats.corrupt += 1;
                }
            }
            let now = Instant::now();
            if now >= deadline {
                // A host that was descheduled past the deadline has not looked at what arrived
                // meanwhile: the rig's frames, and its fault report, may be waiting. Silence is
                // declared only on an empty socket, so that the fault reported is the first
                // that happened (a waiting WATCHDOG, not "link silent").
                match self.poll_waiting() {
                    Err(e) => return Err(self.fail(e)),
                    Ok(Some(sensor)) => break sensor,
                    Ok(None) => {}
                }
                let error = RigError::LinkSilent {
                    silent_for: now - self.last_valid_at,
                    limit: self.options.link_silence,
                    last_sequence: self.last_sequence,
                };
                return Err(self.fail(error));
            }
        };
        self.last_valid_at = Instant::now();
        if self.options.skip_stale {
            let drain_until = self.last_valid_at
                + Duration::from_secs_f64(DRAIN_PERIODS * self.info.sample_period_s);
            for _ in 0..MAX_DRAIN {
                if Instant::now() >= drain_until {
                    break;
                }
                let received = self.transport.recv(&mut self.buf, Duration::ZERO);
                match received {
                    Err(e) => return Err(self.fail(e)),
                    Ok(Recv::Timeout) => break,
                    Ok(Recv::Garbled) => {
                        self.stats.received += 1;
                        self.stats.corrupt += 1;
                    }
                    Ok(Recv::Frame { len, from }) => match self.classify(len, from) {
                        Class::Sensor(sensor) => {
                            self.stats.late += 1;
                            newest = sensor;
                        }
                        Class::Fault(fault) => return Err(self.fail(rig_fault(&fault))),
                        Class::Rejected => {}
                    },
                }
            }
        }
        if let Err(e) = self.check_sensor(&newest) {
            return Err(self.fail(e));
        }
        self.stats.accepted += 1;
        Ok(SensorFrame::from(&newest))
    }

    fn write(&mut self, command: &CommandFrame) -> Result<(), RigError> {
        if let Some(leg) = command.leg_forces_n.iter().position(|f| !f.is_finite()) {
            let reason = format!(
                "leg {leg} force is {}",
                command.leg_forces_n.get(leg).copied().unwrap_or(f64::NAN)
            );
            return Err(self.fail(RigError::CommandInvalid { reason }));
        }
        let mut forces = command.leg_forces_n;
        let mut clamped = false;
        for f in &mut forces {
            let c = f.clamp(self.force_min_n, self.force_max_n);
            clamped |= c != *f;
            *f = c;
        }
        if clamped {
            self.stats.commands_clamped += 1;
        }
        let wire = Command {
            sequence: self.next_command_sequence,
            sensor_sequence: command.sensor_sequence,
            leg_forces_n: forces,
            enable: command.enable,
        };
        self.send_command(&wire)
    }

    fn sample_period_s(&self) -> f64 {
        self.info.sample_period_s
    }
}

impl RigBackend {
    /// Ends the link: sends the closing safe stop (counted in [`stats`](Self::stats), unlike
    /// the one a drop sends) and returns the counters of the whole link.
    pub fn close(&mut self) -> LinkStats {
        if !self.closed {
            let _ = self.safe_stop();
            self.closed = true;
        }
        self.stats
    }
}

impl Drop for RigBackend {
    /// Leaves the rig braked whatever happened to the caller.
    fn drop(&mut self) {
        if !self.closed {
            let _ = self.safe_stop();
        }
    }
}

/// The rig's force limits, tightened by the host's own cap.
fn force_range(info: &RigInfo, options: &RigOptions) -> (f64, f64) {
    let (mut min_n, mut max_n) = (info.limits.force_min_n, info.limits.force_max_n);
    if let Some(cap) = options.force_limit_n {
        min_n = min_n.max(-cap.abs());
        max_n = max_n.min(cap.abs());
    }
    (min_n, max_n)
}

fn rig_fault(fault: &Fault) -> RigError {
    RigError::RigFault {
        code: fault.code,
        leg: fault.leg,
        value: fault.value,
        command_sequence: fault.command_sequence,
    }
}

fn refused(fault: &Fault) -> RigError {
    let detail = match fault.code {
        FaultCode::VERSION_MISMATCH => {
            return RigError::VersionMismatch {
                rig: fault.value as u8,
                host: PROTOCOL_VERSION,
            }
        }
        FaultCode::KEY_REQUIRED => {
            ": the rig requires a shared key and this host has none; pair them: copy the rig's \
             key file to this host (~/.config/stewart/rig.key, or --key FILE) and drop \
             --insecure"
        }
        FaultCode::KEY_MISMATCH => {
            ": the rig's key differs from this host's (or the rig runs without a key); pair \
             them: copy the rig's key file to this host (~/.config/stewart/rig.key, or --key \
             FILE), or run `stewart key new` on one side and copy its file to the other"
        }
        FaultCode::BUSY => ": another host holds the rig's session",
        _ => "",
    };
    RigError::Refused {
        code: fault.code,
        detail: detail.to_string(),
    }
}

/// Fault codes 5–8 answer a `Hello` (protocol section 5); any other fault seen during a
/// handshake is left over from an earlier session (say the watchdog tripping after the host
/// stopped commanding mid-motion) and says nothing about this one.
fn answers_hello(code: FaultCode) -> bool {
    matches!(
        code,
        FaultCode::VERSION_MISMATCH
            | FaultCode::KEY_REQUIRED
            | FaultCode::KEY_MISMATCH
            | FaultCode::BUSY
    )
}

/// Sends `Hello` until the rig answers with a `HelloAck` for it, a refusal, or time runs out.
fn exchange_hello(
    transport: &mut dyn Transport,
    peer: &Peer,
    address: &str,
    options: &RigOptions,
    stats: &mut LinkStats,
    buf: &mut [u8; MAX_FRAME_LEN + 1],
) -> Result<HelloAck, RigError> {
    let host_nonce: u64 = rand::random();
    let auth = options.key.as_ref().map(|key| Auth {
        key: key.bytes(),
        session_id: 0,
    });
    let hello = Message::Hello(Hello {
        host_nonce,
        key_id: options.key.as_ref().map(Key::id),
    });
    let mut out = [0u8; MAX_FRAME_LEN];
    let n = codec::encode(&hello, auth.as_ref(), &mut out).map_err(RigError::Encode)?;
    let start = Instant::now();
    let give_up = start + options.handshake_timeout;
    let mut next_hello = start;
    // A rig busy with another session frees it when that host goes quiet (its session
    // timeout), so "busy" is retried until the handshake time is up.
    let mut busy: Option<Fault> = None;
    // A keyed host cannot tell the rig's untagged refusal from anyone's forgery: it believes
    // one only if no HelloAck proving the key arrives before the handshake time is up.
    let keyed = options.key.is_some();
    let mut unproven: Option<RigError> = None;
    loop {
        let now = Instant::now();
        if now >= give_up {
            if let Some(refusal) = unproven {
                return Err(refusal);
            }
            if let Some(fault) = busy {
                return Err(refused(&fault));
            }
            return Err(RigError::HandshakeTimeout {
                peer: address.to_string(),
                waited: options.handshake_timeout,
            });
        }
        if now >= next_hello {
            transport.send(&out[..n], peer)?;
            next_hello = now + options.hello_interval;
        }
        let wait = next_hello.min(give_up).saturating_duration_since(now);
        let (len, from) = match transport.recv(buf, wait)? {
            Recv::Frame { len, from } => (len, from),
            Recv::Timeout => continue,
            Recv::Garbled => {
                stats.corrupt += 1;
                continue;
            }
        };
        stats.received += 1;
        if from != *peer {
            stats.foreign_sender += 1;
            continue;
        }
        let Some(frame) = buf.get(..len) else {
            stats.corrupt += 1;
            continue;
        };
        let message = match codec::decode(frame, auth.as_ref()) {
            Ok(message) => message,
            Err(CodecError::VersionMismatch(rig)) => {
                let mismatch = RigError::VersionMismatch {
                    rig,
                    host: PROTOCOL_VERSION,
                };
                if !keyed {
                    return Err(mismatch);
                }
                stats.version_mismatch += 1;
                unproven.get_or_insert(mismatch);
                continue;
            }
            Err(e) if e.kind() == codec::CodecErrorKind::Auth => {
                // The rig answers a Hello it cannot authenticate with an untagged refusal.
                if let Ok((Message::Fault(fault), _)) = codec::decode_unverified(frame) {
                    if fault.code == FaultCode::BUSY {
                        busy = Some(fault);
                        continue;
                    }
                    if answers_hello(fault.code) && !keyed {
                        return Err(refused(&fault));
                    }
                    if answers_hello(fault.code) {
                        unproven.get_or_insert(refused(&fault));
                    }
                }
                stats.auth_failed += 1;
                continue;
            }
            Err(e) => {
                stats.count_codec_error(&e);
                continue;
            }
        };
        match message {
            Message::HelloAck(ack) if ack.host_nonce == host_nonce => return Ok(ack),
            Message::Fault(fault) if fault.code == FaultCode::BUSY => busy = Some(fault),
            Message::Fault(fault) if answers_hello(fault.code) => return Err(refused(&fault)),
            // Frames of an earlier session, or an answer to someone else's Hello.
            _ => stats.unexpected += 1,
        }
    }
}

/// Checks the rig's self-description against what the host expects.
fn validate_ack(ack: &HelloAck, address: &str, options: &RigOptions) -> Result<RigInfo, RigError> {
    let mismatch = |reason: String| RigError::LayoutMismatch { reason };
    let layout = ack.layout;
    if usize::from(layout.leg_count) != LEG_COUNT {
        return Err(mismatch(format!(
            "the rig reports {} legs, this host drives {LEG_COUNT}",
            layout.leg_count
        )));
    }
    if options.require_imu && !layout.imu_present {
        return Err(mismatch(
            "the rig has no IMU; the estimator needs its gyro and accelerometer".into(),
        ));
    }
    if !layout.accel_position_m.iter().all(|v| v.is_finite()) {
        return Err(mismatch(
            "the rig's accelerometer position is not finite".into(),
        ));
    }
    if let Some(expected) = options.accel_position_m {
        let distance = expected
            .iter()
            .zip(&layout.accel_position_m)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt();
        if distance.is_nan() || distance > options.accel_position_tolerance_m {
            return Err(mismatch(format!(
                "accelerometer at {:?} m on the rig but {:?} m in the host's configuration",
                layout.accel_position_m, expected
            )));
        }
    }
    if ack.sample_period_ns == 0 {
        return Err(mismatch("the rig reports a zero sample period".into()));
    }
    let sample_period_s = crate::convert::ns_to_seconds(u64::from(ack.sample_period_ns));
    if let Some(expected) = options.sample_period_s {
        if (expected - sample_period_s).abs() > 1e-9 {
            return Err(mismatch(format!(
                "the rig samples every {sample_period_s} s, the host's configuration expects {expected} s"
            )));
        }
    }
    let l = ack.limits;
    let sane = [
        l.stroke_min_m,
        l.stroke_max_m,
        l.speed_max_m_s,
        l.force_min_n,
        l.force_max_n,
    ]
    .iter()
    .all(|v| v.is_finite())
        && l.stroke_min_m < l.stroke_max_m
        && l.speed_max_m_s > 0.0
        && l.force_min_n < l.force_max_n;
    if !sane {
        return Err(mismatch(format!("the rig reports unusable limits {l:?}")));
    }
    Ok(RigInfo {
        address: address.to_string(),
        identity: identity_str(&ack.identity).to_string(),
        session_id: ack.session_id,
        layout,
        sample_period_s,
        watchdog: Duration::from_nanos(u64::from(ack.watchdog_ns)),
        limits: l,
    })
}
