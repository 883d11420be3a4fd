//! The simulated drive's EDS (sim-plant/eds/interpd-sim-drive.eds) checked by an independent
//! CANopen implementation: the Python `canopen` package parses it and derives the PDO mapping
//! from it as a master would (tests/python/check_eds.py). Also cross-checked against the
//! protocol crate's COB-IDs, so the EDS cannot drift from what the code puts on the bus.

use interpd_e2e::repo_root;
use interpd_protocol::cia301::cob;
use sim_plant::can_node;
use std::path::{Path, PathBuf};
use std::process::Command;

const EDS: &str = "sim-plant/eds/interpd-sim-drive.eds";

fn eds_path() -> PathBuf {
    repo_root().join(EDS)
}

/// `python3` with `canopen` importable, or a failure that says how to get it. Not a skip: CI
/// installs it (.ci/python-requirements.txt) and the check must not silently vanish.
fn python_with_canopen() -> &'static str {
    let probe = Command::new("python3").args(["-c", "import canopen"]).output();
    match probe {
        Ok(out) if out.status.success() => "python3",
        Ok(out) => panic!(
            "the EDS test needs the Python package `canopen`: run `python3 -m pip install canopen` \
             (CI installs .ci/python-requirements.txt); python3 said: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        ),
        Err(e) => panic!(
            "the EDS test needs python3 with the `canopen` package ({e}); install python3, then `python3 -m pip install canopen`"
        ),
    }
}

fn run_check(eds: &Path) -> (bool, String) {
    let python = python_with_canopen();
    let script = repo_root().join("tests/python/check_eds.py");
    let out = Command::new(python).arg(&script).arg(eds).output().expect("run check_eds.py");
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    (out.status.success(), text)
}

#[test]
fn eds_parses_with_python_canopen() {
    let (ok, text) = run_check(&eds_path());
    assert!(ok, "{EDS} fails the independent check:\n{text}");
    eprintln!("{}", text.trim());
}

/// The checker is not a rubber stamp: a wrong mapping length and a wrong SubNumber fail it.
#[test]
fn eds_check_rejects_a_broken_file() {
    let good = std::fs::read_to_string(eds_path()).expect("read EDS");
    let bad = good.replacen("DefaultValue=0x60400010", "DefaultValue=0x60400020", 1).replacen(
        "SubNumber=5",
        "SubNumber=4",
        1,
    );
    assert_ne!(bad, good);
    let dir = std::env::temp_dir().join(format!("interpd-eds-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("broken.eds");
    std::fs::write(&path, bad).expect("write broken EDS");
    let (ok, text) = run_check(&path);
    let _ = std::fs::remove_dir_all(&dir);
    assert!(!ok, "a broken EDS passed:\n{text}");
    assert!(text.contains("RPDO1: mapping"), "{text}");
    assert!(text.contains("[1018]: SubNumber=4"), "{text}");
}

/// The default values of one `[section]` of the EDS (plain INI scan; the full parse is the
/// Python test's job).
fn default_value(eds: &str, section: &str) -> Option<String> {
    let header = format!("[{section}]");
    let mut lines = eds.lines().skip_while(|l| l.trim() != header).skip(1);
    lines
        .by_ref()
        .take_while(|l| !l.starts_with('['))
        .find_map(|l| l.strip_prefix("DefaultValue=").map(|v| v.trim().to_owned()))
}

#[test]
fn eds_matches_the_protocol_crate() {
    let eds = std::fs::read_to_string(eds_path()).expect("read EDS");
    let expect = [
        ("1000", "0x00020192".to_owned()),
        ("1005", format!("0x{:08X}", cob::SYNC)),
        ("1014", format!("$NODEID+0x{:X}", cob::EMCY_BASE)),
        ("1400sub1", format!("$NODEID+0x{:X}", cob::RPDO1_BASE)),
        ("1800sub1", format!("$NODEID+0x{:X}", cob::TPDO1_BASE)),
        // CiA 402's default mapping at power-on: controlword alone, statusword alone.
        ("1600sub0", "1".to_owned()),
        ("1600sub1", "0x60400010".to_owned()),
        ("1A00sub0", "1".to_owned()),
        ("1A00sub1", "0x60410010".to_owned()),
        // No mode and no heartbeat until the master configures them.
        ("6060", "0".to_owned()),
        ("1017", "0".to_owned()),
        // What sim-plant's drive node implements (sim_plant::can_node).
        ("1015", (can_node::EMCY_INHIBIT_US / 100).to_string()),
        ("6065", can_node::FOLLOWING_ERROR_WINDOW.to_string()),
        // Quick stop option code 2: ramp, then Switch on disabled (cia402::next_state).
        ("605A", "2".to_owned()),
        // The default machine's cycle, µs; 0x60C2 = 4 · 10⁻³ s.
        ("1006", format!("{:.0}", interpd_config::Config::default_machine().cycle_s() * 1e6)),
        ("608Fsub1", format!("{:.0}", interpd_config::sinks::DEFAULT_INCREMENTS_PER_UNIT)),
    ];
    for (section, want) in expect {
        assert_eq!(default_value(&eds, section).as_deref(), Some(want.as_str()), "[{section}] DefaultValue");
    }
}

/// The master's configuration maps exactly the layout of cia402::Rpdo1 and Tpdo1 (controlword
/// u16 + target position i32; statusword u16 + position actual value i32).
#[test]
fn the_masters_mapping_is_the_protocol_crates_layout() {
    use interpd_canopen::boot::{CspSetup, Op, csp_ops};
    let node = interpd_protocol::cia301::NodeId::new(3).expect("node");
    let setup = CspSetup { vendor_id: 0, product_code: 0x402, cycle_us: 4000, heartbeat_ms: 100, extra: Vec::new() };
    let writes: Vec<(u16, u8, Vec<u8>)> = csp_ops(node, &setup)
        .into_iter()
        .filter_map(|op| if let Op::Write { at, data, .. } = op { Some((at.index, at.sub, data)) } else { None })
        .collect();
    let value = |i: u16, s: u8| writes.iter().rev().find(|w| w.0 == i && w.1 == s).map(|w| w.2.clone());
    let u32le = |v: u32| Some(v.to_le_bytes().to_vec());
    assert_eq!(value(0x1600, 1), u32le(0x6040_0010));
    assert_eq!(value(0x1600, 2), u32le(0x607A_0020));
    assert_eq!(value(0x1600, 0), Some(vec![2]));
    assert_eq!(value(0x1A00, 1), u32le(0x6041_0010));
    assert_eq!(value(0x1A00, 2), u32le(0x6064_0020));
    assert_eq!(value(0x1400, 1), u32le(u32::from(cob::RPDO1_BASE) + 3));
    assert_eq!(value(0x1800, 1), u32le(u32::from(cob::TPDO1_BASE) + 3));
    assert_eq!((value(0x1400, 2), value(0x1800, 2)), (Some(vec![1]), Some(vec![1])), "synchronous");
    assert_eq!(value(0x6060, 0), Some(vec![8]));
    assert_eq!(value(0x1017, 0), Some(100u16.to_le_bytes().to_vec()));
}
