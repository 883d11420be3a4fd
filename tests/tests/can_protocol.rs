//! Property tests of the CAN protocol layer (interpd_protocol::cia301, ::cia402 and ::candump):
//! no input panics a decoder or the log reader, and everything that decodes re-encodes to the
//! same bytes. No CAN interface needed; these run in every `cargo test`.
//!
//! (They live here rather than in protocol/ because proptest is a dev-dependency of this
//! package.)

use interpd_protocol::candump::{self, Iface, Record, Timestamp};
use interpd_protocol::cia301::{self, CanId, Emcy, Frame, Message, NmtCommand, NmtState, NodeId};
use interpd_protocol::cia402::{PowerState, PowerStateMachine, Rpdo1, Scale, Tpdo1, next_state};
use proptest::prelude::*;

fn arb_node() -> impl Strategy<Value = NodeId> {
    (1u8..=127).prop_map(|n| NodeId::new(n).expect("1..=127"))
}

fn arb_message() -> impl Strategy<Value = Message> {
    let nmt = prop_oneof![
        Just(NmtCommand::Start),
        Just(NmtCommand::Stop),
        Just(NmtCommand::EnterPreOperational),
        Just(NmtCommand::ResetNode),
        Just(NmtCommand::ResetCommunication),
    ];
    let state = prop_oneof![
        Just(NmtState::BootUp),
        Just(NmtState::Stopped),
        Just(NmtState::Operational),
        Just(NmtState::PreOperational)
    ];
    prop_oneof![
        (nmt, proptest::option::of(arb_node())).prop_map(|(command, target)| Message::Nmt { command, target }),
        proptest::option::of(any::<u8>()).prop_map(|counter| Message::Sync { counter }),
        (arb_node(), any::<u16>(), any::<u8>(), any::<[u8; 5]>()).prop_map(
            |(node, error_code, error_register, vendor)| {
                Message::Emcy { node, emcy: Emcy { error_code, error_register, vendor } }
            }
        ),
        (arb_node(), any::<u16>(), any::<i32>()).prop_map(|(node, statusword, position_actual)| Message::Tpdo1 {
            node,
            pdo: Tpdo1 { statusword, position_actual }
        }),
        (arb_node(), any::<u16>(), any::<i32>()).prop_map(|(node, controlword, target_position)| Message::Rpdo1 {
            node,
            pdo: Rpdo1 { controlword, target_position }
        }),
        (arb_node(), state).prop_map(|(node, state)| Message::Heartbeat { node, state }),
    ]
}

/// Arbitrary frames, including invalid ones: any u32 id word (all flag combinations), any DLC
/// up to 15 and up to 15 data bytes. Construction may fail; decoding what was built must not.
fn arb_raw() -> impl Strategy<Value = (u32, u8, Vec<u8>)> {
    (any::<u32>(), 0u8..16, proptest::collection::vec(any::<u8>(), 0..16))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4096))]

    #[test]
    fn decoder_never_panics_and_reencodes((word, dlc, data) in arb_raw()) {
        if let Ok(f) = Frame::from_socketcan(word, dlc, &data) {
            prop_assert!(f.len() <= 8);
            if let Ok(m) = cia301::decode(&f) {
                prop_assert_eq!(m.encode(), f);
            }
        }
        // The same bytes on an 11-bit id, which reaches every CANopen branch.
        if let Ok(f) = Frame::standard((word & 0x7FF) as u16, &data[..data.len().min(8)]) {
            if let Ok(m) = cia301::decode(&f) {
                prop_assert_eq!(m.encode(), f);
            }
        }
    }

    #[test]
    fn messages_round_trip(m in arb_message()) {
        let f = m.encode();
        prop_assert_eq!(cia301::decode(&f), Ok(m));
        let back = Frame::from_socketcan(f.socketcan_id_word(), f.len(), f.payload());
        prop_assert_eq!(back, Ok(f));
    }

    #[test]
    fn state_machine_is_total(states in proptest::collection::vec(any::<u16>(), 0..64), sw in any::<u16>()) {
        let mut m = PowerStateMachine::new(PowerState::SwitchOnDisabled);
        for cw in states {
            let before = m.state();
            let after = m.apply(cw);
            // Only Switched on (4) or Operation enabled itself lead to Operation enabled.
            if after == PowerState::OperationEnabled {
                prop_assert!(matches!(before, PowerState::SwitchedOn | PowerState::OperationEnabled));
            }
            prop_assert_eq!(PowerState::from_statusword(after.statusword_bits()), Some(after));
            prop_assert_eq!(next_state(PowerState::FaultReactionActive, cw), PowerState::FaultReactionActive);
        }
        let _ = PowerState::from_statusword(sw);
    }

    #[test]
    fn scaling_is_exact_or_an_error(units in any::<f64>(), per_unit in -1e6f64..1e6) {
        if let Ok(scale) = Scale::new(per_unit) {
            match scale.to_increments(units) {
                Ok(inc) => prop_assert!((units * per_unit - inc as f64).abs() <= 0.5 + 1e-9 * (units * per_unit).abs()),
                Err(_) => prop_assert!(!units.is_finite() || (units * per_unit).round().abs() > i32::MAX as f64 - 1.0),
            }
        }
    }

    /// Arbitrary text never panics the log reader.
    #[test]
    fn candump_reader_never_panics(line in ".{0,80}") {
        let _ = candump::parse_line(&line, 1);
    }

    /// Text made of the log's own alphabet reaches deep into the grammar; whatever parses
    /// writes back to a line that parses to the same record.
    #[test]
    fn candump_near_misses(line in "\\(?[0-9]{0,12}\\.?[0-9]{0,7}\\)? {0,2}[a-z0-9]{0,6} ?[0-9A-Fa-f]{0,9}#{0,2}[R0-9A-Fa-f_]{0,20} ?") {
        if let Ok(r) = candump::parse_line(&line, 1) {
            let text = r.to_string();
            prop_assert_eq!(candump::parse_line(&text, 1), Ok(r.clone()));
            prop_assert_eq!(candump::parse_line(&text, 1).map(|x| x.to_string()), Ok(text));
        }
    }

    /// Valid lines with a few random character edits: whatever still parses writes back
    /// canonically and parses to the same record; everything else is an error with a column
    /// inside the line.
    #[test]
    fn candump_mutated_lines(
        micros in any::<u64>(),
        (word, dlc, data) in arb_raw(),
        edits in proptest::collection::vec((any::<usize>(), 0u8..3, proptest::sample::select(&b"(). #R_0189AFaf\r\x00"[..])), 1..4),
    ) {
        let Ok(frame) = Frame::from_socketcan(word, dlc, &data) else { return Ok(()) };
        let r = Record { time: Timestamp::from_micros(micros), iface: Iface::new("vcan0").expect("name"), frame };
        let mut bytes = r.to_string().into_bytes();
        for (at, op, c) in edits {
            let i = at % (bytes.len() + 1);
            match op {
                0 => bytes.insert(i, c),
                1 if i < bytes.len() => { bytes.remove(i); }
                _ if i < bytes.len() => bytes[i] = c,
                _ => {}
            }
        }
        let line = String::from_utf8(bytes).expect("ASCII edits");
        match candump::parse_line(&line, 1) {
            Ok(parsed) => {
                let text = parsed.to_string();
                prop_assert_eq!(candump::parse_line(&text, 1), Ok(parsed));
            }
            Err(e) => prop_assert!(e.column >= 1 && e.column <= line.chars().count() + 1, "{e}"),
        }
    }

    #[test]
    fn candump_records_round_trip(
        micros in any::<u64>(),
        (word, dlc, data) in arb_raw(),
        name in "[a-z][a-z0-9]{0,14}",
    ) {
        if let Ok(frame) = Frame::from_socketcan(word, dlc, &data) {
            let r = Record { time: Timestamp::from_micros(micros), iface: Iface::new(&name).expect("name"), frame };
            let text = candump::format_log(std::slice::from_ref(&r));
            let back = candump::parse_log(&text).expect("what the writer writes, the reader reads");
            prop_assert_eq!(&back, &vec![r]);
            prop_assert_eq!(candump::format_log(&back), text);
        }
    }
}

#[test]
fn standard_ids_keep_their_width() {
    let id = CanId::extended(0x123).expect("id");
    let f = Frame::data(id, &[1]).expect("frame");
    let r = Record { time: Timestamp::from_micros(0), iface: Iface::new("can0").expect("name"), frame: f };
    assert_eq!(r.to_string(), "(0000000000.000000) can0 00000123#01");
}
