//! End to end: operator messages of a program in `interpd run` over the control socket, with
//! the setpoints received over iceoryx2. `(MSG,…)`, `(DEBUG,…)` and `(PRINT,…)` become `message`
//! events with the parameters as they were when the block executed (a `while` loop's value of
//! each iteration), in program order, each when the motion before it is done: the machine
//! stands at its place (LinuxCNC waits for the motion before a message) and the status read
//! after the event shows the machine there or past it, never before. A loop that writes a
//! million messages without moving comes out bounded: the first ones and the newest, with the
//! count of those left out.

use interpd_e2e::daemon::{Client, Collector, Daemon};
use serde_json::{Value, json};
use std::time::{Duration, Instant};

const TIMEOUT: Duration = Duration::from_secs(60);

/// Five moves of 10 mm in a loop, each followed by a DEBUG naming the loop variable and the X
/// the program reads for its position (#5420) after the move.
const PROGRAM: &str = "G21 G90 G1 F1200 X0 Y0\n\
#<i> = 0\n\
(MSG, Start of the part)\n\
o100 while [#<i> LT 5]\n\
  #<i> = [#<i> + 1]\n\
  G1 X[#<i> * 10]\n\
  (DEBUG, i=#<i> x=#5420 neg=#<neg>)\n\
  #<neg> = [0 - #<i> / 3]\n\
o100 endwhile\n\
(PRINT,done after %d#<i> passes, #<unset>)\n\
M2\n";

fn x_of(st: &Value) -> f64 {
    st["position"][0].as_f64().unwrap()
}

/// Polls `status` until the program ends, pairing each new `message` event with the X of the
/// first status read after it arrived.
fn run_collecting(c: &mut Client) -> Vec<(Value, f64)> {
    let until = Instant::now() + TIMEOUT;
    let mut seen = 0;
    let mut got = Vec::new();
    loop {
        let st = c.ok("status", Value::Null);
        let new: Vec<Value> = c.events.iter().filter(|e| e["event"] == "message").skip(seen).cloned().collect();
        seen += new.len();
        got.extend(new.into_iter().map(|e| (e, x_of(&st))));
        if st["state"] == "finished" || st["state"] == "error" {
            assert_eq!(st["state"], "finished", "{st}");
            c.wait_event("finished", TIMEOUT);
            let new: Vec<Value> = c.events.iter().filter(|e| e["event"] == "message").skip(seen).cloned().collect();
            got.extend(new.into_iter().map(|e| (e, x_of(&st))));
            return got;
        }
        assert!(Instant::now() < until, "not finished: {st}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn messages_come_in_order_with_their_values_after_the_motion_before_them() {
    let daemon = Daemon::start(&[]);
    let mut c = daemon.client();
    c.ok("subscribe", Value::Null);
    let collector = Collector::start(&daemon.prefix);

    // #<neg> is unset in the first pass: LinuxCNC writes ######.
    let info = c.ok("program.load", json!({"text": PROGRAM, "name": "messages"}));
    assert_eq!(info["elements"], 5, "{info}");
    c.ok("motion.start", Value::Null);
    let got = run_collecting(&mut c);

    let texts: Vec<(&str, &str, u64)> = got
        .iter()
        .map(|(e, _)| (e["kind"].as_str().unwrap(), e["text"].as_str().unwrap(), e["line"].as_u64().unwrap()))
        .collect();
    assert_eq!(
        texts,
        [
            ("msg", " Start of the part", 3),
            ("debug", " i=1.000000 x=10.000000 neg=######", 7),
            ("debug", " i=2.000000 x=20.000000 neg=-0.333333", 7),
            ("debug", " i=3.000000 x=30.000000 neg=-0.666667", 7),
            ("debug", " i=4.000000 x=40.000000 neg=-1.000000", 7),
            ("debug", " i=5.000000 x=50.000000 neg=-1.333333", 7),
            ("print", "done after 5 passes, ######", 10),
        ],
        "{got:?}"
    );
    assert!(got.iter().all(|(e, _)| e["dropped"] == 0), "{got:?}");
    // Each DEBUG after its move: the status read after the event shows the machine at least
    // there, and not yet at the next message's place.
    for (k, (_, x)) in got.iter().enumerate().skip(1).take(5) {
        let place = 10.0 * k as f64;
        assert!(*x >= place - 1e-9 && *x < place + 10.0, "message {k} seen at X{x}, its place is X{place}");
    }
    // The events before `finished`, in order; the machine ends at X50.
    let order: Vec<&str> = c.events.iter().filter_map(|e| e["event"].as_str()).collect();
    let last_message = order.iter().rposition(|e| *e == "message").unwrap();
    assert!(last_message < order.iter().position(|e| *e == "finished").unwrap(), "{order:?}");

    // The setpoints: the machine comes to rest at every message's place (a planned exact stop;
    // the moves are collinear, so without it they would run through at 20 mm/s). The 4 ms
    // setpoints straddle the instant of rest: within 0.01 mm of it below 2 mm/s.
    let sps = collector.finish();
    for k in 1..=5 {
        let place = 10.0 * f64::from(k);
        let slowest = sps
            .iter()
            .filter(|s| (s.pos[0] - place).abs() < 0.01)
            .map(|s| s.v_mm_s.abs())
            .fold(f64::INFINITY, f64::min);
        assert!(slowest < 2.0, "no rest at X{place}: slowest {slowest} mm/s");
    }
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "{stderr}");
}

#[test]
fn a_million_messages_without_motion_come_out_bounded_and_counted() {
    let daemon = Daemon::start(&[]);
    let mut c = daemon.client();
    c.ok("subscribe", Value::Null);
    let text = "G21 G90 G1 F1200 X5\n\
o1 while [#1 LT 1000000]\n#1 = [#1 + 1]\n(DEBUG,%d#1)\no1 endwhile\nG1 X10\nM2\n";
    c.ok("program.load", json!({"text": text, "name": "many"}));
    c.ok("motion.start", Value::Null);
    let got = run_collecting(&mut c);
    let cap = interpd_motion::program::PLACE_CAP;
    assert_eq!(got.len(), cap + 1, "{}", got.len());
    for (k, (e, x)) in got.iter().take(cap).enumerate() {
        assert_eq!(e["text"], (k + 1).to_string());
        assert_eq!(e["dropped"], 0);
        assert!(*x >= 5.0 - 1e-9, "seen at X{x}, before its place X5");
    }
    let (last, _) = got.last().unwrap();
    assert_eq!(last["text"], "1000000");
    assert_eq!(last["dropped"], 1_000_000 - cap as u64 - 1, "{last}");
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "{stderr}");
}
