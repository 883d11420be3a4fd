//! `interpd run --candump FILE`: the bus traffic in the `candump -l` format, written by the CAN
//! receive thread (never in the real-time cycle). The receive socket gets the master's own
//! RPDO1/SYNC frames through the kernel's local loopback, so the log holds the whole bus in the
//! order the kernel delivered it, with the kernel's receive timestamps, as `candump -l` would.

use interpd_protocol::candump::{Iface, Timestamp, Writer};
use interpd_protocol::cia301::Frame;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// The log is flushed at least this often, so a killed daemon leaves all but the last moments.
const FLUSH_EVERY: Duration = Duration::from_millis(200);
/// Write errors logged individually; later ones are only counted.
const LOGGED_ERRORS: u64 = 3;

/// An open candump log.
pub struct CandumpLog {
    path: PathBuf,
    writer: Writer<BufWriter<File>>,
    iface: Iface,
    last_flush: Instant,
    pub records: u64,
    pub errors: u64,
}

impl CandumpLog {
    /// Creates (truncates) `path`; the error names the file.
    pub fn create(path: &Path, iface: &str) -> Result<Self, String> {
        let iface =
            Iface::new(iface).ok_or_else(|| format!("interface name {iface:?} cannot appear in a candump log"))?;
        let file = File::create(path).map_err(|e| format!("--candump {}: cannot create: {e}", path.display()))?;
        Ok(Self {
            path: path.to_path_buf(),
            writer: Writer::new(BufWriter::with_capacity(64 * 1024, file)),
            iface,
            last_flush: Instant::now(),
            records: 0,
            errors: 0,
        })
    }

    /// Appends one frame received at `time` (CLOCK_REALTIME, as candump logs it).
    pub fn record(&mut self, time: SystemTime, frame: &Frame) {
        let since = time.duration_since(UNIX_EPOCH).unwrap_or_default();
        let stamp = Timestamp::from_duration(since).unwrap_or_default();
        match self.writer.write_frame(stamp, &self.iface, frame) {
            Ok(()) => self.records += 1,
            Err(e) => self.error("write", &e),
        }
    }

    /// Flushes when [`FLUSH_EVERY`] has passed since the last flush.
    pub fn flush_if_due(&mut self) {
        if self.last_flush.elapsed() >= FLUSH_EVERY {
            self.flush();
        }
    }

    pub fn flush(&mut self) {
        self.last_flush = Instant::now();
        if let Err(e) = self.writer.flush() {
            self.error("flush", &e);
        }
    }

    fn error(&mut self, what: &str, e: &std::io::Error) {
        self.errors += 1;
        if self.errors <= LOGGED_ERRORS {
            tracing::error!("candump log {}: {what} failed: {e} (the machine keeps running)", self.path.display());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use interpd_protocol::candump;

    #[test]
    fn writes_candump_lines_that_read_back() {
        let dir = std::env::temp_dir().join(format!("interpd-canlog-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("bus.log");
        let mut log = CandumpLog::create(&path, "vcan0").unwrap();
        let t = UNIX_EPOCH + Duration::from_micros(1_700_000_000_123_456);
        log.record(t, &Frame::standard(0x201, &[0x0F, 0, 0x10, 0x27, 0, 0]).unwrap());
        log.record(t + Duration::from_micros(4), &Frame::standard(0x080, &[]).unwrap());
        log.flush();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text, "(1700000000.123456) vcan0 201#0F0010270000\n(1700000000.123460) vcan0 080#\n");
        let back = candump::parse_log(&text).unwrap();
        assert_eq!(candump::format_log(&back), text);
        assert_eq!(log.records, 2);
        let Err(e) = CandumpLog::create(&dir.join("no/such/dir.log"), "vcan0") else { panic!("created") };
        assert!(e.contains("cannot create"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
