//! Runs of manual motion (jog, move-to) and the move back to the held point before a resumed
//! program: each chunk samples about a chunk of the OTG motion ([`crate::service::manual`]),
//! with every axis's fastest stop as its tail.

use super::Feeder;
use super::run::Motion;
use crate::interp::Chunk;
use crate::service::feeder::FeederReport;

impl Feeder {
    /// Fills `chunk` with the next stretch of the manual motion; `false` when nothing is left
    /// or planning failed.
    pub(super) fn fill_manual_chunk(&mut self, chunk: &mut Chunk) -> bool {
        let (chunk_s, cycle_s, max_piece_s) = (self.chunk_s, self.cycle_s, 2.0 * self.cycle_s);
        let Some(run) = self.run.as_mut() else { return false };
        run.open_chunk(chunk);
        let seq = run.seq;
        let part = match &mut run.motion {
            Motion::Manual(part) => part,
            Motion::Path(path) => match path.returning.as_mut() {
                Some(part) => part,
                None => return false,
            },
            Motion::Law { .. } => return false,
        };
        let filled = part.fill(seq, chunk_s, cycle_s, max_piece_s, &mut chunk.points, &mut chunk.tail);
        for (axis, limit) in part.take_limit_reports() {
            let _ = self.reports.send(FeederReport::JogLimit { axis, limit });
        }
        let last = match filled {
            Ok(last) => last,
            Err(e) => {
                self.manual_failed(&e);
                return false;
            }
        };
        let mut end = *chunk.points.last().expect("points");
        match &mut run.motion {
            Motion::Path(path) if last => {
                // Back on the path: the program continues from rest exactly at the held point,
                // and its queue fills to the program's depth from here.
                path.returning = None;
                run.reached_depth = false;
                let at = match path.feed.eval(run.s_start_mm) {
                    Ok((at, _)) => at,
                    Err(e) => {
                        self.failed(&e);
                        return false;
                    }
                };
                end.pos = at.pos;
                end.line = run.end.line;
                if let Some(p) = chunk.points.last_mut() {
                    *p = end;
                }
                chunk.last = false;
            }
            _ => chunk.last = last,
        }
        run.close_chunk(end, Vec::new());
        true
    }
}
