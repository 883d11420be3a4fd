//! The SDO client and server against each other, against an independent implementation's
//! recorded frames (the Python `canopen` package, `tests/python/record_sdo.py`), and under
//! timeouts, aborts and protocol errors.

use interpd_canopen::od::{Access, DataType, Entry, ObjectDictionary};
use interpd_canopen::sdo_client::{Direction, SdoClient, SdoError, Step};
use interpd_canopen::sdo_frame::{Initiate, Request};
use interpd_canopen::sdo_server::{ObjectAccess, SdoServer};
use interpd_canopen::{Address, SdoAbort, eds};
use interpd_protocol::cia301::{Frame, NodeId};

const EDS: &str = include_str!("../../sim-plant/eds/interpd-sim-drive.eds");
const RECORDED: &str = include_str!("sdo_python_canopen.txt");

fn node() -> NodeId {
    NodeId::new(3).unwrap()
}

fn hex(s: &str) -> Vec<u8> {
    (0..s.len()).step_by(2).map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap()).collect()
}

struct Block {
    name: String,
    frames: Vec<(char, Frame)>,
    result: String,
}

fn recorded() -> Vec<Block> {
    let mut blocks: Vec<Block> = Vec::new();
    for line in RECORDED.lines() {
        if let Some(name) = line.strip_prefix("# ") {
            blocks.push(Block { name: name.into(), frames: Vec::new(), result: String::new() });
        } else if let Some(r) = line.strip_prefix("= ") {
            blocks.last_mut().unwrap().result = r.into();
        } else {
            let (side, rest) = line.split_at(1);
            let (id, data) = rest.trim().split_once('#').unwrap();
            let f = Frame::standard(u16::from_str_radix(id, 16).unwrap(), &hex(data)).unwrap();
            blocks.last_mut().unwrap().frames.push((side.chars().next().unwrap(), f));
        }
    }
    assert_eq!(blocks.len(), 8, "the recording has its eight transfers");
    blocks
}

/// Our server answers python-canopen's client exactly as python-canopen's server did.
#[test]
fn our_server_answers_as_python_canopen_does() {
    let mut od = eds::parse(EDS, node()).unwrap().od;
    let mut server = SdoServer::new(node());
    for b in recorded() {
        let mut expect = None;
        for (side, f) in &b.frames {
            match side {
                'C' => {
                    assert!(server.is_request(f));
                    expect = server.on_request(f.payload(), &mut od);
                }
                _ => assert_eq!(expect.take().as_ref(), Some(f), "{}: our server's answer", b.name),
            }
        }
    }
    assert_eq!(od.int(Address::new(0x1017, 0)), Some(250));
}

/// Our client, given python-canopen's server answers, sends python-canopen's client requests
/// and ends with the same result.
#[test]
fn our_client_talks_as_python_canopen_does() {
    for b in recorded() {
        if b.name.contains("segmented download") {
            // python-canopen forced segmentation of 2 bytes; our client sends them expedited.
            continue;
        }
        let mut client = SdoClient::new(node(), 1_000_000);
        let (_, first) = &b.frames[0];
        let sent = match Request::decode(first.payload()).unwrap() {
            Request::InitiateUpload { at } => client.upload(at, 0).unwrap(),
            Request::InitiateDownload { at, data: Initiate::Expedited(c) } => {
                client.download(at, c.as_slice().to_vec(), 0).unwrap()
            }
            other => panic!("{other:?}"),
        };
        assert_eq!(&sent, first, "{}", b.name);
        let mut outcome = None;
        let mut expect_next: Option<Frame> = None;
        for (side, f) in &b.frames[1..] {
            if *side == 'C' {
                assert_eq!(expect_next.take().as_ref(), Some(f), "{}: our client's request", b.name);
                continue;
            }
            match client.on_frame(f, 10).unwrap() {
                Step::Send(next) => expect_next = Some(next),
                Step::Uploaded(d) => {
                    outcome = Some(format!("ok {}", d.iter().map(|x| format!("{x:02X}")).collect::<String>()))
                }
                Step::Downloaded => outcome = Some("ok".into()),
                Step::Failed { error: SdoError::Aborted { abort, .. }, abort: None } => {
                    outcome = Some(format!("abort 0x{:08X}", abort.code()))
                }
                other => panic!("{}: {other:?}", b.name),
            }
        }
        assert_eq!(outcome.as_deref(), Some(b.result.as_str()), "{}", b.name);
        assert!(!client.busy());
    }
}

fn string_od() -> ObjectDictionary {
    let mut od = ObjectDictionary::default();
    let entry = |data_type, access, value: Vec<u8>| Entry {
        name: "x".into(),
        data_type,
        access,
        pdo_mappable: false,
        low: None,
        high: Some(1000),
        value,
    };
    od.insert(Address::new(0x2000, 0), entry(DataType::VisibleString, Access::ReadWrite, Vec::new()));
    od.insert(Address::new(0x2001, 0), entry(DataType::Unsigned16, Access::ReadWrite, vec![0, 0]));
    od.insert(Address::new(0x2002, 0), entry(DataType::Unsigned32, Access::ReadOnly, vec![1, 2, 3, 4]));
    od
}

/// Runs one transfer between our client and server to its end.
fn exchange(client: &mut SdoClient, server: &mut SdoServer, od: &mut dyn ObjectAccess, first: Frame) -> Step {
    let mut frame = first;
    for _ in 0..1000 {
        let answer = server.on_request(frame.payload(), od).expect("the server answers");
        match client.on_frame(&answer, 0).expect("for the client") {
            Step::Send(f) => frame = f,
            done => return done,
        }
    }
    panic!("no end");
}

#[test]
fn client_and_server_move_every_length_both_ways() {
    let mut od = string_od();
    let mut server = SdoServer::new(node());
    let mut client = SdoClient::new(node(), 1_000);
    let at = Address::new(0x2000, 0);
    for len in 0..=40usize {
        let data: Vec<u8> = (0..len).map(|i| b'a' + (i * 7 % 26) as u8).collect();
        let f = client.download(at, data.clone(), 0).unwrap();
        assert_eq!(exchange(&mut client, &mut server, &mut od, f), Step::Downloaded, "length {len}");
        let f = client.upload(at, 0).unwrap();
        assert_eq!(exchange(&mut client, &mut server, &mut od, f), Step::Uploaded(data), "length {len}");
    }
    // Refusals come back as typed aborts with their meaning.
    let f = client.download(Address::new(0x2002, 0), vec![0; 4], 0).unwrap();
    let Step::Failed { error, abort: None } = exchange(&mut client, &mut server, &mut od, f) else { panic!() };
    assert_eq!(
        error.to_string(),
        "node 3: SDO download (write) of 0x2002:0 refused by the drive: abort 0x06010002: attempt to write a read-only object"
    );
    for (data, abort) in [(vec![1], SdoAbort::LengthTooLow), (vec![0xE9, 3], SdoAbort::ValueTooHigh)] {
        let f = client.download(Address::new(0x2001, 0), data, 0).unwrap();
        let Step::Failed { error: SdoError::Aborted { abort: a, .. }, .. } =
            exchange(&mut client, &mut server, &mut od, f)
        else {
            panic!()
        };
        assert_eq!(a, abort);
    }
    let f = client.upload(Address::new(0x2001, 7), 0).unwrap();
    assert!(matches!(
        exchange(&mut client, &mut server, &mut od, f),
        Step::Failed { error: SdoError::Aborted { abort: SdoAbort::NoSuchSubIndex, .. }, .. }
    ));
}

#[test]
fn one_transfer_at_a_time_and_timeouts_abort() {
    let mut client = SdoClient::new(node(), 500_000);
    let at = Address::new(0x1017, 0);
    client.upload(at, 1_000).unwrap();
    assert!(matches!(client.download(at, vec![1, 0], 1_000), Err(SdoError::Busy { .. })));
    assert_eq!(client.poll(500_999), None);
    let Some(Step::Failed { error, abort: Some(f) }) = client.poll(501_000) else { panic!() };
    assert_eq!(error, SdoError::Timeout { node: node(), dir: Direction::Upload, at, timeout_ms: 500 });
    assert_eq!((f.id().raw(), f.payload()), (0x603, &[0x80, 0x17, 0x10, 0, 0, 0, 4, 5][..]));
    assert!(!client.busy());
    // A late answer after the timeout is not taken for a new transfer's.
    let late = Frame::standard(0x583, &[0x4B, 0x17, 0x10, 0, 100, 0, 0, 0]).unwrap();
    assert_eq!(client.on_frame(&late, 600_000), None);
    // Other nodes' frames are not this client's.
    client.upload(at, 0).unwrap();
    assert_eq!(client.on_frame(&Frame::standard(0x584, &[0x4B, 0x17, 0x10, 0, 1, 0, 0, 0]).unwrap(), 0), None);
}

#[test]
fn toggle_errors_abort_on_both_sides() {
    let mut od = string_od();
    od.write(Address::new(0x2000, 0), b"fourteen bytes").unwrap();
    let mut client = SdoClient::new(node(), 1_000);
    client.upload(Address::new(0x2000, 0), 0).unwrap();
    let init = Frame::standard(0x583, &[0x41, 0x00, 0x20, 0, 14, 0, 0, 0]).unwrap();
    assert!(matches!(client.on_frame(&init, 0), Some(Step::Send(_))));
    // The server answers the first segment with toggle 1.
    let wrong = Frame::standard(0x583, &[0x10, b'f', b'o', b'u', b'r', b't', b'e', b'e']).unwrap();
    let Some(Step::Failed { error: SdoError::Protocol { abort, .. }, abort: Some(f) }) = client.on_frame(&wrong, 0)
    else {
        panic!()
    };
    assert_eq!(abort, SdoAbort::ToggleBit);
    assert_eq!(f.payload()[4..], 0x0503_0000u32.to_le_bytes());

    let mut server = SdoServer::new(node());
    let r = server.on_request(&[0x21, 0x00, 0x20, 0, 10, 0, 0, 0], &mut od).unwrap();
    assert_eq!(r.payload()[0], 0x60);
    let r = server.on_request(&[0x10, 1, 2, 3, 4, 5, 6, 7], &mut od).unwrap();
    assert_eq!(r.payload(), &[0x80, 0x00, 0x20, 0, 0, 0, 3, 5]);
    // Unknown command specifiers (block transfer) are refused, not served.
    let r = server.on_request(&[0xC0, 0x00, 0x20, 0, 0, 0, 0, 0], &mut od).unwrap();
    assert_eq!(r.payload()[4..], 0x0504_0001u32.to_le_bytes());
    assert_eq!(server.stats.aborts_sent, 2);
}
