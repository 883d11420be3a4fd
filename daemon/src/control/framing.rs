//! Splitting a byte stream into lines without ever holding more than one line (plus one read
//! chunk) in memory, whatever the peer sends.

use std::io::{self, Read};

/// Bytes asked of the socket per read.
const CHUNK: usize = 16 * 1024;

/// What [`LineReader::next_line`] found.
#[derive(Debug, PartialEq, Eq)]
pub enum Frame {
    /// One line without its `\n` (and without a `\r` before it).
    Line(Vec<u8>),
    /// The peer closed the stream after a complete line (or before sending anything).
    Eof,
    /// The peer closed the stream in the middle of a line; these are the bytes after the last
    /// `\n`. A proper prefix of a JSON object is never itself a complete JSON object, so a
    /// request cut off here can never be mistaken for a different, valid one.
    EofMidLine(Vec<u8>),
    /// The current line exceeds the limit; the reader must not be used further.
    TooLong,
}

/// A line reader with a hard limit on the line length.
pub struct LineReader<R> {
    inner: R,
    limit: usize,
    /// Received, not yet returned bytes are `buf[start..]`.
    buf: Vec<u8>,
    start: usize,
    /// `buf[start..scanned]` is known to hold no `\n`, so no byte is searched twice.
    scanned: usize,
}

impl<R: Read> LineReader<R> {
    /// `limit`: the longest line accepted, without its `\n` and an optional `\r`.
    pub fn new(inner: R, limit: usize) -> LineReader<R> {
        LineReader { inner, limit, buf: Vec::new(), start: 0, scanned: 0 }
    }

    pub fn next_line(&mut self) -> io::Result<Frame> {
        let mut chunk = [0u8; CHUNK];
        loop {
            if let Some(pos) = self.buf[self.scanned..].iter().position(|&b| b == b'\n') {
                let end = self.scanned + pos;
                let mut line = &self.buf[self.start..end];
                if let [rest @ .., b'\r'] = line {
                    line = rest;
                }
                if line.len() > self.limit {
                    return Ok(Frame::TooLong);
                }
                let line = line.to_vec();
                self.start = end + 1;
                self.scanned = self.start;
                return Ok(Frame::Line(line));
            }
            self.scanned = self.buf.len();
            let pending = self.buf.len() - self.start;
            // Room for the limit, a `\r` and the `\n` still to come: anything beyond cannot
            // end in an acceptable line.
            if pending > self.limit + 1 {
                return Ok(Frame::TooLong);
            }
            // Drop the returned lines before reading more, so the buffer holds one partial
            // line plus at most one chunk.
            if self.start > 0 {
                self.buf.drain(..self.start);
                self.scanned -= self.start;
                self.start = 0;
            }
            // After a long line, give the memory back rather than keep 1 MiB per idle client.
            if self.buf.capacity() > 4 * CHUNK && self.buf.len() < CHUNK {
                self.buf.shrink_to(2 * CHUNK);
            }
            let n = loop {
                match self.inner.read(&mut chunk) {
                    Ok(n) => break n,
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                    Err(e) => return Err(e),
                }
            };
            if n == 0 {
                let rest = std::mem::take(&mut self.buf);
                self.start = 0;
                self.scanned = 0;
                return Ok(if rest.is_empty() { Frame::Eof } else { Frame::EofMidLine(rest) });
            }
            self.buf.extend_from_slice(&chunk[..n]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hands out its data in reads of at most `step` bytes, like a socket would.
    struct Trickle {
        data: Vec<u8>,
        pos: usize,
        step: usize,
    }

    impl Read for Trickle {
        fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
            let n = self.step.min(out.len()).min(self.data.len() - self.pos);
            out[..n].copy_from_slice(&self.data[self.pos..self.pos + n]);
            self.pos += n;
            Ok(n)
        }
    }

    fn reader(data: &[u8], step: usize, limit: usize) -> LineReader<Trickle> {
        LineReader::new(Trickle { data: data.to_vec(), pos: 0, step }, limit)
    }

    #[test]
    fn splits_lines_across_reads() {
        for step in [1, 2, 3, 7, 100_000] {
            let mut r = reader(b"ab\r\n\ncd\nef", step, 10);
            assert_eq!(r.next_line().expect("read"), Frame::Line(b"ab".to_vec()));
            assert_eq!(r.next_line().expect("read"), Frame::Line(b"".to_vec()));
            assert_eq!(r.next_line().expect("read"), Frame::Line(b"cd".to_vec()));
            assert_eq!(r.next_line().expect("read"), Frame::EofMidLine(b"ef".to_vec()));
            assert_eq!(r.next_line().expect("read"), Frame::Eof);
        }
    }

    #[test]
    fn limit_is_exact() {
        let limit = 40_000;
        for step in [1000, CHUNK, 100_000] {
            let mut data = vec![b'x'; limit];
            data.extend_from_slice(b"\r\n");
            data.extend(vec![b'y'; limit]);
            data.push(b'\n');
            let mut r = reader(&data, step, limit);
            assert_eq!(r.next_line().expect("read"), Frame::Line(vec![b'x'; limit]));
            assert_eq!(r.next_line().expect("read"), Frame::Line(vec![b'y'; limit]));
            assert_eq!(r.next_line().expect("read"), Frame::Eof);

            let mut data = vec![b'x'; limit + 1];
            data.push(b'\n');
            assert_eq!(reader(&data, step, limit).next_line().expect("read"), Frame::TooLong);
        }
    }

    #[test]
    fn memory_stays_bounded_without_newlines() {
        // 100 MB without a newline: the reader gives up after the limit plus one chunk.
        struct Endless(usize);
        impl Read for Endless {
            fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
                self.0 += out.len();
                out.fill(b'a');
                Ok(out.len())
            }
        }
        let mut r = LineReader::new(Endless(0), 1000);
        assert_eq!(r.next_line().expect("read"), Frame::TooLong);
        assert!(r.inner.0 <= 1000 + 2 * CHUNK, "read {} bytes", r.inner.0);
        assert!(r.buf.capacity() <= 4 * CHUNK);
    }
}
