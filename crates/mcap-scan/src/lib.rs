//! A damage-tolerant MCAP reader: it walks a log record by record from any `Read + Seek` source,
//! and a record it cannot trust costs that record, never the file or the process.
//!
//! The rules (MCAP format: <https://mcap.dev/spec>):
//! - **No length from the file is trusted.** A record's length must fit in what the file still
//!   holds, every record the reader decodes must consume its length exactly, and a chunk's
//!   decompressed size is bounded by the size its header declares, itself capped at
//!   [`MAX_CHUNK_BYTES`]. So no allocation exceeds what the file can hold, or that cap.
//! - **Chunks are checked**: the record must be exactly its header plus its compressed bytes,
//!   the decompressed size must be the declared one, and a non-zero `uncompressed_crc` must be
//!   the CRC-32 of the decompressed records.
//! - **A damaged record is skipped and reading resumes** at the next valid chunk record, found
//!   from the summary's chunk index when the footer is intact, else by scanning the bytes for a
//!   record that passes every check above.
//! - **What was lost is said**: each skipped region is a [`Gap`] (where, how many bytes, why,
//!   and the log times of the last message before it and the first after it). A file that does
//!   not end with the MCAP magic was cut short, and [`ScanEnd::truncated`] says where.
//!
//! Schemas and channels are taken from the data section as met, and from the summary section
//! when the footer is intact, so a damaged chunk that held a channel's definition loses only
//! that chunk's messages.

#![warn(missing_docs)]

use std::collections::HashMap;
use std::io::{Read, Seek, SeekFrom};
use std::sync::Arc;

use anyhow::{bail, Context, Result};

/// The MCAP magic that starts and ends a log.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

/// Largest decompressed chunk accepted, bytes: far above the writer's 512 KiB chunks, and a
/// bound on what one damaged size field can make the reader allocate.
pub const MAX_CHUNK_BYTES: u64 = 256 << 20;

/// Largest summary section read, bytes (a one-hour 1 kHz log's is about 2 MB).
const MAX_SUMMARY_BYTES: u64 = 64 << 20;

/// Bytes scanned at a time while looking for the next valid chunk.
const SCAN_WINDOW: usize = 1 << 20;

mod op {
    pub const HEADER: u8 = 0x01;
    pub const FOOTER: u8 = 0x02;
    pub const SCHEMA: u8 = 0x03;
    pub const CHANNEL: u8 = 0x04;
    pub const MESSAGE: u8 = 0x05;
    pub const CHUNK: u8 = 0x06;
    pub const MESSAGE_INDEX: u8 = 0x07;
    pub const CHUNK_INDEX: u8 = 0x08;
    pub const ATTACHMENT: u8 = 0x09;
    pub const ATTACHMENT_INDEX: u8 = 0x0A;
    pub const STATISTICS: u8 = 0x0B;
    pub const METADATA: u8 = 0x0C;
    pub const METADATA_INDEX: u8 = 0x0D;
    pub const SUMMARY_OFFSET: u8 = 0x0E;
    pub const DATA_END: u8 = 0x0F;
}

/// A channel as its Channel and Schema records define it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ChannelDef {
    /// Channel id.
    pub id: u16,
    /// Topic.
    pub topic: String,
    /// Message encoding (`json` or `protobuf`).
    pub message_encoding: String,
    /// Schema name (empty without a schema).
    pub schema_name: String,
    /// Schema encoding (`jsonschema` or `protobuf`).
    pub schema_encoding: String,
    /// The schema document's text (a binary protobuf descriptor set, read lossily as UTF-8).
    pub schema_text: String,
}

/// One message read.
#[derive(Clone, Copy, Debug)]
pub struct Message<'a> {
    /// Its channel.
    pub channel: &'a ChannelDef,
    /// The writer's sequence number.
    pub sequence: u32,
    /// Log time, ns.
    pub log_time_ns: u64,
    /// The message's bytes.
    pub data: &'a [u8],
}

/// A region of the file that was skipped, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Gap {
    /// Byte offset where the skipped region starts.
    pub offset: u64,
    /// Bytes skipped.
    pub bytes: u64,
    /// What was wrong with it.
    pub reason: String,
    /// Log time of the last message read before it, ns.
    pub after_ns: Option<u64>,
    /// Log time of the first message read after it, ns (`None`: none followed).
    pub before_ns: Option<u64>,
    /// Messages skipped one by one (a chunk whose records are intact, on a channel never
    /// defined), when the gap is such messages rather than a region of bytes.
    pub messages: u64,
}

/// What the reader hands its caller, in file order.
#[derive(Debug)]
pub enum Event<'a> {
    /// A message.
    Message(Message<'a>),
    /// A region skipped (its `before_ns` is filled in [`ScanEnd::gaps`]).
    Gap(&'a Gap),
}

/// How the reading ended.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ScanEnd {
    /// Why the file ends before its footer (cut short), if it does.
    pub truncated: Option<String>,
    /// Every skipped region, in file order.
    pub gaps: Vec<Gap>,
    /// Every channel defined, by id.
    pub channels: Vec<ChannelDef>,
}

/// A little-endian cursor that refuses to read past its end.
struct Cur<'a> {
    b: &'a [u8],
    pos: usize,
}

impl<'a> Cur<'a> {
    fn new(b: &'a [u8]) -> Self {
        Self { b, pos: 0 }
    }
    fn bytes(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.pos.checked_add(n)?;
        let s = self.b.get(self.pos..end)?;
        self.pos = end;
        Some(s)
    }
    fn u8(&mut self) -> Option<u8> {
        Some(self.bytes(1)?[0])
    }
    fn u16(&mut self) -> Option<u16> {
        Some(u16::from_le_bytes(self.bytes(2)?.try_into().ok()?))
    }
    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.bytes(4)?.try_into().ok()?))
    }
    fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.bytes(8)?.try_into().ok()?))
    }
    fn string(&mut self) -> Option<&'a str> {
        let n = self.u32()? as usize;
        std::str::from_utf8(self.bytes(n)?).ok()
    }
    /// A u32-prefixed byte array.
    fn prefixed(&mut self) -> Option<&'a [u8]> {
        let n = self.u32()? as usize;
        self.bytes(n)
    }
    fn rest(&mut self) -> &'a [u8] {
        let s = self.b.get(self.pos..).unwrap_or_default();
        self.pos = self.b.len();
        s
    }
    fn done(&self) -> bool {
        self.pos == self.b.len()
    }
}

/// A chunk's header, checked against the record's length.
struct ChunkHeader<'a> {
    uncompressed_size: u64,
    uncompressed_crc: u32,
    compression: &'a str,
    /// Bytes of the header, from the record's body start to the compressed records.
    header_len: usize,
}

/// Parses a chunk header from the start of `body` (or as much of it as is given), checking that
/// the record of length `record_len` is exactly the header plus the compressed records.
fn chunk_header(body: &[u8], record_len: u64) -> Option<ChunkHeader<'_>> {
    let mut c = Cur::new(body);
    let _start = c.u64()?;
    let _end = c.u64()?;
    let uncompressed_size = c.u64()?;
    let uncompressed_crc = c.u32()?;
    let n = c.u32()? as usize;
    if n > 8 {
        return None;
    }
    let compression = std::str::from_utf8(c.bytes(n)?).ok()?;
    if !matches!(compression, "" | "zstd" | "lz4") {
        return None;
    }
    let compressed_size = c.u64()?;
    let header_len = c.pos;
    if (header_len as u64).checked_add(compressed_size)? != record_len
        || uncompressed_size > MAX_CHUNK_BYTES
    {
        return None;
    }
    Some(ChunkHeader {
        uncompressed_size,
        uncompressed_crc,
        compression,
        header_len,
    })
}

/// True when `body` is a well-formed record of opcode `op` outside a chunk that the reader
/// skips (each consumes its length exactly, so a damaged length is caught).
fn skippable(op: u8, body: &[u8]) -> bool {
    let mut c = Cur::new(body);
    let ok = match op {
        op::HEADER => c.string().and(c.string()).is_some(),
        op::MESSAGE_INDEX => c
            .u16()
            .and_then(|_| c.u32())
            .is_some_and(|n| n % 16 == 0 && c.bytes(n as usize).is_some()),
        op::METADATA => c.string().and_then(|_| map_bytes(&mut c)).is_some(),
        op::DATA_END => c.u32().is_some(),
        // Attachments (never written by the run logger) keep their own CRC; their length is
        // only checked against the file.
        op::ATTACHMENT => return true,
        _ => false,
    };
    ok && c.done()
}

/// A u32-byte-length map of strings, checked to consist of whole strings.
fn map_bytes<'a>(c: &mut Cur<'a>) -> Option<&'a [u8]> {
    let map = c.prefixed()?;
    let mut m = Cur::new(map);
    while !m.done() {
        m.string()?;
        m.string()?;
    }
    Some(map)
}

/// The schema records met, by id: (name, encoding, text).
type Schemas = HashMap<u16, (String, String, String)>;

/// Schema or Channel record: stored. False when malformed.
fn define(
    op: u8,
    body: &[u8],
    schemas: &mut Schemas,
    channels: &mut HashMap<u16, Arc<ChannelDef>>,
) -> bool {
    let mut c = Cur::new(body);
    match op {
        op::SCHEMA => {
            let parsed = (|| {
                let id = c.u16()?;
                let name = c.string()?;
                let encoding = c.string()?;
                let data = c.prefixed()?;
                Some((id, name, encoding, data))
            })();
            let Some((id, name, encoding, data)) = parsed.filter(|_| c.done()) else {
                return false;
            };
            schemas.entry(id).or_insert_with(|| {
                (
                    name.to_string(),
                    encoding.to_string(),
                    String::from_utf8_lossy(data).into_owned(),
                )
            });
            true
        }
        op::CHANNEL => {
            let parsed = (|| {
                let id = c.u16()?;
                let schema_id = c.u16()?;
                let topic = c.string()?;
                let encoding = c.string()?;
                map_bytes(&mut c)?;
                Some((id, schema_id, topic, encoding))
            })();
            let Some((id, schema_id, topic, encoding)) = parsed.filter(|_| c.done()) else {
                return false;
            };
            let (schema_name, schema_encoding, schema_text) =
                schemas.get(&schema_id).cloned().unwrap_or_default();
            channels.entry(id).or_insert_with(|| {
                Arc::new(ChannelDef {
                    id,
                    topic: topic.to_string(),
                    message_encoding: encoding.to_string(),
                    schema_name,
                    schema_encoding,
                    schema_text,
                })
            });
            true
        }
        _ => false,
    }
}

/// The reader's state over one source.
struct Scanner<R> {
    src: R,
    len: u64,
    schemas: Schemas,
    channels: HashMap<u16, Arc<ChannelDef>>,
    /// Start offsets of every chunk, from the summary's chunk index (empty without a footer).
    chunk_starts: Vec<u64>,
    /// End of the data section: the summary's start when the footer is intact, else the file's end.
    data_end: u64,
    gaps: Vec<Gap>,
    /// Gaps whose `before_ns` waits for the next message.
    open_gaps: usize,
    last_ns: Option<u64>,
    /// A record's body, reused.
    body: Vec<u8>,
    /// A chunk's decompressed records, reused.
    chunk: Vec<u8>,
}

impl<R: Read + Seek> Scanner<R> {
    fn read_at(&mut self, offset: u64, n: u64, into_chunk: bool) -> std::io::Result<()> {
        // `n` never exceeds what the file holds past `offset` (every caller checks): the
        // allocation is bounded by the file.
        let buf = if into_chunk {
            &mut self.chunk
        } else {
            &mut self.body
        };
        buf.clear();
        self.src.seek(SeekFrom::Start(offset))?;
        (&mut self.src).take(n).read_to_end(buf)?;
        if (buf.len() as u64) < n {
            return Err(std::io::ErrorKind::UnexpectedEof.into());
        }
        Ok(())
    }

    /// Opcode and length of the record at `pos`, when its length fits in the file.
    fn record_at(&mut self, pos: u64) -> Option<(u8, u64)> {
        if self.len.saturating_sub(pos) < 9 {
            return None;
        }
        self.read_at(pos, 9, false).ok()?;
        let mut c = Cur::new(&self.body);
        let (op, n) = (c.u8()?, c.u64()?);
        (n <= self.len - pos - 9).then_some((op, n))
    }

    fn gap(
        &mut self,
        offset: u64,
        bytes: u64,
        reason: String,
        on: &mut dyn FnMut(Event<'_>) -> Result<()>,
    ) -> Result<()> {
        self.gaps.push(Gap {
            offset,
            bytes,
            reason,
            after_ns: self.last_ns,
            before_ns: None,
            messages: 0,
        });
        self.open_gaps += 1;
        match self.gaps.last() {
            Some(g) => on(Event::Gap(g)),
            None => Ok(()),
        }
    }

    /// Reads the summary's schemas, channels and chunk index when the footer is intact.
    fn read_summary(&mut self) {
        if self.len < 8 + 8 + 9 + 20 + 8 {
            return;
        }
        let footer_at = self.len - 8 - 9 - 20;
        if self.read_at(footer_at, 9 + 20 + 8, false).is_err() {
            return;
        }
        let mut c = Cur::new(&self.body);
        let parsed = (|| {
            let (op, n) = (c.u8()?, c.u64()?);
            let start = c.u64()?;
            let _offsets = c.u64()?;
            let crc = c.u32()?;
            let magic = c.bytes(8)?;
            (op == op::FOOTER && n == 20 && magic == MAGIC).then_some((start, crc))
        })();
        let Some((start, crc)) = parsed else { return };
        if start == 0 || start < 8 || start > footer_at || footer_at - start > MAX_SUMMARY_BYTES {
            return;
        }
        // The CRC covers the summary and the footer up to its own CRC field.
        if self
            .read_at(start, footer_at + 9 + 16 - start, false)
            .is_err()
        {
            return;
        }
        if crc != 0 && crc32fast::hash(&self.body) != crc {
            return;
        }
        let summary = std::mem::take(&mut self.body);
        let records = &summary[..(footer_at - start) as usize];
        let mut c = Cur::new(records);
        let mut chunk_starts = Vec::new();
        while !c.done() {
            let Some((op, body)) = c
                .u8()
                .zip(c.u64())
                .and_then(|(op, n)| c.bytes(usize::try_from(n).ok()?).map(|b| (op, b)))
            else {
                break;
            };
            match op {
                op::SCHEMA | op::CHANNEL => {
                    define(op, body, &mut self.schemas, &mut self.channels);
                }
                op::CHUNK_INDEX => {
                    if let Some(at) = Cur::new(body)
                        .bytes(24)
                        .and_then(|b| Some(u64::from_le_bytes(b.get(16..24)?.try_into().ok()?)))
                    {
                        if at < start {
                            chunk_starts.push(at);
                        }
                    }
                }
                _ => {}
            }
        }
        chunk_starts.sort_unstable();
        self.chunk_starts = chunk_starts;
        self.data_end = start;
        self.body = summary;
    }

    /// Decompresses and checks the chunk whose body is in `self.body`; `Err` says what is wrong.
    fn unpack_chunk(&mut self, record_len: u64) -> std::result::Result<(), String> {
        let body = std::mem::take(&mut self.body);
        let result = (|| {
            let h =
                chunk_header(&body, record_len).ok_or("its header does not match its length")?;
            let compressed = body.get(h.header_len..).ok_or("its header is cut")?;
            let want = h.uncompressed_size;
            self.chunk.clear();
            let limit = want + 1;
            let read = match h.compression {
                "zstd" => zstd::stream::read::Decoder::with_buffer(compressed).and_then(|mut d| {
                    // The frame's declared window is allocated before anything is checked:
                    // bound it by the chunk's declared size (at least 4 MiB, the window of
                    // zstd's levels up to 12 on a stream of unknown size, as the writer's are;
                    // at most zstd's own default limit of 128 MiB).
                    let log2 = (64 - want.saturating_sub(1).leading_zeros()).clamp(22, 27);
                    d.window_log_max(log2)?;
                    d.take(limit).read_to_end(&mut self.chunk)
                }),
                "lz4" => lz4::Decoder::new(compressed)
                    .and_then(|d| d.take(limit).read_to_end(&mut self.chunk)),
                _ => compressed.take(limit).read_to_end(&mut self.chunk),
            };
            read.map_err(|e| format!("it does not decompress ({e})"))?;
            if self.chunk.len() as u64 != want {
                return Err(format!(
                    "it decompresses to {} bytes, not the {want} its header declares",
                    self.chunk.len()
                ));
            }
            if h.uncompressed_crc != 0 && crc32fast::hash(&self.chunk) != h.uncompressed_crc {
                return Err("its CRC does not match its contents".to_string());
            }
            Ok(())
        })();
        self.body = body;
        result
    }

    /// Hands the records of the decompressed chunk to `on`; the offset of a damaged record
    /// inside it, if one is.
    fn emit_chunk(
        &mut self,
        on: &mut dyn FnMut(Event<'_>) -> Result<()>,
    ) -> Result<Option<String>> {
        let chunk = std::mem::take(&mut self.chunk);
        let result = self.emit_records(&chunk, on);
        self.chunk = chunk;
        result
    }

    fn emit_records(
        &mut self,
        records: &[u8],
        on: &mut dyn FnMut(Event<'_>) -> Result<()>,
    ) -> Result<Option<String>> {
        let mut c = Cur::new(records);
        let mut unknown = 0u64;
        let mut damage = None;
        while !c.done() {
            let at = c.pos;
            let Some((op, body)) = c
                .u8()
                .zip(c.u64())
                .and_then(|(op, n)| c.bytes(usize::try_from(n).ok()?).map(|b| (op, b)))
            else {
                damage = Some(format!("a record at byte {at} of the chunk overruns it"));
                break;
            };
            match op {
                op::SCHEMA | op::CHANNEL => {
                    if !define(op, body, &mut self.schemas, &mut self.channels) {
                        damage = Some(format!("a malformed definition at byte {at} of the chunk"));
                        break;
                    }
                }
                op::MESSAGE => {
                    let mut m = Cur::new(body);
                    let Some((id, sequence, log_time_ns)) = (|| {
                        let id = m.u16()?;
                        let seq = m.u32()?;
                        let t = m.u64()?;
                        m.u64()?;
                        Some((id, seq, t))
                    })() else {
                        damage = Some(format!("a short message at byte {at} of the chunk"));
                        break;
                    };
                    let Some(channel) = self.channels.get(&id).cloned() else {
                        unknown += 1;
                        continue;
                    };
                    self.message(&channel, sequence, log_time_ns, m.rest(), on)?;
                }
                _ => {
                    damage = Some(format!(
                        "an unexpected record (opcode {op:#04x}) at byte {at} of the chunk"
                    ));
                    break;
                }
            }
        }
        if unknown > 0 {
            self.gaps.push(Gap {
                offset: 0,
                bytes: 0,
                reason: format!("{unknown} messages on channels whose definition was lost"),
                after_ns: self.last_ns,
                before_ns: None,
                messages: unknown,
            });
            self.open_gaps += 1;
        }
        Ok(damage)
    }

    fn message(
        &mut self,
        channel: &ChannelDef,
        sequence: u32,
        log_time_ns: u64,
        data: &[u8],
        on: &mut dyn FnMut(Event<'_>) -> Result<()>,
    ) -> Result<()> {
        let open = self.gaps.len() - self.open_gaps;
        for g in &mut self.gaps[open..] {
            g.before_ns = Some(log_time_ns);
        }
        self.open_gaps = 0;
        self.last_ns = Some(log_time_ns);
        on(Event::Message(Message {
            channel,
            sequence,
            log_time_ns,
            data,
        }))
    }

    /// Reads and checks the chunk record of length `n` at `pos`: Ok(true) when good.
    fn try_chunk(&mut self, pos: u64, n: u64) -> std::result::Result<(), String> {
        self.read_at(pos + 9, n, false)
            .map_err(|e| format!("it cannot be read ({e})"))?;
        self.unpack_chunk(n)
    }

    /// The next offset after `from` where a valid chunk record starts, or `None` up to the
    /// data section's end. With the summary's chunk index the next indexed chunk; else a scan.
    fn resync(&mut self, from: u64) -> Option<u64> {
        if !self.chunk_starts.is_empty() {
            let i = self.chunk_starts.partition_point(|&s| s < from);
            for k in i..self.chunk_starts.len() {
                let at = self.chunk_starts[k];
                if let Some((op::CHUNK, n)) = self.record_at(at) {
                    if self.try_chunk(at, n).is_ok() {
                        return Some(at);
                    }
                }
            }
            return None;
        }
        let mut window = Vec::new();
        let mut start = from;
        while start < self.data_end {
            let n = (self.data_end - start).min(SCAN_WINDOW as u64);
            window.clear();
            if self.src.seek(SeekFrom::Start(start)).is_err()
                || (&mut self.src).take(n).read_to_end(&mut window).is_err()
            {
                return None;
            }
            for i in memchr_all(op::CHUNK, &window) {
                let at = start + i as u64;
                let head = &window[i..];
                let Some(record_len) = head
                    .get(1..9)
                    .and_then(|b| b.try_into().ok())
                    .map(u64::from_le_bytes)
                else {
                    // Too near the window's end: read from here next.
                    if n == SCAN_WINDOW as u64 {
                        break;
                    }
                    continue;
                };
                if record_len > self.len.saturating_sub(at + 9) {
                    continue;
                }
                // The window overlaps the next by more than a chunk header, so a header cut by
                // this window's end is seen whole in the next.
                let plausible = head
                    .get(9..)
                    .is_some_and(|h| chunk_header(h, record_len).is_some());
                if plausible && self.try_chunk(at, record_len).is_ok() {
                    return Some(at);
                }
            }
            if start + (window.len() as u64) >= self.data_end || window.len() <= 64 {
                break;
            }
            // Overlap so a record header across the boundary is seen whole.
            start += (window.len() - 64) as u64;
        }
        None
    }

    fn run(&mut self, on: &mut dyn FnMut(Event<'_>) -> Result<()>) -> Result<ScanEnd> {
        let mut pos = 8u64;
        // A chunk already read and checked by `resync`, waiting to be emitted.
        let mut checked_chunk_at: Option<u64> = None;
        let mut truncated = None;
        let cut = {
            let mut tail = [0u8; 8];
            self.src.seek(SeekFrom::Start(self.len - 8))?;
            self.src.read_exact(&mut tail)?;
            &tail != MAGIC
        };
        while pos < self.data_end {
            let record = self.record_at(pos);
            let problem = match record {
                None if self.len - pos < 9 => Some("a record header is cut".to_string()),
                None => Some("a record's length runs past the end of the file".to_string()),
                Some((op::CHUNK, n)) => {
                    let checked = if checked_chunk_at == Some(pos) {
                        Ok(())
                    } else {
                        self.try_chunk(pos, n)
                    };
                    checked_chunk_at = None;
                    match checked {
                        Ok(()) => match self.emit_chunk(on)? {
                            None => {
                                pos += 9 + n;
                                continue;
                            }
                            Some(d) => {
                                // The rest of this chunk is lost; the next record is sound.
                                self.gap(pos, 9 + n, format!("a chunk without CRC holds {d}"), on)?;
                                pos += 9 + n;
                                continue;
                            }
                        },
                        Err(why) => Some(format!("a damaged chunk: {why}")),
                    }
                }
                Some((op::DATA_END, 4)) => break,
                Some((op @ (op::SCHEMA | op::CHANNEL), n)) => {
                    self.read_at(pos + 9, n, false)?;
                    let body = std::mem::take(&mut self.body);
                    let ok = define(op, &body, &mut self.schemas, &mut self.channels);
                    self.body = body;
                    if ok {
                        pos += 9 + n;
                        continue;
                    }
                    Some(format!("a malformed record (opcode {op:#04x})"))
                }
                Some((op::MESSAGE, n)) => {
                    self.read_at(pos + 9, n, false)?;
                    let body = std::mem::take(&mut self.body);
                    let result = self.emit_records_unchunked(&body, n, on);
                    self.body = body;
                    if result? {
                        pos += 9 + n;
                        continue;
                    }
                    Some("a malformed message record".to_string())
                }
                Some((
                    op::FOOTER
                    | op::CHUNK_INDEX
                    | op::ATTACHMENT_INDEX
                    | op::STATISTICS
                    | op::METADATA_INDEX
                    | op::SUMMARY_OFFSET,
                    _,
                )) if !cut && self.chunk_starts.is_empty() => {
                    // The summary of a whole file whose DataEnd or footer was lost: the data ended.
                    break;
                }
                Some((op, n)) => {
                    self.read_at(pos + 9, n, false)?;
                    if skippable(op, &self.body) {
                        pos += 9 + n;
                        continue;
                    }
                    Some(format!("a malformed or unknown record (opcode {op:#04x})"))
                }
            };
            let why = problem.unwrap_or_default();
            match self.resync(pos + 1) {
                Some(next) => {
                    self.gap(pos, next - pos, why, on)?;
                    checked_chunk_at = Some(next);
                    pos = next;
                }
                None if cut => {
                    truncated = Some(format!(
                        "the file ends at byte {} inside a record that starts at byte {pos} ({why})",
                        self.len
                    ));
                    self.gap(
                        pos,
                        self.len - pos,
                        "the file was cut short".to_string(),
                        on,
                    )?;
                    break;
                }
                None => {
                    self.gap(pos, self.data_end - pos, why, on)?;
                    break;
                }
            }
        }
        if cut && truncated.is_none() {
            truncated = Some(format!(
                "the file ends at byte {} without its summary and footer",
                self.len
            ));
        }
        let mut channels: Vec<ChannelDef> = self.channels.values().map(|c| (**c).clone()).collect();
        channels.sort_by_key(|c| c.id);
        Ok(ScanEnd {
            truncated,
            gaps: std::mem::take(&mut self.gaps),
            channels,
        })
    }

    /// A message record outside chunks (an unchunked log): true when well formed.
    fn emit_records_unchunked(
        &mut self,
        body: &[u8],
        n: u64,
        on: &mut dyn FnMut(Event<'_>) -> Result<()>,
    ) -> Result<bool> {
        let mut framed = Vec::with_capacity(body.len() + 9);
        framed.push(op::MESSAGE);
        framed.extend_from_slice(&n.to_le_bytes());
        framed.extend_from_slice(body);
        Ok(self.emit_records(&framed, on)?.is_none())
    }
}

/// Offsets of every `byte` in `hay`.
fn memchr_all(byte: u8, hay: &[u8]) -> impl Iterator<Item = usize> + '_ {
    hay.iter()
        .enumerate()
        .filter(move |&(_, &b)| b == byte)
        .map(|(i, _)| i)
}

/// Reads the MCAP log in `src` from start to end, handing every message and every skipped
/// region to `on` in file order. Errors: the source cannot be read, it is not an MCAP log (no
/// magic), or `on` failed. A damaged or cut log is not an error: see [`ScanEnd`].
pub fn scan<R: Read + Seek>(
    mut src: R,
    on: &mut dyn FnMut(Event<'_>) -> Result<()>,
) -> Result<ScanEnd> {
    let len = src
        .seek(SeekFrom::End(0))
        .context("cannot find the log's length")?;
    let mut magic = [0u8; 8];
    src.seek(SeekFrom::Start(0))?;
    if len < 8 || src.read_exact(&mut magic).is_err() || &magic != MAGIC {
        bail!("it does not start with the MCAP magic bytes");
    }
    let mut s = Scanner {
        src,
        len,
        schemas: HashMap::new(),
        channels: HashMap::new(),
        chunk_starts: Vec::new(),
        data_end: len,
        gaps: Vec::new(),
        open_gaps: 0,
        last_ns: None,
        body: Vec::new(),
        chunk: Vec::new(),
    };
    s.read_summary();
    s.run(on)
}
