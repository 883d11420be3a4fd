//! The order of the messages in a recording: each stream in its own arrival order, the two
//! streams merged by log time (setpoints before feedback at equal times).
//!
//! Why not simply write what each drain of the subscriber queues returns: the feedback of a
//! cycle arrives a little after its setpoint, so where a drain happens to cut the streams would
//! decide the interleaving, and a replay recorded again would interleave differently. Holding
//! every message until the newest log time seen is [`REORDER_WINDOW_NS`] past it makes the
//! merge depend on the two streams' contents only: a replay of a recording, recorded again,
//! gives the same messages in the same order.

use super::schema::{Payload, Stream};
use std::collections::VecDeque;

/// How far (log time) a stream may lag behind the other and still be merged in order: 50
/// cycles at 4 ms. The plant answers a setpoint within a cycle or two, and a subscriber more
/// than 64 samples behind loses samples anyway.
pub const REORDER_WINDOW_NS: u64 = 200_000_000;
/// Most messages held at once: a publisher whose times do not advance must not make the
/// recorder grow without bound (then the oldest are written without waiting).
pub const MAX_PENDING: usize = 4096;

/// The merge of the two streams.
#[derive(Debug, Default)]
pub struct Interleave {
    /// Per stream (index `Stream as usize`), in arrival order.
    queues: [VecDeque<Payload>; 2],
    /// Newest log time received on any stream, ns.
    newest_ns: u64,
    /// Log time of the last message handed out, ns.
    written_ns: Option<u64>,
    /// Messages handed out with a log time before one already handed out (a stream lagged
    /// more than the window, or went back in time).
    pub out_of_order: u64,
}

fn log_ns(p: &Payload) -> u64 {
    p.mcap_times().0
}

impl Interleave {
    /// Takes a received message.
    pub fn push(&mut self, p: Payload) {
        self.newest_ns = self.newest_ns.max(log_ns(&p));
        self.queues[p.stream() as usize].push_back(p);
    }

    /// Moves to `out`, in merged order, every message the window has passed.
    pub fn pop_ready(&mut self, out: &mut Vec<Payload>) {
        self.pop(out, false);
    }

    /// Moves every held message to `out`, in merged order (at the end of a recording).
    pub fn pop_all(&mut self, out: &mut Vec<Payload>) {
        self.pop(out, true);
    }

    fn pop(&mut self, out: &mut Vec<Payload>, all: bool) {
        while let Some(i) = self.next_stream() {
            let held = self.queues[0].len() + self.queues[1].len();
            let head = log_ns(&self.queues[i][0]);
            let ready = all || head.saturating_add(REORDER_WINDOW_NS) <= self.newest_ns || held > MAX_PENDING;
            if !ready {
                break;
            }
            let Some(p) = self.queues[i].pop_front() else { break };
            if self.written_ns.is_some_and(|w| head < w) {
                self.out_of_order += 1;
            }
            self.written_ns = Some(self.written_ns.map_or(head, |w| w.max(head)));
            out.push(p);
        }
    }

    /// The stream whose head comes next: the older head; setpoints on a tie.
    fn next_stream(&self) -> Option<usize> {
        let sp = Stream::Setpoints as usize;
        let fb = Stream::Feedback as usize;
        match (self.queues[sp].front(), self.queues[fb].front()) {
            (None, None) => None,
            (Some(_), None) => Some(sp),
            (None, Some(_)) => Some(fb),
            (Some(a), Some(b)) => Some(if log_ns(a) <= log_ns(b) { sp } else { fb }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use interpd_protocol::shm::{Feedback, Setpoints};

    const MS: u64 = 1_000_000;

    fn sp(cycle: u64, t: u64) -> Payload {
        Payload::Setpoints(Setpoints { cycle, time_ns: t, ..Setpoints::default() })
    }

    fn fb(cycle: u64, t: u64) -> Payload {
        Payload::Feedback(Feedback { cycle, time_ns: t, ..Feedback::default() })
    }

    fn order(out: &[Payload]) -> Vec<(Stream, u64)> {
        out.iter().map(|p| (p.stream(), p.cycle())).collect()
    }

    /// A stream of `n` cycles at 4 ms, setpoint k and feedback k at the same time.
    fn cycles(n: u64) -> (Vec<Payload>, Vec<Payload>) {
        ((0..n).map(|k| sp(k, k * 4 * MS)).collect(), (0..n).map(|k| fb(k, k * 4 * MS)).collect())
    }

    /// Feeds the streams in batches: `lag` feedback samples behind the setpoints, `batch`
    /// setpoints per drain.
    fn record(sps: &[Payload], fbs: &[Payload], batch: usize, lag: usize) -> Vec<Payload> {
        let mut il = Interleave::default();
        let mut out = Vec::new();
        let (mut i, mut j) = (0, 0);
        while i < sps.len() || j < fbs.len() {
            let i_end = (i + batch).min(sps.len());
            il.push_all(&sps[i..i_end]);
            i = i_end;
            let j_end = i.saturating_sub(lag).max(j).min(fbs.len());
            let j_end = if i == sps.len() { fbs.len() } else { j_end };
            il.push_all(&fbs[j..j_end]);
            j = j_end;
            il.pop_ready(&mut out);
        }
        il.pop_all(&mut out);
        assert_eq!(il.out_of_order, 0);
        out
    }

    impl Interleave {
        fn push_all(&mut self, ps: &[Payload]) {
            for p in ps {
                self.push(*p);
            }
        }
    }

    #[test]
    fn the_order_does_not_depend_on_where_the_drains_cut_the_streams() {
        let (sps, fbs) = cycles(300);
        let reference = record(&sps, &fbs, 1, 0);
        let expected: Vec<(Stream, u64)> =
            (0..300).flat_map(|k| [(Stream::Setpoints, k), (Stream::Feedback, k)]).collect();
        assert_eq!(order(&reference), expected);
        for (batch, lag) in [(3, 1), (7, 5), (16, 2), (64, 30), (2, 40)] {
            assert_eq!(order(&record(&sps, &fbs, batch, lag)), expected, "batch {batch}, lag {lag}");
        }
    }

    #[test]
    fn each_stream_keeps_its_arrival_order() {
        // The second setpoint goes back in time (two publishers): it still follows the first.
        let mut il = Interleave::default();
        for p in [sp(1, 10), sp(2, 5), sp(3, 30), fb(1, 10), fb(2, 20)] {
            il.push(p);
        }
        let mut out = Vec::new();
        il.pop_all(&mut out);
        assert_eq!(
            order(&out),
            [
                (Stream::Setpoints, 1),
                (Stream::Setpoints, 2),
                (Stream::Feedback, 1),
                (Stream::Feedback, 2),
                (Stream::Setpoints, 3)
            ]
        );
        assert_eq!(il.out_of_order, 1, "setpoint 2 at 5 ns follows setpoint 1 at 10 ns");
    }

    #[test]
    fn messages_wait_for_the_window_and_a_late_stream_is_counted() {
        let mut il = Interleave::default();
        let mut out = Vec::new();
        il.push(sp(0, 10));
        il.push(sp(1, REORDER_WINDOW_NS + 9));
        il.pop_ready(&mut out);
        assert!(out.is_empty(), "nothing is a whole window old yet");
        il.push(sp(2, REORDER_WINDOW_NS + 10));
        il.pop_ready(&mut out);
        assert_eq!(order(&out), [(Stream::Setpoints, 0)]);
        // Feedback older than what was written: written at once, counted.
        il.push(fb(0, 5));
        il.pop_ready(&mut out);
        assert_eq!(order(&out)[1], (Stream::Feedback, 0));
        assert_eq!(il.out_of_order, 1);
    }

    #[test]
    fn times_that_never_advance_do_not_hold_more_than_the_bound() {
        let mut il = Interleave::default();
        let mut out = Vec::new();
        for k in 0..(MAX_PENDING as u64 + 10) {
            il.push(sp(k, 7));
            il.pop_ready(&mut out);
        }
        assert_eq!(out.len(), 10);
        assert_eq!(out[0].cycle(), 0);
    }
}
