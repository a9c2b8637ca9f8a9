//! The live view: the run log's channels served over the Foxglove WebSocket protocol while the
//! log is written (`--live` of `stewart simulate` and `stewart rig`), by Foxglove's own SDK.
//!
//! **One message, two sinks.** The server is the run log's [`Tap`]: the log's writer thread
//! hands it each message, the same bytes at the same log time, before it writes them to the
//! file ([`runlog::tap`]). So the live view has exactly the log's channels (topic, schema name,
//! schema, encoding) at the log's rates ([`runlog::run_log::rates`]), and a channel added to
//! the catalogue ([`runlog::messages::channels`]) is served without a change here.
//!
//! **Which thread does what.**
//!
//! - The caller's thread (the run loop; on a rig, the control loop) only serializes the message
//!   into a recycled batch and queues full batches, as without a live view: it never calls the
//!   SDK. The SDK allocates a frame per message per subscribed client and takes locks; a rig's
//!   control loop is allocation-free once warm (`tests/no_heap_tick.rs`) and must not wait on a
//!   lock a socket thread holds, so none of that happens on it. With a live view a batch is
//!   handed over once it spans [`runlog::mcap_log::LIVE_BATCH_SPAN_NS`] of log time (the view
//!   runs at most that far behind the log, and moves in steps of 25 a second), and the queue
//!   is longer in proportion, so that it holds as many seconds of log as without one.
//! - The log's writer thread (`mcap-writer`) gets every batch queued and, for each message,
//!   calls [`Tap::message`] (the SDK copies the message to each subscribed client's queue,
//!   and keeps the [`LATCHED`] records), then writes the batch to the file. A batch the log
//!   drops for a full queue ([`runlog::mcap_log::Delivery::DropWhenFull`]) is missing from the
//!   live view too: the view is the log's messages, never more.
//! - The SDK's own threads (a tokio runtime) write the sockets.
//!
//! **Never in the run's way.** [`LiveServer::log`] does not wait: with no client subscribed to
//! a channel it returns at once; otherwise the SDK queues the message for each subscribed
//! client (a bounded queue of [`BACKLOG_MESSAGES`] that drops the oldest message when a client
//! falls behind). So a stalled client holds neither the writer thread nor, through it, the log
//! or the run. Stopping the server detaches its connections instead of waiting for them.
//!
//! **Pace.** A simulation served live is held to the wall clock ([`Pace::WallClock`]) by the
//! log, on the caller's thread ([`runlog::tap`]); on a rig ([`Pace::AsRun`]) nothing is held.
//!
//! **Late clients.** The run-level records written once ([`LATCHED`]: metadata, truth,
//! estimator settings, tare) are kept, and a client subscribing to one of those channels
//! after it was written gets its latest message.

#![warn(missing_docs)]

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};

use anyhow::{Context as _, Result};
use foxglove::websocket::{ChannelView, Client, ServerListener};
use foxglove::{PartialMetadata, RawChannel, Schema, WebSocketServer, WebSocketServerHandle};

use runlog::channel::ChannelSpec;
use runlog::messages as topics;
pub use runlog::tap::{Pace, Tap};

/// `--live`'s address when none is given: loopback only, Foxglove's default port.
pub const DEFAULT_ADDR: &str = "127.0.0.1:8765";

/// Messages queued for one client before its oldest are dropped: about 1.8 s of a 1 kHz run's
/// log (about 580 messages a second, `/sensors` and `/commands` ten frames a message).
pub const BACKLOG_MESSAGES: usize = 1024;

/// Channels whose latest message a client gets when it subscribes: the records written once
/// per run, which a client connecting after the start would otherwise never see.
pub const LATCHED: [&str; 4] = [
    topics::METADATA,
    topics::TRUTH,
    topics::ESTIMATOR_SETTINGS,
    topics::TARE,
];

/// The latest message of each [`LATCHED`] channel: bytes and log time.
type Latest = Mutex<HashMap<&'static str, (Vec<u8>, u64)>>;

/// Replays the latched records to a client that subscribes to their channels.
struct Replay {
    latest: Arc<Latest>,
    channels: HashMap<String, Arc<RawChannel>>,
}

impl ServerListener for Replay {
    fn on_subscribe(&self, client: Client, channel: ChannelView) {
        let Some(raw) = self.channels.get(channel.topic()) else {
            return;
        };
        let latest = self.latest.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((bytes, log_time)) = latest.get(channel.topic()) {
            raw.log_with_meta_to_sink(
                bytes,
                PartialMetadata::with_log_time(*log_time),
                client.sink_id(),
            );
        }
    }
}

/// The live view of `--live ADDR`: a server with the log's catalogue bound to `addr`, or
/// `None` without the flag. Called before the log is created, so that a refused address
/// leaves no log behind.
pub fn serve(addr: Option<SocketAddr>, pace: Pace) -> Result<Option<LiveServer>> {
    addr.map(|a| {
        let mut server = LiveServer::start(a, &runlog::messages::channels())?;
        server.pace = pace;
        Ok(server)
    })
    .transpose()
}

/// A Foxglove WebSocket server with every channel of the log. See the [module docs](self).
pub struct LiveServer {
    handle: Option<WebSocketServerHandle>,
    addr: SocketAddr,
    channels: HashMap<&'static str, Arc<RawChannel>>,
    latest: Arc<Latest>,
    pace: Pace,
    /// The channels' and the server's context: they hold it weakly, so it lives here.
    _context: Arc<foxglove::Context>,
}

impl LiveServer {
    /// Binds `addr` and serves `specs` (the log's catalogue, [`runlog::messages::channels`]).
    /// Errors: the address cannot be bound (taken, not local, no permission), a channel's
    /// schema does not build.
    pub fn start(addr: SocketAddr, specs: &[ChannelSpec]) -> Result<Self> {
        let context = foxglove::Context::new();
        let mut channels = HashMap::new();
        for spec in specs {
            let schema = Schema::new(
                spec.schema_name,
                spec.encoding.schema_encoding(),
                spec.schema_data()?,
            );
            let channel = context
                .channel_builder(spec.topic)
                .message_encoding(spec.encoding.message_encoding())
                .schema(schema)
                .build_raw()
                .with_context(|| format!("cannot serve the channel {} live", spec.topic))?;
            channels.insert(spec.topic, channel);
        }
        let latest = Arc::new(Latest::default());
        let replay = Replay {
            latest: Arc::clone(&latest),
            channels: channels
                .iter()
                .filter(|(topic, _)| LATCHED.contains(topic))
                .map(|(topic, c)| ((*topic).to_string(), Arc::clone(c)))
                .collect(),
        };
        // An IPv6 host is bracketed: the SDK binds "host:port".
        let host = match addr {
            SocketAddr::V4(a) => a.ip().to_string(),
            SocketAddr::V6(a) => format!("[{}]", a.ip()),
        };
        let handle = WebSocketServer::new()
            .name(concat!("stewart ", env!("CARGO_PKG_VERSION")))
            .bind(host, addr.port())
            .context(&context)
            .message_backlog_size(BACKLOG_MESSAGES)
            .listener(Arc::new(replay))
            .start_blocking()
            .map_err(|e| match e {
                foxglove::FoxgloveError::Bind(io) => anyhow::anyhow!(
                    "cannot serve the live view on {addr}: {io} (another program, or another \
                     run's --live, may hold the port: give another with --live IP:PORT)"
                ),
                other => anyhow::anyhow!("cannot serve the live view on {addr}: {other}"),
            })?;
        let addr = SocketAddr::new(addr.ip(), handle.port());
        Ok(Self {
            handle: Some(handle),
            addr,
            channels,
            latest,
            pace: Pace::AsRun,
            _context: context,
        })
    }

    /// The address served (with the port the system chose when `start` was given port 0).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// How the log that serves this view keeps time ([`serve`]'s `pace`).
    pub fn pace(&self) -> Pace {
        self.pace
    }

    /// The server as the tap a log is created with ([`runlog::RunLog::create_tapped`]).
    pub fn into_tap(self) -> Box<dyn Tap> {
        Box::new(self)
    }

    /// Clients connected now.
    pub fn client_count(&self) -> usize {
        self.handle.as_ref().map_or(0, |h| h.client_count())
    }

    /// Sends `bytes` (one message in its channel's encoding) on `topic` at `log_time_ns` to the
    /// clients subscribed to it; an unknown topic is ignored (the log refuses it). Never waits
    /// for a client (nor for the wall clock: see [`Pace::hold`]). The log calls it on its
    /// writer thread, as [`Tap::message`] (see the [module docs](self)); it allocates.
    pub fn log(&self, topic: &str, bytes: &[u8], log_time_ns: u64) {
        let Some((&topic, channel)) = self.channels.get_key_value(topic) else {
            return;
        };
        if LATCHED.contains(&topic) {
            let mut latest = self.latest.lock().unwrap_or_else(|p| p.into_inner());
            latest.insert(topic, (bytes.to_vec(), log_time_ns));
        }
        channel.log_with_meta(bytes, PartialMetadata::with_log_time(log_time_ns));
    }
}

impl Tap for LiveServer {
    fn message(&self, topic: &'static str, bytes: &[u8], log_time_ns: u64) {
        self.log(topic, bytes, log_time_ns);
    }

    fn pace(&self) -> Pace {
        self.pace
    }
}

impl Drop for LiveServer {
    fn drop(&mut self) {
        if let Some(handle) = self.handle.take() {
            // Each client gets its close frame in the background; a stalled client does not
            // hold the run's end.
            handle.stop().detach_all();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_taken_port_is_refused_with_the_address() {
        let specs = runlog::messages::channels();
        let first = LiveServer::start("127.0.0.1:0".parse().unwrap(), &specs).unwrap();
        assert_ne!(first.addr().port(), 0);
        let err = LiveServer::start(first.addr(), &specs)
            .err()
            .expect("a second server on the same port is refused");
        let text = format!("{err:#}");
        assert!(text.contains(&first.addr().to_string()), "{text}");
        assert!(text.contains("--live"), "{text}");
    }

    #[test]
    fn logging_without_clients_returns_and_latches_the_run_records() {
        let specs = runlog::messages::channels();
        let server = LiveServer::start("127.0.0.1:0".parse().unwrap(), &specs).unwrap();
        assert_eq!(server.client_count(), 0);
        server.log(topics::METADATA, b"{}", 5);
        server.log(topics::ESTIMATE, b"{}", 6);
        server.log("/not/a/channel", b"{}", 7);
        let latest = server.latest.lock().unwrap();
        assert_eq!(latest.get(topics::METADATA), Some(&(b"{}".to_vec(), 5)));
        assert!(!latest.contains_key(topics::ESTIMATE));
    }
}
