//! The MCAP file: writing recorded payloads ([`RecordFile`]) and reading them back validated
//! ([`read_messages`]).
//!
//! One channel per stream, topic `<prefix>/<service>` (the iceoryx2 service name), schema
//! [`schema::SETPOINTS`] / [`schema::FEEDBACK`]; a metadata record `interpd.recording` says
//! what was recorded. Chunks are zstd-compressed and small, so a crash loses little.

use super::RecordError;
use super::schema::{self, MESSAGE_ENCODING, Payload, SCHEMA_ENCODING, Stream};
use mcap::records::{MessageHeader, Metadata};
use mcap::sans_io::LinearReaderOptions;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::{Path, PathBuf};

/// Uncompressed chunk size: about 0.4 s of setpoints and feedback at 4 ms, the most a crash of
/// the recording process can lose.
pub const CHUNK_BYTES: u64 = 64 * 1024;
/// Name of the metadata record describing the recording.
pub const METADATA_NAME: &str = "interpd.recording";
/// Largest MCAP record a reader accepts (ours are ≤ [`CHUNK_BYTES`] plus a little): a corrupted
/// length field must not make the reader allocate gigabytes.
pub const MAX_RECORD_BYTES: usize = 64 * 1024 * 1024;

/// An MCAP file being written.
pub struct RecordFile {
    path: PathBuf,
    writer: mcap::Writer<BufWriter<File>>,
    channels: BTreeMap<StreamKey, u16>,
    sequence: u32,
    scratch: Vec<u8>,
}

type StreamKey = u8;

fn key(stream: Stream) -> StreamKey {
    stream as u8
}

impl RecordFile {
    /// Creates (truncates) `path` and writes the MCAP header.
    pub fn create(path: &Path) -> Result<RecordFile, RecordError> {
        let file = File::create(path)
            .map_err(|e| RecordError::Open { path: path.to_path_buf(), message: format!("cannot create: {e}") })?;
        let options = mcap::WriteOptions::new()
            .profile("")
            .library(format!("interpd/{} {}", env!("CARGO_PKG_VERSION"), mcap::LIBRARY_IDENTIFIER))
            .chunk_size(Some(CHUNK_BYTES))
            // Compress in the recording thread: no worker threads competing with the real-time one.
            .compression_threads(0);
        let writer = options
            .create(BufWriter::new(file))
            .map_err(|e| RecordError::Open { path: path.to_path_buf(), message: e.to_string() })?;
        Ok(RecordFile { path: path.to_path_buf(), writer, channels: BTreeMap::new(), sequence: 0, scratch: Vec::new() })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Adds the schemas and the channels `<prefix>/setpoints` and `<prefix>/feedback`, and the
    /// metadata record (`prefix`, payload version and `extra` entries).
    pub fn begin(&mut self, prefix: &str, extra: &BTreeMap<String, String>) -> Result<(), RecordError> {
        for stream in Stream::ALL {
            let s = stream.schema();
            let schema_id =
                self.writer.add_schema(s.name, SCHEMA_ENCODING, s.idl().as_bytes()).map_err(self.write_err())?;
            let topic = format!("{prefix}/{}", s.service);
            let meta = BTreeMap::from([("service".to_string(), topic.clone())]);
            let id = self.writer.add_channel(schema_id, &topic, MESSAGE_ENCODING, &meta).map_err(self.write_err())?;
            self.channels.insert(key(stream), id);
        }
        let mut metadata = BTreeMap::from([
            ("service_prefix".to_string(), prefix.to_string()),
            ("payload_version".to_string(), interpd_protocol::shm::PAYLOAD_VERSION.to_string()),
            ("recorder".to_string(), format!("interpd {}", env!("CARGO_PKG_VERSION"))),
        ]);
        metadata.extend(extra.iter().map(|(k, v)| (k.clone(), v.clone())));
        self.writer.write_metadata(&Metadata { name: METADATA_NAME.into(), metadata }).map_err(self.write_err())?;
        Ok(())
    }

    /// Writes one payload as a message of its stream's channel.
    pub fn write(&mut self, payload: &Payload) -> Result<(), RecordError> {
        let channel_id = *self
            .channels
            .get(&key(payload.stream()))
            .ok_or_else(|| RecordError::Write { path: self.path.clone(), message: "write before begin()".into() })?;
        let (log_time, publish_time) = payload.mcap_times();
        self.scratch.clear();
        schema::encode(payload.as_bytes(), &mut self.scratch);
        let header = MessageHeader { channel_id, sequence: self.sequence, log_time, publish_time };
        self.sequence = self.sequence.wrapping_add(1);
        let (writer, data) = (&mut self.writer, &self.scratch);
        writer
            .write_to_known_channel(&header, data)
            .map_err(|e| RecordError::Write { path: self.path.clone(), message: with_causes(&e) })
    }

    /// Writes the summary and footer and flushes; returns the file size in bytes.
    pub fn finish(mut self) -> Result<u64, RecordError> {
        self.writer.finish().map_err(self.write_err())?;
        let out = self.writer.into_inner();
        let file =
            out.into_inner().map_err(|e| RecordError::Write { path: self.path.clone(), message: e.to_string() })?;
        file.sync_all().map_err(|e| RecordError::Write { path: self.path.clone(), message: e.to_string() })?;
        Ok(file.metadata().map(|m| m.len()).unwrap_or(0))
    }

    fn write_err(&self) -> impl Fn(mcap::McapError) -> RecordError + use<> {
        let path = self.path.clone();
        move |e| RecordError::Write { path: path.clone(), message: with_causes(&e) }
    }
}

/// An error with its causes, so that the system's reason ("File too large", "No space left on
/// device") reaches the message and not only the MCAP writer's summary of it.
fn with_causes(e: &dyn std::error::Error) -> String {
    let mut message = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let text = c.to_string();
        if !message.contains(&text) {
            message.push_str(": ");
            message.push_str(&text);
        }
        cause = c.source();
    }
    message
}

/// One validated message of a recording.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Recorded {
    /// 0-based position among the file's messages.
    pub index: u64,
    pub log_time_ns: u64,
    pub publish_time_ns: u64,
    pub payload: Payload,
}

/// Reads the messages of `path` in file order, validating each (MCAP structure and CRCs,
/// channel schema and encodings, payload size, header, version, finite values, times
/// consistent with the payload). The first error ends the iteration.
pub fn read_messages(path: &Path) -> Result<impl Iterator<Item = Result<Recorded, RecordError>>, RecordError> {
    let file = File::open(path)
        .map_err(|e| RecordError::Open { path: path.to_path_buf(), message: format!("cannot open: {e}") })?;
    let options = LinearReaderOptions::default()
        .with_prevalidate_chunk_crcs(true)
        .with_validate_data_section_crc(true)
        .with_validate_summary_section_crc(true)
        .with_check_finishes_after_end_magic(true)
        .with_record_length_limit(MAX_RECORD_BYTES);
    let reader = mcap::io::MessageReader::new_with_options(BufReader::new(file), options);
    let path = path.to_path_buf();
    let mut failed = false;
    let mut index = 0u64;
    Ok(reader.map_while(move |m| {
        if failed {
            return None;
        }
        let result = m
            .map_err(|e| RecordError::Corrupt { path: path.clone(), index, message: e.to_string() })
            .and_then(|m| check_message(&path, index, &m));
        failed = result.is_err();
        index += 1;
        Some(result)
    }))
}

fn check_message(path: &Path, index: u64, m: &mcap::Message<'_>) -> Result<Recorded, RecordError> {
    let bad = |message: String| RecordError::Message {
        path: path.to_path_buf(),
        index,
        topic: m.channel.topic.clone(),
        message,
    };
    let schema = m.channel.schema.as_ref().ok_or_else(|| bad("channel has no schema".into()))?;
    let stream = Stream::from_schema_name(&schema.name).ok_or_else(|| {
        bad(format!(
            "schema `{}` is not an interpd payload (expected interpd::Setpoints or interpd::Feedback)",
            schema.name
        ))
    })?;
    if schema.encoding != SCHEMA_ENCODING || m.channel.message_encoding != MESSAGE_ENCODING {
        return Err(bad(format!(
            "encodings schema `{}`/message `{}`, expected {SCHEMA_ENCODING}/{MESSAGE_ENCODING}",
            schema.encoding, m.channel.message_encoding
        )));
    }
    let payload = schema::decode(stream, &m.data).map_err(|e| bad(format!("{}: {e}", schema.name)))?;
    if payload.mcap_times() != (m.log_time, m.publish_time) {
        let (log, publish) = payload.mcap_times();
        return Err(bad(format!(
            "MCAP times log {} / publish {} ns differ from the payload's {log} / {publish} ns",
            m.log_time, m.publish_time
        )));
    }
    Ok(Recorded { index, log_time_ns: m.log_time, publish_time_ns: m.publish_time, payload })
}

/// The metadata record [`METADATA_NAME`] of a recording, if it has one (reads the whole file
/// linearly; for tests and tools, not for replay).
pub fn read_metadata(path: &Path) -> Result<Option<BTreeMap<String, String>>, RecordError> {
    let bytes =
        std::fs::read(path).map_err(|e| RecordError::Open { path: path.to_path_buf(), message: e.to_string() })?;
    let corrupt =
        |e: mcap::McapError| RecordError::Corrupt { path: path.to_path_buf(), index: 0, message: e.to_string() };
    for record in mcap::read::LinearReader::new(&bytes).map_err(corrupt)? {
        if let mcap::records::Record::Metadata(m) = record.map_err(corrupt)? {
            if m.name == METADATA_NAME {
                return Ok(Some(m.metadata));
            }
        }
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;
    use interpd_protocol::shm::{Feedback, Setpoints};

    fn temp(name: &str) -> PathBuf {
        std::env::temp_dir().join(format!("interpd-record-{}-{name}.mcap", std::process::id()))
    }

    fn sample_stream() -> Vec<Payload> {
        let mut out = Vec::new();
        for cycle in 0..300u64 {
            let t = 1_000_000_000 + cycle * 4_000_000;
            let mut sp = Setpoints { n_axes: 3, cycle, time_ns: t, publish_ns: t + 50_000, ..Setpoints::default() };
            sp.pos[0] = cycle as f64 * 0.01;
            sp.s_mm = cycle as f64 * 0.01;
            out.push(Payload::Setpoints(sp));
            let mut fb =
                Feedback { n_axes: 3, cycle, time_ns: t, setpoint_publish_ns: t + 50_000, ..Feedback::default() };
            fb.following_error[2] = -1e-6 * cycle as f64;
            out.push(Payload::Feedback(fb));
        }
        out
    }

    #[test]
    fn a_written_recording_reads_back_identically() {
        let path = temp("round-trip");
        let mut file = RecordFile::create(&path).expect("create");
        file.begin("test/rt", &BTreeMap::from([("axes".to_string(), "X Y Z".to_string())])).expect("begin");
        let stream = sample_stream();
        for p in &stream {
            file.write(p).expect("write");
        }
        let bytes = file.finish().expect("finish");
        assert!(bytes > 0);
        let back: Vec<Recorded> = read_messages(&path).expect("open").collect::<Result<_, _>>().expect("valid");
        assert_eq!(back.len(), stream.len());
        for (i, (r, p)) in back.iter().zip(&stream).enumerate() {
            assert_eq!(r.index, i as u64);
            assert_eq!(r.payload.as_bytes(), p.as_bytes(), "message {i}");
            assert_eq!((r.log_time_ns, r.publish_time_ns), p.mcap_times());
        }
        let meta = read_metadata(&path).expect("readable").expect("metadata record");
        assert_eq!(meta["service_prefix"], "test/rt");
        assert_eq!(meta["axes"], "X Y Z");
        let _ = std::fs::remove_file(&path);
    }

    #[test]
    fn a_truncated_recording_is_refused_with_the_message_index() {
        let path = temp("truncated");
        let mut file = RecordFile::create(&path).expect("create");
        file.begin("test/tr", &BTreeMap::new()).expect("begin");
        for p in &sample_stream() {
            file.write(p).expect("write");
        }
        file.finish().expect("finish");
        let bytes = std::fs::read(&path).expect("read");
        std::fs::write(&path, &bytes[..bytes.len() / 2]).expect("truncate");
        let results: Vec<_> = read_messages(&path).expect("open").collect();
        let err = results.last().expect("something").as_ref().expect_err("truncated");
        assert!(matches!(err, RecordError::Corrupt { .. }), "{err}");
        assert!(results[..results.len() - 1].iter().all(Result::is_ok));
        assert!(err.to_string().contains("at message"), "{err}");
        let _ = std::fs::remove_file(&path);
    }
}
