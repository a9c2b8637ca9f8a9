//! Host and emulator against each other over loopback UDP, plus scripted raw peers that
//! misbehave on purpose. The inner backend is a tiny fake: fixed leg lengths, leg forces that
//! echo the applied command, and a log of every command it was given.

use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use control::io::{Backend, CommandFrame, SensorFrame, Status, LEG_COUNT};
use rand::{Rng, SeedableRng};

use crate::codec::{self, Auth, MAX_FRAME_LEN};
use crate::emulator::{Emulator, EmulatorConfig, FaultInjection};
use crate::wire::*;
use crate::{ErrorKind, Key, RigBackend, RigError, RigOptions};

const PERIOD_S: f64 = 0.001;
const LENGTH_M: f64 = 0.55;

/// Stands in for the simulator: time advances in `write`, forces follow the command.
#[derive(Debug, Default)]
pub(crate) struct FakeBackend {
    time_s: f64,
    sequence: u64,
    applied: Vec<CommandFrame>,
    /// Legs extend at this speed while the actuators are enabled, m/s.
    rate_m_s: f64,
    enabled_ticks: u64,
    /// The sample period, s (`None`: [`PERIOD_S`]).
    period_s: Option<f64>,
}

impl FakeBackend {
    /// Largest force magnitude ever applied with the actuators enabled.
    pub(crate) fn max_enabled_force(&self) -> f64 {
        self.applied
            .iter()
            .filter(|c| c.enable)
            .flat_map(|c| c.leg_forces_n)
            .fold(0.0, |m: f64, f| m.max(f.abs()))
    }
}

impl Backend for FakeBackend {
    type Error = String;

    fn read(&mut self) -> Result<SensorFrame, String> {
        let last = self.applied.last().copied().unwrap_or_default();
        Ok(SensorFrame {
            sequence: self.sequence,
            time_s: self.time_s,
            leg_lengths_m: [LENGTH_M + self.rate_m_s * self.enabled_ticks as f64 * PERIOD_S;
                LEG_COUNT],
            leg_forces_n: if last.enable {
                last.leg_forces_n
            } else {
                [0.0; LEG_COUNT]
            },
            gyro_rad_s: [0.0; 3],
            accel_m_s2: [0.0, 0.0, stewart_types::STANDARD_GRAVITY_M_S2],
            status: Status(0),
        })
    }

    fn write(&mut self, command: &CommandFrame) -> Result<(), String> {
        // Like the simulator, refuse what no actuator can do.
        if command.leg_forces_n.iter().any(|f| !f.is_finite()) {
            return Err(format!("non-finite force in {command:?}"));
        }
        self.applied.push(*command);
        self.enabled_ticks += u64::from(command.enable);
        self.sequence += 1;
        self.time_s = self.sequence as f64 * self.sample_period_s();
        Ok(())
    }

    fn sample_period_s(&self) -> f64 {
        self.period_s.unwrap_or(PERIOD_S)
    }
}

pub(crate) fn limits() -> Limits {
    Limits {
        stroke_min_m: 0.4,
        stroke_max_m: 0.7,
        speed_max_m_s: 0.5,
        force_min_n: -500.0,
        force_max_n: 500.0,
    }
}

/// One real-time pair (emulator and host, each a 1 kHz loop) at a time: run side by side on a
/// 2-core machine, they starve each other for hundreds of milliseconds and trip watchdogs that
/// no real host would. Held for the whole test; a failed test does not poison it.
fn one_at_a_time() -> MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Tests not about timing get generous time limits: the machine is shared and a scheduler
/// hiccup must not trip a watchdog there. The timing tests set the real defaults.
fn config() -> EmulatorConfig {
    EmulatorConfig {
        seed: 7,
        watchdog: Duration::from_millis(1000),
        ..EmulatorConfig::new(limits())
    }
}

fn host_options() -> RigOptions {
    RigOptions {
        link_silence: Duration::from_millis(1500),
        ..RigOptions::default()
    }
}

struct Running {
    _turn: MutexGuard<'static, ()>,
    address: String,
    stop: Arc<AtomicBool>,
    thread: JoinHandle<Emulator<FakeBackend>>,
}

impl Running {
    fn finish(self) -> Emulator<FakeBackend> {
        self.stop.store(true, Ordering::Relaxed);
        self.thread.join().expect("emulator thread panicked")
    }
}

fn start(config: EmulatorConfig) -> Running {
    start_with(FakeBackend::default(), config)
}

fn start_with(inner: FakeBackend, config: EmulatorConfig) -> Running {
    let turn = one_at_a_time();
    let mut emulator = Emulator::bind("udp://127.0.0.1:0", inner, config).expect("bind");
    let address = format!("udp://{}", emulator.local_addr().expect("local address"));
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let thread = std::thread::spawn(move || {
        emulator.run(&flag).expect("emulator run");
        emulator
    });
    Running {
        _turn: turn,
        address,
        stop,
        thread,
    }
}

/// Runs the host loop for `ticks` reads, commanding `force_n` on every leg.
fn drive(host: &mut RigBackend, ticks: usize, force_n: f64) -> Result<Vec<SensorFrame>, RigError> {
    let mut frames = Vec::with_capacity(ticks);
    for _ in 0..ticks {
        let frame = host.read()?;
        host.write(&CommandFrame {
            sequence: 0,
            sensor_sequence: frame.sequence,
            leg_forces_n: [force_n; LEG_COUNT],
            enable: true,
        })?;
        frames.push(frame);
    }
    Ok(frames)
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i]
}

#[test]
fn host_and_emulator_run_a_session() {
    let rig = start(config());
    let mut host = RigBackend::connect(&rig.address, host_options()).unwrap();
    assert_eq!(host.info().identity, "stewart-emulator");
    assert_eq!(host.sample_period_s(), PERIOD_S);
    assert_eq!(host.info().watchdog, config().watchdog);

    let mut arrivals = Vec::new();
    let mut frames = Vec::new();
    for _ in 0..300 {
        let frame = host.read().unwrap();
        arrivals.push(Instant::now());
        host.write(&CommandFrame {
            sequence: 0,
            sensor_sequence: frame.sequence,
            leg_forces_n: [42.0; LEG_COUNT],
            enable: true,
        })
        .unwrap();
        frames.push(frame);
    }
    let stats = *host.stats();
    drop(host);
    // Let the emulator take the last commands off its socket before it stops.
    std::thread::sleep(Duration::from_millis(20));
    let emulator = rig.finish();

    assert!(frames.windows(2).all(|w| w[1].sequence > w[0].sequence));
    assert!(frames
        .iter()
        .all(|f| f.leg_lengths_m == [LENGTH_M; LEG_COUNT]));
    // The commanded force comes back through the fake's load cells once it is applied.
    let echoed = frames
        .iter()
        .filter(|f| f.leg_forces_n == [42.0; LEG_COUNT])
        .count();
    assert!(
        echoed > 250,
        "only {echoed} frames show the commanded force"
    );
    assert!(frames.last().unwrap().status.has(Status::ENABLED));
    // Every sequence number is accounted for.
    assert_eq!(
        stats.accepted + stats.lost + stats.late,
        frames.last().unwrap().sequence
    );
    assert_eq!(stats.corrupt + stats.foreign_sender + stats.auth_failed, 0);
    assert!(emulator.faults().is_empty(), "{:?}", emulator.faults());
    assert_eq!(emulator.stats().core.sessions, 1);
    // 300 commands and the safe stop sent on drop (a few may still be in flight under load).
    let accepted = emulator.stats().core.commands_accepted;
    assert!((295..=301).contains(&accepted), "{accepted}");
    // Dropping the host sent a safe stop, and the emulator ends braked.
    assert!(!emulator.inner().applied.last().unwrap().enable);

    let mut periods_ms: Vec<f64> = arrivals
        .windows(2)
        .map(|w| (w[1] - w[0]).as_secs_f64() * 1e3)
        .collect();
    periods_ms.sort_by(f64::total_cmp);
    println!(
        "loop period over {} ticks: median {:.3} ms, p99 {:.3} ms, max {:.3} ms; {stats}",
        periods_ms.len(),
        percentile(&periods_ms, 0.5),
        percentile(&periods_ms, 0.99),
        periods_ms.last().unwrap()
    );
}

#[test]
fn commands_are_clamped_to_the_rigs_limits() {
    let rig = start(config());
    let options = RigOptions {
        force_limit_n: Some(300.0),
        ..host_options()
    };
    let mut host = RigBackend::connect(&rig.address, options).unwrap();
    assert_eq!(host.force_limits_n(), (-300.0, 300.0));
    drive(&mut host, 50, 1e6).unwrap();
    drive(&mut host, 50, -1e6).unwrap();
    let clamped = host.stats().commands_clamped;
    let nan = host.write(&CommandFrame {
        leg_forces_n: [f64::NAN; LEG_COUNT],
        enable: true,
        ..CommandFrame::default()
    });
    assert_eq!(nan.unwrap_err().kind(), ErrorKind::Command);
    drop(host);
    let emulator = rig.finish();
    assert_eq!(clamped, 100);
    assert!(emulator.faults().is_empty(), "{:?}", emulator.faults());
    assert_eq!(emulator.inner().max_enabled_force(), 300.0);
}

/// A UDP peer that speaks the protocol by hand, to misbehave in ways the real sides never do.
struct RawPeer {
    socket: UdpSocket,
}

impl RawPeer {
    fn new() -> Self {
        let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
        socket
            .set_read_timeout(Some(Duration::from_millis(1000)))
            .unwrap();
        Self { socket }
    }

    fn addr(&self) -> SocketAddr {
        self.socket.local_addr().unwrap()
    }

    fn send(&self, to: SocketAddr, message: &Message, auth: Option<&Auth<'_>>) {
        let mut out = [0u8; MAX_FRAME_LEN];
        let n = codec::encode(message, auth, &mut out).unwrap();
        self.socket.send_to(&out[..n], to).unwrap();
    }

    /// The next frame that decodes under `auth` (others skipped), within the read timeout.
    fn recv(&self, auth: Option<&Auth<'_>>) -> Option<(Message, SocketAddr)> {
        let mut buf = [0u8; MAX_FRAME_LEN + 1];
        let give_up = Instant::now() + Duration::from_secs(5);
        while Instant::now() < give_up {
            let Ok((n, from)) = self.socket.recv_from(&mut buf) else {
                return None;
            };
            if let Ok(message) = codec::decode(&buf[..n], auth) {
                return Some((message, from));
            }
            if let Ok((message @ Message::Fault(_), _)) = codec::decode_unverified(&buf[..n]) {
                return Some((message, from));
            }
        }
        None
    }

    /// Waits until a sensor frame shows `force_n` on the load cells: the fake echoes the
    /// applied command, so the rig has then applied it (a fixed sleep is not enough on a busy
    /// machine, where the next command may overtake it before the rig's next tick).
    fn wait_until_applied(&self, force_n: f64) {
        loop {
            match self.recv(None) {
                Some((Message::Sensor(s), _)) if s.leg_forces_n == [force_n; LEG_COUNT] => return,
                Some(_) => continue,
                None => panic!("the rig never applied {force_n} N"),
            }
        }
    }

    /// Opens a session with the rig at `rig`; returns the HelloAck.
    fn hello(&self, rig: SocketAddr, key: Option<&Key>) -> Result<HelloAck, Fault> {
        let auth = key.map(|k| Auth {
            key: k.bytes(),
            session_id: 0,
        });
        let hello = Hello {
            host_nonce: 99,
            key_id: key.map(Key::id),
        };
        self.send(rig, &Message::Hello(hello), auth.as_ref());
        loop {
            match self.recv(auth.as_ref()) {
                Some((Message::HelloAck(ack), _)) if ack.host_nonce == 99 => return Ok(ack),
                Some((Message::Fault(fault), _)) => return Err(fault),
                Some(_) => continue,
                None => panic!("no answer to Hello"),
            }
        }
    }
}

fn socket_addr(address: &str) -> SocketAddr {
    address.trim_start_matches("udp://").parse().unwrap()
}

fn command(sequence: u64, force_n: f64) -> Message {
    Message::Command(Command {
        sequence,
        sensor_sequence: 0,
        leg_forces_n: [force_n; LEG_COUNT],
        enable: true,
    })
}

#[test]
fn a_second_sender_cannot_command_during_a_session() {
    let rig = start(config());
    let rig_addr = socket_addr(&rig.address);
    let mut host = RigBackend::connect(&rig.address, host_options()).unwrap();
    drive(&mut host, 20, 10.0).unwrap();

    // A second host doing everything right is refused as busy...
    let stray = RawPeer::new();
    assert_eq!(
        stray.hello(rig_addr, None),
        Err(stray_fault(FaultCode::BUSY))
    );
    // ...and its well-formed commands at any sequence number are dropped.
    for sequence in [1, 2, 1_000, u64::MAX] {
        stray.send(rig_addr, &command(sequence, 400.0), None);
    }
    // Another full host backend keeps asking for the handshake time, then gives up with a
    // clear error, before any motion.
    let impatient = RigOptions {
        handshake_timeout: Duration::from_millis(150),
        ..host_options()
    };
    let second = RigBackend::connect(&rig.address, impatient);
    let err = second.err().expect("second host must be refused");
    assert_eq!(err.kind(), ErrorKind::Handshake);
    assert!(err.to_string().contains("another host"), "{err}");

    drive(&mut host, 100, 10.0).unwrap();
    drop(host);
    let emulator = rig.finish();
    assert_eq!(emulator.inner().max_enabled_force(), 10.0);
    assert!(
        emulator.stats().core.foreign_sender >= 5,
        "{:?}",
        emulator.stats()
    );
    assert_eq!(emulator.stats().core.sessions, 1);
}

fn stray_fault(code: FaultCode) -> Fault {
    Fault {
        code,
        leg: NO_LEG,
        value: 0.0,
        command_sequence: 0,
    }
}

#[test]
fn with_a_key_unkeyed_and_wrongly_keyed_frames_are_dropped() {
    let key = Key::from_hex("000102030405060708090a0b0c0d0e0f").unwrap();
    let other = Key::from_hex("ff0102030405060708090a0b0c0d0e0f").unwrap();
    let rig = start(EmulatorConfig {
        key: Some(key.clone()),
        ..config()
    });
    let rig_addr = socket_addr(&rig.address);

    // Hosts without the key are refused by name.
    let err = RigBackend::connect(&rig.address, host_options())
        .err()
        .unwrap();
    assert!(err.to_string().contains("requires a shared key"), "{err}");
    let wrong = RigOptions {
        key: Some(other.clone()),
        ..host_options()
    };
    let err = RigBackend::connect(&rig.address, wrong).err().unwrap();
    assert!(err.to_string().contains("key differs"), "{err}");

    // A keyed session opened by hand, so that bad frames come from the session's own address.
    let host = RawPeer::new();
    let ack = host.hello(rig_addr, Some(&key)).unwrap();
    let good = Auth {
        key: key.bytes(),
        session_id: ack.session_id,
    };
    let wrong_key = Auth {
        key: other.bytes(),
        session_id: ack.session_id,
    };
    let old_session = Auth {
        key: key.bytes(),
        session_id: ack.session_id ^ 1,
    };
    host.send(rig_addr, &command(1, 5.0), Some(&good));
    host.send(rig_addr, &command(2, 400.0), None);
    host.send(rig_addr, &command(3, 400.0), Some(&wrong_key));
    host.send(rig_addr, &command(4, 400.0), Some(&old_session));
    host.send(rig_addr, &command(5, 6.0), Some(&good));
    // Sensor frames come back tagged for this session.
    let (message, from) = host.recv(Some(&good)).expect("tagged sensor frame");
    assert_eq!(from, rig_addr);
    assert!(matches!(message, Message::Sensor(_)));
    std::thread::sleep(Duration::from_millis(10));
    let emulator = rig.finish();
    let stats = emulator.stats().core;
    assert_eq!(emulator.inner().max_enabled_force(), 6.0);
    assert_eq!(stats.commands_accepted, 2);
    // The keyless host's Hello, the wrongly keyed host's (one or more: it asks until its
    // handshake time is up, since it cannot tell the rig's untagged refusal from a forgery),
    // three bad commands.
    assert!(stats.auth_failed >= 5, "{stats:?}");
}

#[test]
fn a_version_mismatch_is_refused_before_any_motion() {
    // The emulator answers a Hello of another version with its own version, and opens nothing.
    let rig = start(config());
    let rig_addr = socket_addr(&rig.address);
    let peer = RawPeer::new();
    let mut out = [0u8; MAX_FRAME_LEN];
    let hello = Message::Hello(Hello {
        host_nonce: 1,
        key_id: None,
    });
    let n = codec::encode(&hello, None, &mut out).unwrap();
    out[1] = PROTOCOL_VERSION + 1;
    let crc = codec::CRC32.checksum(&out[..n - 4]);
    out[n - 4..n].copy_from_slice(&crc.to_le_bytes());
    peer.socket.send_to(&out[..n], rig_addr).unwrap();
    let (answer, _) = peer.recv(None).expect("an answer");
    assert_eq!(
        answer,
        Message::Fault(Fault {
            value: f64::from(PROTOCOL_VERSION),
            ..stray_fault(FaultCode::VERSION_MISMATCH)
        })
    );
    peer.send(rig_addr, &command(1, 100.0), None);
    std::thread::sleep(Duration::from_millis(5));
    let emulator = rig.finish();
    assert_eq!(emulator.stats().core.sessions, 0);
    assert_eq!(emulator.inner().max_enabled_force(), 0.0);

    // The host refuses a rig that answers in another version, naming both.
    let fake_rig = RawPeer::new();
    let fake_addr = fake_rig.addr();
    let answer = std::thread::spawn(move || {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let (_, host) = fake_rig.socket.recv_from(&mut buf).unwrap();
        let fault = Message::Fault(stray_fault(FaultCode::BUSY));
        let n = codec::encode(&fault, None, &mut buf).unwrap();
        buf[1] = 7;
        let crc = codec::CRC32.checksum(&buf[..n - 4]);
        buf[n - 4..n].copy_from_slice(&crc.to_le_bytes());
        fake_rig.socket.send_to(&buf[..n], host).unwrap();
    });
    let err = RigBackend::connect(&format!("udp://{fake_addr}"), host_options())
        .err()
        .unwrap();
    answer.join().unwrap();
    assert!(
        matches!(
            err,
            RigError::VersionMismatch {
                rig: 7,
                host: PROTOCOL_VERSION
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("v7"), "{err}");
}

#[test]
fn layout_mismatches_are_refused_by_name() {
    let no_imu = EmulatorConfig {
        layout: SensorLayout {
            imu_present: false,
            ..config().layout
        },
        ..config()
    };
    // Each refusal leaves the rig holding a session until its timeout: one rig per case.
    let rig = start(no_imu.clone());
    let err = RigBackend::connect(&rig.address, host_options())
        .err()
        .unwrap();
    assert!(err.to_string().contains("no IMU"), "{err}");
    let emulator = rig.finish();
    assert_eq!(emulator.inner().max_enabled_force(), 0.0);
    let rig = start(no_imu.clone());
    let elsewhere = RigOptions {
        require_imu: false,
        accel_position_m: Some([0.0, 0.0, 0.1]),
        ..host_options()
    };
    let err = RigBackend::connect(&rig.address, elsewhere).err().unwrap();
    assert!(err.to_string().contains("accelerometer at"), "{err}");
    rig.finish();
    let rig = start(no_imu);
    let faster = RigOptions {
        require_imu: false,
        sample_period_s: Some(0.0005),
        ..host_options()
    };
    let err = RigBackend::connect(&rig.address, faster).err().unwrap();
    assert!(err.to_string().contains("samples every"), "{err}");
    let emulator = rig.finish();
    assert_eq!(emulator.inner().max_enabled_force(), 0.0);
}

#[test]
fn link_silence_is_detected_and_the_rig_brakes() {
    let rig = start(EmulatorConfig {
        faults: FaultInjection {
            stop_after_frames: Some(100),
            ..FaultInjection::default()
        },
        ..config()
    });
    let mut host = RigBackend::connect(&rig.address, RigOptions::default()).unwrap();
    let mut last_good = Instant::now();
    let err = loop {
        match drive(&mut host, 1, 20.0) {
            Ok(_) => last_good = Instant::now(),
            Err(e) => break e,
        }
    };
    let detected_after = last_good.elapsed();
    assert_eq!(err.kind(), ErrorKind::Link);
    let RigError::LinkSilent {
        silent_for,
        limit,
        last_sequence,
    } = err
    else {
        panic!("{err}");
    };
    assert_eq!(limit, Duration::from_millis(50));
    assert!(silent_for >= limit);
    assert!(last_sequence <= 100);
    println!("link silence detected {detected_after:?} after the last frame");
    assert!(
        detected_after < Duration::from_millis(100),
        "{detected_after:?}"
    );
    std::thread::sleep(Duration::from_millis(40));
    let emulator = rig.finish();
    // The host's safe stop and the rig's own watchdog both leave the actuators braked.
    assert!(!emulator.inner().applied.last().unwrap().enable);
}

#[test]
fn the_rig_watchdog_brakes_and_the_host_hears_the_fault() {
    let rig = start(EmulatorConfig {
        watchdog: Duration::from_millis(20),
        ..config()
    });
    let mut host = RigBackend::connect(&rig.address, host_options()).unwrap();
    // On a loaded machine the 20 ms can already pass while driving: the fault is then heard
    // there, which is just as much what this test is about.
    let err = match drive(&mut host, 20, 30.0) {
        Err(e) => e,
        Ok(_) => {
            std::thread::sleep(Duration::from_millis(60));
            loop {
                if let Err(e) = host.read() {
                    break e;
                }
            }
        }
    };
    assert!(
        matches!(
            err,
            RigError::RigFault {
                code: FaultCode::WATCHDOG,
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("watchdog"), "{err}");
    drop(host);
    let emulator = rig.finish();
    assert_eq!(emulator.faults().len(), 1);
    let applied = &emulator.inner().applied;
    let first_brake_after_motion = applied
        .iter()
        .rposition(|c| c.enable)
        .expect("the actuators were enabled");
    assert!(applied[first_brake_after_motion + 1..]
        .iter()
        .all(|c| !c.enable));
}

#[test]
fn a_command_beyond_the_limits_brakes_and_latches() {
    let rig = start(config());
    let rig_addr = socket_addr(&rig.address);
    let host = RawPeer::new();
    host.hello(rig_addr, None).unwrap();
    host.send(rig_addr, &command(1, 100.0), None);
    host.wait_until_applied(100.0);
    host.send(rig_addr, &command(2, 501.0), None);
    let fault = loop {
        match host.recv(None) {
            Some((Message::Fault(fault), _)) => break fault,
            Some(_) => continue,
            None => panic!("no fault report"),
        }
    };
    assert_eq!(fault.code, FaultCode::FORCE_LIMIT);
    assert_eq!(fault.value, 501.0);
    assert_eq!(fault.command_sequence, 2);
    // Later valid commands do not release the brakes: the fault holds until a new session,
    // and its report is repeated in case a datagram was lost.
    let mut repeats = 0;
    let mut faulted_frames = 0;
    for sequence in 3..60 {
        host.send(rig_addr, &command(sequence, 50.0), None);
        match host.recv(None) {
            Some((Message::Fault(again), _)) => {
                assert_eq!(again, fault);
                repeats += 1;
            }
            Some((Message::Sensor(s), _)) if Status(s.status).has(Status::FAULT) => {
                faulted_frames += 1
            }
            _ => {}
        }
    }
    assert!(repeats >= 1, "{repeats}");
    assert!(faulted_frames >= 40, "{faulted_frames}");
    let emulator = rig.finish();
    let applied = &emulator.inner().applied;
    assert_eq!(emulator.inner().max_enabled_force(), 100.0);
    assert!(!applied.last().unwrap().enable);
}

#[test]
fn dropped_and_corrupted_frames_are_counted_never_fed() {
    let rig = start(EmulatorConfig {
        faults: FaultInjection {
            drop_fraction: 0.10,
            corrupt_fraction: 0.05,
            ..FaultInjection::default()
        },
        ..config()
    });
    let mut host = RigBackend::connect(&rig.address, host_options()).unwrap();
    let frames = drive(&mut host, 500, 1.0).unwrap();
    let stats = *host.stats();
    drop(host);
    let emulator = rig.finish();
    let e = emulator.stats();
    println!("host: {stats}\nemulator: {e:?}");
    let last = frames.last().unwrap().sequence;
    assert_eq!(stats.accepted + stats.lost + stats.late, last);
    assert!(frames.windows(2).all(|w| w[1].sequence > w[0].sequence));
    // Every corrupted frame the host saw was caught; the ones it never saw were sent after it
    // stopped reading.
    assert!(
        stats.corrupt > 0 && stats.corrupt <= e.corrupted_injected,
        "{stats}"
    );
    // Dropped and corrupted frames both leave gaps.
    assert!(stats.lost >= stats.corrupt, "{stats}");
    assert!(
        stats.lost <= e.dropped_injected + e.corrupted_injected,
        "{stats}"
    );
    let lost_fraction = stats.lost as f64 / last as f64;
    assert!((0.08..0.22).contains(&lost_fraction), "{lost_fraction}");
}

#[test]
fn delayed_frames_arrive_out_of_sequence_and_are_dropped() {
    let rig = start(EmulatorConfig {
        faults: FaultInjection {
            delay_fraction: 0.1,
            delay: Duration::from_millis(3),
            ..FaultInjection::default()
        },
        ..config()
    });
    let mut host = RigBackend::connect(&rig.address, host_options()).unwrap();
    let frames = drive(&mut host, 300, 1.0).unwrap();
    let stats = *host.stats();
    drop(host);
    rig.finish();
    assert!(frames.windows(2).all(|w| w[1].sequence > w[0].sequence));
    assert!(stats.out_of_sequence > 0, "{stats}");
}

/// A fake rig that completes a handshake, then sends a script of frames from its own address.
fn scripted_rig(
    key: Option<Key>,
    script: impl FnOnce(&UdpSocket, SocketAddr, Option<Auth<'_>>) + Send + 'static,
) -> (String, JoinHandle<()>) {
    let rig = RawPeer::new();
    let address = format!("udp://{}", rig.addr());
    let thread = std::thread::spawn(move || {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let (n, host) = rig.socket.recv_from(&mut buf).unwrap();
        let auth0 = key.as_ref().map(|k| Auth {
            key: k.bytes(),
            session_id: 0,
        });
        let Ok(Message::Hello(hello)) = codec::decode(&buf[..n], auth0.as_ref()) else {
            panic!("expected Hello");
        };
        let ack = HelloAck {
            host_nonce: hello.host_nonce,
            session_id: 77,
            identity: identity_from_str("scripted"),
            layout: config().layout,
            sample_period_ns: 1_000_000,
            watchdog_ns: 20_000_000,
            limits: limits(),
        };
        rig.send(host, &Message::HelloAck(ack), auth0.as_ref());
        let auth = key.as_ref().map(|k| Auth {
            key: k.bytes(),
            session_id: 77,
        });
        script(&rig.socket, host, auth);
    });
    (address, thread)
}

fn sensor(sequence: u64) -> Message {
    Message::Sensor(Sensor {
        sequence,
        time_ns: sequence * 1_000_000,
        leg_lengths_m: [LENGTH_M; LEG_COUNT],
        leg_forces_n: [1.0; LEG_COUNT],
        gyro_rad_s: [0.0; 3],
        accel_m_s2: [0.0, 0.0, 9.8],
        status: 0,
    })
}

fn send_to(socket: &UdpSocket, to: SocketAddr, message: &Message, auth: Option<&Auth<'_>>) {
    let mut out = [0u8; MAX_FRAME_LEN];
    let n = codec::encode(message, auth, &mut out).unwrap();
    socket.send_to(&out[..n], to).unwrap();
}

#[test]
fn the_host_feeds_only_good_in_order_frames_and_counts_the_rest() {
    let key = Key::from_hex("00112233445566778899aabbccddeeff").unwrap();
    let other = Key::from_hex("ff112233445566778899aabbccddeeff").unwrap();
    let (address, rig) = scripted_rig(Some(key.clone()), move |socket, host, auth| {
        let good = auth.as_ref();
        let wrong = Auth {
            key: other.bytes(),
            session_id: 77,
        };
        let mut rng = rand::rngs::StdRng::seed_from_u64(1);
        send_to(socket, host, &sensor(1), good);
        send_to(socket, host, &sensor(1), good); // duplicate
        send_to(socket, host, &sensor(2), None); // untagged
        send_to(socket, host, &sensor(2), Some(&wrong)); // wrong key
        for _ in 0..20 {
            let len = rng.random_range(0..300);
            let junk: Vec<u8> = (0..len).map(|_| rng.random()).collect();
            socket.send_to(&junk, host).unwrap(); // noise from the rig's own address
        }
        send_to(socket, host, &sensor(4), good); // 3 lost
        send_to(socket, host, &sensor(3), good); // out of sequence
        send_to(
            socket,
            host,
            &Message::Command(Command {
                sequence: 1,
                sensor_sequence: 1,
                leg_forces_n: [0.0; LEG_COUNT],
                enable: true,
            }),
            good,
        ); // unexpected kind
        send_to(socket, host, &sensor(5), good);
        // A stranger speaking the protocol perfectly.
        let stranger = UdpSocket::bind("127.0.0.1:0").unwrap();
        send_to(&stranger, host, &sensor(6), good);
        send_to(socket, host, &sensor(7), good);
        std::thread::sleep(Duration::from_millis(200));
    });
    let options = RigOptions {
        key: Some(key),
        skip_stale: false,
        ..host_options()
    };
    let mut host = RigBackend::connect(&address, options).unwrap();
    let mut sequences = Vec::new();
    let err = loop {
        match host.read() {
            Ok(frame) => sequences.push(frame.sequence),
            Err(e) => break e,
        }
    };
    rig.join().unwrap();
    assert_eq!(err.kind(), ErrorKind::Link);
    assert_eq!(sequences, [1, 4, 5, 7]);
    let s = host.stats();
    assert_eq!(s.duplicate, 1, "{s}");
    assert_eq!(s.auth_failed, 2, "{s}");
    assert_eq!(s.lost, 3, "{s}"); // 2, 3 and 6
    assert_eq!(s.out_of_sequence, 1, "{s}");
    assert_eq!(s.unexpected, 1, "{s}");
    assert_eq!(s.foreign_sender, 1, "{s}");
    // Random bytes: counted as corrupt (or, for a rare lucky first byte, as another protocol).
    assert_eq!(s.corrupt + s.version_mismatch, 20, "{s}");
}

#[test]
fn invalid_sensor_values_fail_the_read_by_name() {
    let (address, rig) = scripted_rig(None, |socket, host, _| {
        send_to(socket, host, &sensor(1), None);
        let Message::Sensor(mut bad) = sensor(2) else {
            unreachable!()
        };
        bad.gyro_rad_s[1] = f64::NAN;
        send_to(socket, host, &Message::Sensor(bad), None);
        bad.sequence = 3;
        bad.gyro_rad_s[1] = 0.0;
        bad.leg_lengths_m[4] = 0.9;
        send_to(socket, host, &Message::Sensor(bad), None);
        bad.sequence = 4;
        bad.leg_lengths_m[4] = LENGTH_M;
        bad.status = Status::FAULT | Status::BRAKED;
        send_to(socket, host, &Message::Sensor(bad), None);
        bad.sequence = 5;
        bad.status = Status::ESTOP;
        send_to(socket, host, &Message::Sensor(bad), None);
        std::thread::sleep(Duration::from_millis(100));
    });
    let options = RigOptions {
        skip_stale: false,
        ..host_options()
    };
    let mut host = RigBackend::connect(&address, options).unwrap();
    assert_eq!(host.read().unwrap().sequence, 1);
    let err = host.read().unwrap_err();
    assert_eq!(err.kind(), ErrorKind::Sensor);
    assert!(err.to_string().contains("gyro [1] is NaN"), "{err}");
    let err = host.read().unwrap_err();
    assert!(err.to_string().contains("leg 4 length"), "{err}");
    let err = host.read().unwrap_err();
    assert!(err.to_string().contains("FAULT status bit"), "{err}");
    let err = host.read().unwrap_err();
    assert!(err.to_string().contains("emergency stop"), "{err}");
    rig.join().unwrap();
}

#[test]
fn random_datagrams_at_both_sockets_are_counted_and_harmless() {
    let rig = start(config());
    let rig_addr = socket_addr(&rig.address);
    let mut host = RigBackend::connect(&rig.address, host_options()).unwrap();
    let host_addr = host.local_addr().unwrap();
    let noise = UdpSocket::bind("127.0.0.1:0").unwrap();
    let mut rng = rand::rngs::StdRng::seed_from_u64(3);
    for tick in 0..200 {
        if tick % 2 == 0 {
            for to in [host_addr, rig_addr] {
                let len = rng.random_range(0..400);
                let junk: Vec<u8> = (0..len).map(|_| rng.random()).collect();
                noise.send_to(&junk, to).unwrap();
            }
        }
        drive(&mut host, 1, 2.0).unwrap();
    }
    // Quiet ticks: the rig reads what is waiting every tick, so by now it has seen the noise.
    drive(&mut host, 20, 2.0).unwrap();
    let stats = *host.stats();
    drop(host);
    let emulator = rig.finish();
    assert_eq!(stats.foreign_sender, 100, "{stats}");
    assert!(emulator.stats().core.corrupt + emulator.stats().core.foreign_sender >= 100);
    assert_eq!(emulator.inner().max_enabled_force(), 2.0);
}

#[cfg(unix)]
#[test]
fn a_session_runs_over_a_serial_line() {
    use crate::transport::{Peer, SerialTransport};
    let _turn = one_at_a_time();
    let (a, b) = serialport::TTYPort::pair().expect("pseudo-terminal pair");
    let rig_side = SerialTransport::from_port(Box::new(a), "pty-rig");
    let host_side = SerialTransport::from_port(Box::new(b), "pty-host");
    let mut emulator = Emulator::new(FakeBackend::default(), Box::new(rig_side), config()).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let thread = std::thread::spawn(move || {
        emulator.run(&flag).expect("emulator run");
        emulator
    });
    let mut host = RigBackend::connect_over(
        Box::new(host_side),
        Peer::Serial,
        "pty".into(),
        host_options(),
    )
    .unwrap();
    let frames = drive(&mut host, 200, 25.0).unwrap();
    let stats = *host.stats();
    // Stop the rig before the host closes its end: a closed pseudo-terminal reads as an
    // error on the other end, unlike a real serial line.
    stop.store(true, Ordering::Relaxed);
    let emulator = thread.join().unwrap();
    drop(host);
    assert_eq!(
        stats.corrupt + stats.auth_failed + stats.unexpected,
        0,
        "{stats}"
    );
    assert_eq!(
        stats.accepted + stats.lost + stats.late,
        frames.last().unwrap().sequence
    );
    assert_eq!(emulator.inner().max_enabled_force(), 25.0);
    assert!(emulator.faults().is_empty(), "{:?}", emulator.faults());
}

/// Drives until the rig reports a fault; returns it.
fn drive_until_fault(rig: &Running) -> RigError {
    let mut host = RigBackend::connect(&rig.address, host_options()).unwrap();
    for _ in 0..2000 {
        if let Err(e) = drive(&mut host, 1, 1.0) {
            return e;
        }
    }
    panic!("no fault after 2000 ticks");
}

#[test]
fn the_rig_brakes_on_leg_speed() {
    let fast = FakeBackend {
        rate_m_s: 1.0,
        ..FakeBackend::default()
    };
    let rig = start_with(fast, config());
    let err = drive_until_fault(&rig);
    let emulator = rig.finish();
    let RigError::RigFault {
        code, leg, value, ..
    } = err
    else {
        panic!("{err}");
    };
    assert_eq!((code, leg), (FaultCode::SPEED_LIMIT, 0));
    assert!((value - 1.0).abs() < 1e-9, "{value}");
    // Tripped on the first full 10-sample window: the legs moved 10 samples' worth at most.
    assert!(
        emulator.inner().enabled_ticks <= 11,
        "{}",
        emulator.inner().enabled_ticks
    );
    assert!(!emulator.inner().applied.last().unwrap().enable);
}

#[test]
fn the_rig_brakes_at_the_end_of_the_stroke() {
    let creeping = FakeBackend {
        rate_m_s: 0.45,
        ..FakeBackend::default()
    };
    let rig = start_with(creeping, config());
    let err = drive_until_fault(&rig);
    let emulator = rig.finish();
    let RigError::RigFault { code, value, .. } = err else {
        panic!("{err}");
    };
    assert_eq!(code, FaultCode::STROKE_LIMIT);
    assert!(
        value > 0.7 && value < 0.7 + 0.45 * PERIOD_S * 1.5,
        "{value}"
    );
    let fake = emulator.inner();
    let last_length = LENGTH_M + 0.45 * fake.enabled_ticks as f64 * PERIOD_S;
    assert!(last_length < 0.7 + 0.45 * PERIOD_S * 1.5, "{last_length}");
}

#[test]
fn a_braking_command_with_garbage_forces_reaches_the_backend_as_zeros() {
    let rig = start(config());
    let rig_addr = socket_addr(&rig.address);
    let host = RawPeer::new();
    host.hello(rig_addr, None).unwrap();
    host.send(rig_addr, &command(1, 5.0), None);
    host.wait_until_applied(5.0);
    let brake = Message::Command(Command {
        sequence: 2,
        sensor_sequence: 0,
        leg_forces_n: [f64::NAN, f64::INFINITY, 1e300, 0.0, -1.0, 2.0],
        enable: false,
    });
    host.send(rig_addr, &brake, None);
    // Braked, the fake's load cells read zero: the brake reached the backend (whose `write`
    // refuses non-finite forces, which would end the emulator's run with an error).
    host.wait_until_applied(0.0);
    host.send(rig_addr, &command(3, 10.0), None);
    host.wait_until_applied(10.0);
    let emulator = rig.finish();
    assert!(emulator.faults().is_empty(), "{:?}", emulator.faults());
    assert_eq!(emulator.stats().core.commands_accepted, 3);
    assert_eq!(emulator.inner().max_enabled_force(), 10.0);
    assert!(emulator
        .inner()
        .applied
        .iter()
        .filter(|c| !c.enable)
        .all(|c| c.leg_forces_n == [0.0; LEG_COUNT]));
}

#[test]
fn after_a_pause_of_the_caller_the_host_skips_to_the_newest_frame() {
    let rig = start(config());
    let mut host = RigBackend::connect(&rig.address, RigOptions::default()).unwrap();
    // Longer than the 50 ms silence limit, but the rig kept sending: not a silent link. And
    // about 150 frames queued, more than a drain of 64 would reach: one read catches up.
    std::thread::sleep(Duration::from_millis(150));
    let first = host.read().unwrap();
    let stats = *host.stats();
    let second = host.read().unwrap();
    drop(host);
    rig.finish();
    assert!(first.sequence >= 120, "{}", first.sequence);
    assert_eq!(stats.late + 1, first.sequence, "{stats}");
    // The next read is the next sample or nearly: no second jump of a backlog, which would be
    // tens of frames (a busy machine may still let a few periods pass between the two reads).
    assert!(
        second.sequence - first.sequence <= 20,
        "{} then {}",
        first.sequence,
        second.sequence
    );
}

#[test]
fn a_host_restarts_its_session_over_the_same_link() {
    use crate::emulator::SessionStart;
    let _turn = one_at_a_time();
    let seen: Arc<Mutex<Vec<SessionStart>>> = Arc::default();
    let config = EmulatorConfig {
        // The old session must still be open when the host restarts after the watchdog trips.
        session_timeout: Duration::from_secs(10),
        ..config()
    };
    let mut emulator =
        Emulator::bind("udp://127.0.0.1:0", FakeBackend::default(), config).expect("bind");
    let log = Arc::clone(&seen);
    emulator.set_session_hook(Box::new(
        move |inner: &mut FakeBackend, start: &SessionStart| {
            // What an operator would do between sessions; visible in the frames of the session.
            inner.rate_m_s = 0.01 * start.number as f64;
            log.lock().unwrap().push(*start);
        },
    ));
    let address = format!("udp://{}", emulator.local_addr().unwrap());
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let thread = std::thread::spawn(move || {
        emulator.run(&flag).expect("emulator run");
        emulator
    });

    let mut host = RigBackend::connect(&address, host_options()).expect("connect");
    let first = host.info().session_id;
    let frames = drive(&mut host, 50, 10.0).unwrap();
    // Numbered from 1; a busy machine may leave the first frames waiting, skipped as late
    // (CI once saw 3 here).
    assert!(frames[0].sequence <= 50, "{}", frames[0].sequence);
    // The host stops commanding: the rig's watchdog trips and its fault reports wait in the
    // host's socket. A new session must not mistake them for an answer to its Hello.
    std::thread::sleep(Duration::from_millis(1200));
    host.restart_session().expect("a new session");
    assert_ne!(host.info().session_id, first);
    assert_eq!(host.last_sequence(), 0);
    let frames = drive(&mut host, 50, 10.0).unwrap();
    // Numbered from 1 again (the old session had reached about 1250 by now); a busy machine
    // may leave some of the new session's first frames waiting, skipped as late.
    assert!(frames[0].sequence < 300, "{}", frames[0].sequence);
    assert!(frames.windows(2).all(|w| w[1].sequence > w[0].sequence));
    drop(host);
    stop.store(true, Ordering::Relaxed);
    let emulator = thread.join().unwrap();
    let sessions = seen.lock().unwrap().clone();
    assert_eq!(sessions.len(), 2);
    assert_eq!([sessions[0].number, sessions[1].number], [1, 2]);
    assert_eq!(sessions[0].peer, sessions[1].peer);
    assert_eq!(emulator.inner().rate_m_s, 0.02);
    // The first session's watchdog fault, nothing in the second.
    assert_eq!(emulator.faults().len(), 1, "{:?}", emulator.faults());
    assert_eq!(emulator.faults()[0].code, FaultCode::WATCHDOG);
}

#[test]
fn in_lockstep_a_slow_host_pauses_the_emulated_world() {
    let rig = start(EmulatorConfig {
        lockstep: Some(Duration::from_millis(2000)),
        ..config()
    });
    let mut host = RigBackend::connect(&rig.address, host_options()).expect("connect");
    drive(&mut host, 20, 10.0).unwrap();
    // (Until the host's first command the rig runs in real time, so a slow start may already
    // have skipped frames as late: only the pause below is this test's business.)
    let late_before = host.stats().late;
    // A descheduled host: 100 periods without an answer.
    std::thread::sleep(Duration::from_millis(100));
    drive(&mut host, 20, 10.0).unwrap();
    let stats = *host.stats();
    let accepted_late = stats.late - late_before;
    drop(host);
    let emulator = rig.finish();
    // Real time would have applied the last command ~100 more times.
    let enabled = emulator.inner().applied.iter().filter(|c| c.enable).count();
    assert!((39..=45).contains(&enabled), "{enabled} enabled ticks");
    assert!(emulator.faults().is_empty(), "{:?}", emulator.faults());
    assert_eq!(accepted_late, 0, "{stats}");
}

/// Fast-forwarding, a host that answers at once runs the emulated world faster than real
/// time: 100 samples of 50 ms (5 s of real time) take a fraction of it, the rig core's clock
/// counts the emulated time, and nothing is late or faulted.
#[test]
fn fast_forwarding_runs_the_emulated_world_as_fast_as_the_host_answers() {
    const PERIOD: f64 = 0.05;
    let inner = FakeBackend {
        period_s: Some(PERIOD),
        ..FakeBackend::default()
    };
    let rig = start_with(
        inner,
        EmulatorConfig {
            lockstep: Some(Duration::from_millis(1000)),
            fast_forward: true,
            ..config()
        },
    );
    let mut host = RigBackend::connect(&rig.address, host_options()).expect("connect");
    let started = std::time::Instant::now();
    let frames = drive(&mut host, 100, 10.0).unwrap();
    let took = started.elapsed();
    let stats = *host.stats();
    drop(host);
    let emulator = rig.finish();
    // Real time would take 5 s; any machine answers 100 loopback datagrams in far less.
    assert!(
        took < Duration::from_millis(2500),
        "{took:?} for 100 samples"
    );
    assert!(
        emulator.fast_forwarded() >= Duration::from_millis(2500),
        "the rig core's clock ran {:?} ahead of the wall",
        emulator.fast_forwarded()
    );
    for pair in frames.windows(2) {
        assert_eq!(pair[1].sequence, pair[0].sequence + 1);
        assert!((pair[1].time_s - pair[0].time_s - PERIOD).abs() < 1e-9);
    }
    assert!(emulator.faults().is_empty(), "{:?}", emulator.faults());
    assert_eq!(stats.late, 0, "{stats}");
}
