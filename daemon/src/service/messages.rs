//! The operator messages of the running program between the look-ahead and the supervisor.
//!
//! The look-ahead thread reads a program ahead of the motion; the messages it reads wait here,
//! numbered in program order, until the real-time thread reports that the motion reached them
//! (`Notice::Message`) or the program ended (`Notice::Finished`). The real-time thread never
//! touches this queue: it reports numbers only. Bounded: when [`CAP`] messages wait (a loop
//! that writes messages far faster than the motion moves), the newest replaces the last one
//! waiting and is counted as dropped ([`MessageQueue`]), so memory stays fixed and the first
//! and the latest messages always come out.

use interpd_motion::program::{Message, MessageKind, MessageQueue};
use interpd_protocol::api::{Event, MessageKind as ApiKind};

/// Messages waiting for the motion, at most.
pub const CAP: usize = 4096;

/// The messages read and not yet reached.
#[derive(Debug)]
pub struct MessageBoard {
    queue: MessageQueue,
}

impl Default for MessageBoard {
    fn default() -> Self {
        Self { queue: MessageQueue::with_cap(CAP) }
    }
}

impl MessageBoard {
    /// Queues a message the look-ahead read.
    pub fn push(&mut self, m: Message) {
        self.queue.push(m);
    }

    /// The events of the messages up to number `upto` (all of them with `None`: the program
    /// ended), oldest first; they leave the board.
    pub fn take_upto(&mut self, upto: Option<u64>) -> Vec<Event> {
        let mut out = Vec::new();
        while self.queue.front().is_some_and(|m| upto.is_none_or(|u| m.id <= u)) {
            if let Some(m) = self.queue.pop() {
                out.push(event(m));
            }
        }
        out
    }

    /// Forgets every message (a new program starts, or the running one was stopped).
    pub fn clear(&mut self) {
        self.queue.clear();
    }

    pub fn len(&self) -> usize {
        self.queue.len()
    }

    pub fn is_empty(&self) -> bool {
        self.queue.is_empty()
    }
}

/// The `message` event of `m`.
pub fn event(m: Message) -> Event {
    let kind = match m.kind {
        MessageKind::Msg => ApiKind::Msg,
        MessageKind::Debug => ApiKind::Debug,
        MessageKind::Print => ApiKind::Print,
    };
    Event::Message { kind, text: m.text, line: m.line, dropped: m.dropped }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn msg(id: u64) -> Message {
        Message { id, kind: MessageKind::Msg, text: format!("m{id}"), line: id as u32, dropped: 0 }
    }

    #[test]
    fn messages_leave_in_order_up_to_the_number_reached() {
        let mut b = MessageBoard::default();
        (1..=5).for_each(|id| b.push(msg(id)));
        let lines = |v: Vec<Event>| {
            v.into_iter().map(|e| if let Event::Message { line, .. } = e { line } else { 0 }).collect::<Vec<_>>()
        };
        assert_eq!(lines(b.take_upto(Some(2))), [1, 2]);
        // A number reached again (a replan placed it once more): nothing twice.
        assert!(b.take_upto(Some(2)).is_empty());
        assert_eq!(lines(b.take_upto(None)), [3, 4, 5]);
        assert!(b.is_empty());
    }

    #[test]
    fn the_board_is_bounded() {
        let mut b = MessageBoard::default();
        (1..=(CAP as u64 + 100)).for_each(|id| b.push(msg(id)));
        assert_eq!(b.len(), CAP);
        let last = b.take_upto(None).pop();
        assert!(matches!(last, Some(Event::Message { dropped: 100, line, .. }) if line == CAP as u32 + 100));
    }
}
