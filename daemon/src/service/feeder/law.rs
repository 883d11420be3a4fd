//! Runs of motion-law moves: each chunk samples about a chunk's duration of the laws (see
//! [`crate::service::law_run`]) and takes the fastest stop along the move's line as its tail,
//! so a hold, a stop or an underrun works as for programs.

use super::Feeder;
use super::run::Motion;
use crate::interp::Chunk;
use crate::interp::coarse::{CoarseBuilder, CoarsePoint};

impl Feeder {
    /// Fills `chunk` with about one chunk of the laws (longer where no stop can follow);
    /// `false` when nothing is left.
    pub(super) fn fill_law_chunk(&mut self, chunk: &mut Chunk) -> bool {
        let (chunk_s, max_piece_s) = (self.chunk_s, 2.0 * self.cycle_s);
        let Some(run) = self.run.as_mut() else { return false };
        if matches!(&run.motion, Motion::Law { law, .. } if law.is_done()) {
            return false;
        }
        run.open_chunk(chunk);
        let Motion::Law { feed, law } = &mut run.motion else { return false };
        let mut want_s = chunk_s;
        let tail = loop {
            law.sample(want_s, max_piece_s, &self.max_jerk, &mut chunk.points);
            let end = *chunk.points.last().expect("points");
            if law.is_done() {
                break Vec::new();
            }
            // A law may run backwards for a while (overshooting laws); the path stop needs v ≥ 0.
            if end.v_mm_s >= 0.0 {
                if let Some(stop) = feed.stop_from(end.s_mm, end.v_mm_s, end.a_mm_s2, end.line) {
                    break stop;
                }
            }
            self.stats.tail_retries += 1;
            want_s = 0.25 * chunk_s;
        };
        let end = *chunk.points.last().expect("points");
        chunk.last = law.is_done();
        if !tail.is_empty() {
            chunk.tail.push(CoarsePoint { t_s: 0.0, ..end });
            let mut builder = CoarseBuilder::new(feed.path(), max_piece_s, &self.max_jerk);
            builder.build(&tail, 0.0, &mut chunk.tail);
            self.stats.max_coarse_error_mm = self.stats.max_coarse_error_mm.max(builder.max_error_mm);
        }
        run.close_chunk(end, tail);
        true
    }
}
