//! A Foxglove WebSocket client for the `--live` tests (`tests/live_view.rs`,
//! `tests/rig_live_view.rs`): it connects as the Foxglove app does (subprotocol
//! `foxglove.sdk.v1`), reads the server's messages with the SDK's own protocol parser, checks
//! every advertised channel against the log's catalogue, subscribes to the topics it is asked
//! for, and gives each message received with its topic and log time. Plus the checks both
//! tests make: a message is the log's, byte for byte, and `/tf` is the SDK's `FrameTransform`
//! of the plate over the base.

use std::collections::HashMap;
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::Path;
use std::time::{Duration, Instant};

use foxglove::ws_protocol::server::ServerMessage;
use tungstenite::client::IntoClientRequest;
use tungstenite::{Message, WebSocket};

/// The subprotocol the SDK's server speaks (the Foxglove app offers it).
pub const SUBPROTOCOL: &str = "foxglove.sdk.v1";

/// A loopback address (port chosen by the system) nobody listens on now.
pub fn free_port() -> SocketAddr {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    listener.local_addr().unwrap()
}

/// One message a subscription delivered.
#[derive(Clone, Debug)]
pub struct LiveMessage {
    pub topic: String,
    pub log_time: u64,
    pub data: Vec<u8>,
}

/// A client of the live view.
pub struct LiveClient {
    socket: WebSocket<TcpStream>,
    /// Topics subscribed to as they are advertised; `None`: every channel.
    wanted: Option<Vec<String>>,
    /// Channel id → topic, from the advertisements.
    pub advertised: HashMap<u64, String>,
    /// Subscription id → topic.
    pub subscribed: HashMap<u32, String>,
    /// The `serverInfo`'s name.
    pub server_name: Option<String>,
}

/// The HTTP status the live view at `addr` answers a WebSocket handshake offering only
/// `subprotocol` with (101: switched; 400: refused).
pub fn handshake_status(addr: SocketAddr, subprotocol: &str) -> u16 {
    let stream = TcpStream::connect(addr).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(20)))
        .unwrap();
    let mut request = format!("ws://{addr}").into_client_request().unwrap();
    request
        .headers_mut()
        .insert("Sec-WebSocket-Protocol", subprotocol.parse().unwrap());
    match tungstenite::client(request, stream) {
        Ok((_, response)) => response.status().as_u16(),
        Err(tungstenite::HandshakeError::Failure(tungstenite::Error::Http(response))) => {
            response.status().as_u16()
        }
        Err(e) => panic!("WebSocket handshake with {addr}: {e}"),
    }
}

impl LiveClient {
    /// Connects to the live view at `addr`, retrying until the run has bound it (panics at
    /// `deadline` or when `run` ended first); subscribes to `wanted` (every channel with
    /// `None`) as they are advertised. Reads time out after 20 s.
    pub fn connect<T>(
        addr: SocketAddr,
        deadline: Instant,
        run: &std::thread::JoinHandle<T>,
        wanted: Option<&[&str]>,
    ) -> Self {
        let socket = loop {
            if let Ok(stream) = TcpStream::connect(addr) {
                stream
                    .set_read_timeout(Some(Duration::from_secs(20)))
                    .unwrap();
                let mut request = format!("ws://{addr}").into_client_request().unwrap();
                request
                    .headers_mut()
                    .insert("Sec-WebSocket-Protocol", SUBPROTOCOL.parse().unwrap());
                let (socket, response) = tungstenite::client(request, stream)
                    .unwrap_or_else(|e| panic!("WebSocket handshake with {addr}: {e}"));
                assert_eq!(
                    response.headers()["sec-websocket-protocol"],
                    SUBPROTOCOL,
                    "the server's subprotocol"
                );
                break socket;
            }
            assert!(
                Instant::now() < deadline && !run.is_finished(),
                "nothing listens on {addr}"
            );
            std::thread::sleep(Duration::from_millis(5));
        };
        Self {
            socket,
            wanted: wanted.map(|w| w.iter().map(|t| t.to_string()).collect()),
            advertised: HashMap::new(),
            subscribed: HashMap::new(),
            server_name: None,
        }
    }

    /// Reads until the server's advertisement has been answered with the subscriptions.
    pub fn wait_subscribed(&mut self) {
        while self.subscribed.is_empty() {
            let message = self.read().expect("the server closed before advertising");
            if let Message::Text(text) = message {
                self.on_text(text.as_str());
            }
        }
    }

    /// The next message on a subscribed channel; the server's other messages are handled on
    /// the way. `None` once the server closed the connection (the run ended).
    pub fn next_message(&mut self) -> Option<LiveMessage> {
        loop {
            match self.read()? {
                Message::Text(text) => self.on_text(text.as_str()),
                Message::Binary(bytes) => {
                    if let ServerMessage::MessageData(m) =
                        ServerMessage::parse_binary(&bytes).unwrap()
                    {
                        let topic = self.subscribed[&m.subscription_id].clone();
                        return Some(LiveMessage {
                            topic,
                            log_time: m.log_time,
                            data: m.data.to_vec(),
                        });
                    }
                }
                _ => {}
            }
        }
    }

    /// The next frame, `None` when the connection is closed; panics on anything else (a read
    /// timeout: the server went silent).
    fn read(&mut self) -> Option<Message> {
        use tungstenite::Error;
        match self.socket.read() {
            Ok(Message::Close(_)) | Err(Error::ConnectionClosed | Error::AlreadyClosed) => None,
            Err(Error::Protocol(
                tungstenite::error::ProtocolError::ResetWithoutClosingHandshake,
            )) => None,
            Err(Error::Io(e))
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::ConnectionReset
                        | std::io::ErrorKind::ConnectionAborted
                        | std::io::ErrorKind::UnexpectedEof
                ) =>
            {
                None
            }
            Ok(m) => Some(m),
            Err(e) => panic!("reading the live view: {e}"),
        }
    }

    /// `serverInfo` and `advertise` (every channel must be the log's, with its schema name
    /// and encodings); the wanted channels are subscribed to.
    fn on_text(&mut self, text: &str) {
        let catalogue = runlog::messages::channels();
        match ServerMessage::parse_json(text).unwrap() {
            ServerMessage::ServerInfo(info) => self.server_name = Some(info.name.to_string()),
            ServerMessage::Advertise(a) => {
                let mut subscriptions = Vec::new();
                for c in &a.channels {
                    let spec = catalogue
                        .iter()
                        .find(|s| s.topic == c.topic)
                        .unwrap_or_else(|| panic!("{} is not a log channel", c.topic));
                    assert_eq!(c.schema_name, spec.schema_name, "{}", c.topic);
                    assert_eq!(c.encoding, spec.encoding.message_encoding(), "{}", c.topic);
                    assert_eq!(
                        c.schema_encoding.as_deref(),
                        Some(spec.encoding.schema_encoding()),
                        "{}",
                        c.topic
                    );
                    self.advertised.insert(c.id, c.topic.to_string());
                    let wanted = self
                        .wanted
                        .as_ref()
                        .is_none_or(|w| w.iter().any(|t| *t == c.topic));
                    if wanted {
                        let id = self.subscribed.len() as u32 + 1;
                        self.subscribed.insert(id, c.topic.to_string());
                        subscriptions.push(serde_json::json!({"id": id, "channelId": c.id}));
                    }
                }
                if !subscriptions.is_empty() {
                    let subscribe =
                        serde_json::json!({"op": "subscribe", "subscriptions": subscriptions});
                    self.socket
                        .send(Message::text(subscribe.to_string()))
                        .unwrap();
                }
            }
            _ => {}
        }
    }
}

/// Every message of the log at `path` as (topic, log time) → payloads.
pub fn log_payloads(path: &Path) -> HashMap<(String, u64), Vec<Vec<u8>>> {
    let bytes = std::fs::read(path).unwrap();
    let mut out: HashMap<(String, u64), Vec<Vec<u8>>> = HashMap::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        out.entry((m.channel.topic.clone(), m.log_time))
            .or_default()
            .push(m.data.to_vec());
    }
    out
}

/// Each message received is the log's message at the same log time, byte for byte.
pub fn assert_in_log(received: &[LiveMessage], log: &Path) {
    let in_log = log_payloads(log);
    for m in received {
        let same = in_log
            .get(&(m.topic.clone(), m.log_time))
            .is_some_and(|all| all.contains(&m.data));
        assert!(
            same,
            "{} at {} ns is not the log's message",
            m.topic, m.log_time
        );
    }
}

/// `/tf` decoded as the SDK's `FrameTransform`, checked: base → platform, a unit quaternion,
/// the plate above the base.
pub fn plate_transform(bytes: &[u8]) -> foxglove::messages::FrameTransform {
    let tf = <foxglove::messages::FrameTransform as prost::Message>::decode(bytes)
        .unwrap_or_else(|e| panic!("/tf is not a foxglove.FrameTransform: {e}"));
    assert_eq!(tf.parent_frame_id, runlog::foxglove::BASE_FRAME);
    assert_eq!(tf.child_frame_id, runlog::foxglove::PLATFORM_FRAME);
    let q = tf.rotation.expect("rotation");
    let norm = (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w).sqrt();
    assert!((norm - 1.0).abs() < 1e-9, "|q| = {norm}");
    let p = tf.translation.expect("translation");
    assert!(p.z > 0.5 && p.z < 5.0, "plate height {} m", p.z);
    assert!(tf.timestamp.is_some());
    tf
}
