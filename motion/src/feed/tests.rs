use super::*;
use crate::path::Element;
use crate::program::check_open;
use std::time::Duration;

/// The embedded machine, with no wall-time limit on the smoothing stage's solves (which would
/// make its output depend on the host's speed).
fn settings() -> Settings {
    let mut s = Settings::default_machine();
    s.prep.max_solve_ms = 1e5;
    s
}

/// [`settings`] with a look-ahead of `mm`.
fn with_lookahead(mm: f64) -> Settings {
    let mut s = settings();
    s.planner.lookahead_mm = mm;
    s
}

fn later() -> Instant {
    Instant::now() + Duration::from_secs(60)
}

/// A CAM-like G64 program: `n` short moves along a noisy curve with a few corners.
fn cam_program(n: usize) -> String {
    let mut t = String::from("G21 G90 G64 P0.01\nG1 X0 Y0 F3000\n");
    for i in 1..=n {
        let x = i as f64 * 0.05;
        let y = (x * 0.7).sin() * 3.0 + if i % 7 == 0 { 0.004 } else { 0.0 };
        let corner = if i % 97 == 0 { " Z0.5" } else { "" };
        t.push_str(&format!("X{x:.4} Y{y:.4}{corner}\n"));
    }
    t.push_str("M30\n");
    t
}

/// Plans `feed` to its end asking for `need_s` at a time (reading ahead before each call with
/// `ahead`), and returns every segment.
fn plan_all(feed: &mut Feed, need_s: f64, ahead: bool) -> Vec<Segment> {
    let mut out = Vec::new();
    while !feed.finished() {
        if ahead {
            feed.read_ahead(later());
        }
        feed.plan(need_s).expect("plans");
        while let Some(s) = feed.pop_segment() {
            out.push(s);
        }
    }
    out
}

#[test]
fn the_motion_does_not_depend_on_how_the_program_is_read_or_asked_for() {
    let text = cam_program(600);
    let settings = with_lookahead(20.0);
    let open = || Feed::builder(&settings).open_text("cam.ngc", text.clone()).expect("opens");
    let reference = plan_all(&mut open(), 1e-9, false);
    assert!(reference.len() > 100 && open().summary().is_some());
    for (need_s, ahead) in [(1e-9, true), (0.05, false), (0.05, true), (10.0, true), (1e9, false)] {
        let got = plan_all(&mut open(), need_s, ahead);
        // Bit for bit: the planner plans after the same elements whatever the reading did.
        assert!(got == reference, "asking for {need_s} s, reading ahead {ahead}: the motion differs");
    }
}

#[test]
fn reading_ahead_stops_at_its_bound_and_keeps_an_error_for_the_planner() {
    let text = stops_then_a_bad_line();
    let mut feed = Feed::builder(&settings()).open_text("t.ngc", text.clone()).expect("opens");
    let (until, deadline) = (5.0, later());
    assert!(feed.window.can_read_ahead(until));
    assert!(feed.window.read_ahead(until, deadline));
    let read_mm = feed.path().length_mm();
    assert!((5.0..6.5).contains(&read_mm), "read to {read_mm} mm");
    assert!(!feed.window.can_read_ahead(until) && !feed.window.read_ahead(until, deadline));
    // A deadline already passed reads nothing.
    assert!(!feed.window.read_ahead(100.0, Instant::now()));
    // Past the bad line: the error is kept, and reading ahead stops there.
    assert!(feed.window.read_ahead(100.0, deadline));
    assert!(!feed.window.can_read_ahead(100.0));
    // The planner gets what it gets without reading ahead: the same elements, then the error.
    let (ahead, error) = elements_until_error(&mut feed);
    let (plain, plain_error) =
        elements_until_error(&mut Feed::builder(&settings()).open_text("t.ngc", text).expect("opens"));
    assert!(ahead.len() >= 19 && ahead == plain, "{} elements, without reading ahead {}", ahead.len(), plain.len());
    assert_eq!(error, plain_error);
    // The error keeps its place as data.
    let FeedError::Program(errors) = &error else { panic!("not a program error: {error:?}") };
    assert_eq!((errors.0[0].file.as_str(), errors.0[0].line), ("t.ngc", 23), "{error}");
}

/// 1 mm moves at an exact stop each, then a bad line (23).
fn stops_then_a_bad_line() -> String {
    let mut text = String::from("G21 G90 G61\nG1 F600\n");
    for i in 1..=20 {
        text.push_str(&format!("X{i}\n"));
    }
    text.push_str("G1 X30 Q5\n");
    text
}

fn elements_until_error(feed: &mut Feed) -> (Vec<Element>, FeedError) {
    let mut got = Vec::new();
    loop {
        match feed.window.element(got.len(), false) {
            Ok(Some((e, _))) => got.push(e.clone()),
            Ok(None) => panic!("the error of line 23 was lost after {} elements", got.len()),
            Err(e) => return (got, e),
        }
    }
}

#[test]
fn a_program_continued_by_appended_text_is_not_read_ahead_and_waits_for_it() {
    let path = std::path::Path::new("open.ngc");
    let text = "G21 G90 G61\nG1 F600 X1\nX2\n".to_string();
    let (_, appends) = check_open(path, Some(text.clone()), &settings(), 1 << 20).expect("checks");
    let appends = appends.expect("no end: open");
    let mut feed = Feed::builder(&settings()).appends(&appends).open_text("open.ngc", text).expect("opens");
    assert!(!feed.wants_to_read_ahead() && !feed.read_ahead(later()));
    // What is there is planned to rest at its end while nothing more comes.
    let mut first = Vec::new();
    while !feed.exhausted() {
        feed.plan_or_rest(10.0).expect("plans");
        feed.take(100.0, &mut first);
    }
    assert!(!feed.finished() && feed.waits_for_text(false));
    let s_rest = first.last().expect("moves").s1_mm();
    assert!((s_rest - 2.0).abs() < 1e-9, "rests at {s_rest}");
    // Appended text arrives; a restart from rest there continues with it to the end.
    let appended = appends.append("X3\nM2\n", false).expect("appends");
    assert!(appended.program_end && feed.has_new_text());
    feed.restart_at_rest(s_rest, Vec::new());
    let rest = plan_all(&mut feed, 1.0, false);
    assert!((rest.last().expect("moves").s1_mm() - 3.0).abs() < 1e-9);
    assert!(matches!(appends.append("X4\n", false), Err(crate::program::AppendError::Ended)));
}

#[test]
fn trimming_behind_the_motion_bounds_the_window() {
    let settings = with_lookahead(20.0);
    let mut feed = Feed::builder(&settings).open_text("cam.ngc", cam_program(20_000)).expect("opens");
    let (mut held_max, mut segments) = (0, 0);
    while !feed.finished() {
        feed.read_ahead(later());
        feed.plan(0.1).expect("plans");
        let mut out = Vec::new();
        feed.take(0.1, &mut out);
        segments += out.len();
        if let Some(last) = out.last() {
            feed.trim_before(last.s0_mm);
        }
        held_max = held_max.max(feed.path().elements.len());
    }
    let progress = feed.progress();
    assert!(progress.finished && progress.lines_read == 20_003 && progress.segments == segments as u64);
    // What the look-ahead holds (20 mm planned, as much read ahead, and the elements between
    // the machine and the planner) is a small part of the program's 1000 mm.
    let stats = feed.stats();
    assert!(stats.prep.pieces > 0 && stats.plan.nodes > 0);
    assert!(held_max * 10 < stats.prep.pieces as usize, "the window held {held_max} of {} elements", stats.prep.pieces);
}

#[test]
fn a_restart_from_rest_and_a_replan_continue_along_the_same_path() {
    let text = "G21 G90 G61\nG1 X50 F6000\nY50\nX0\nM30\n";
    let whole: Vec<Segment> =
        plan_all(&mut Feed::builder(&settings()).open_text("sq.ngc", text).expect("opens"), 1.0, false);
    let end_mm = whole.last().expect("moves").s1_mm();
    // Take the first quarter second, then stop along the path and restart from rest there.
    let mut feed = Feed::builder(&settings()).open_text("sq.ngc", text).expect("opens");
    feed.plan(0.25).expect("plans");
    let mut first = Vec::new();
    feed.take(0.25, &mut first);
    let last = *first.last().expect("moves");
    let end = last.at(last.dt_s);
    let stop = feed.stop_from(end.s_mm, end.v, end.a, last.line).expect("a stop fits");
    let s_rest = stop.last().map_or(end.s_mm, Segment::s1_mm);
    feed.restart_at_rest(s_rest, stop);
    let rest = plan_all(&mut feed, 1.0, false);
    assert!((rest.last().expect("moves").s1_mm() - end_mm).abs() < 1e-9);
    // A replan at a higher feed from a moving state gets to the same end sooner.
    let mut feed = Feed::builder(&settings()).open_text("sq.ngc", text).expect("opens");
    feed.plan(0.25).expect("plans");
    let mut first = Vec::new();
    let t_first = feed.take(0.25, &mut first);
    let last = *first.last().expect("moves");
    let end = last.at(last.dt_s);
    let floor = feed.stop_from(end.s_mm, end.v, end.a, last.line).expect("a stop fits");
    feed.set_feed_override(1.5);
    feed.replan(end.s_mm, end.v, end.a, floor);
    let rest = plan_all(&mut feed, 1.0, false);
    assert!(rest[0].v0 == end.v && rest[0].a0 == end.a, "continues from the state it was given");
    let faster_s = t_first + rest.iter().map(|s| s.dt_s).sum::<f64>();
    assert!((rest.last().expect("moves").s1_mm() - end_mm).abs() < 1e-9);
    assert!(faster_s < profile_duration(&whole) * 0.9, "{faster_s} s at 150 %");
    assert_eq!(feed.stats().replans, 1);
}

fn profile_duration(segments: &[Segment]) -> f64 {
    segments.iter().map(|s| s.dt_s).sum()
}

#[test]
fn a_path_held_whole_starts_from_where_the_machine_stands() {
    let program = crate::program::parse("G21 G90\nG1 X10 F600\n", "p.ngc", &settings()).expect("parses");
    let mut here = [0.0; crate::path::MAX_AXES];
    here[1] = 5.0;
    let mut feed = Feed::builder(&settings()).start_from(here).whole(program.path);
    assert_eq!(feed.path().elements.len(), 2, "the approach move, then the program");
    assert_eq!(feed.start().expect("starts"), (here, 0));
    let segments = plan_all(&mut feed, 1.0, false);
    let length = 5.0 + 10.0;
    assert!((segments.last().expect("moves").s1_mm() - length).abs() < 1e-9);
}

/// A program that begins with a rapid to the part and then cuts along dense G64 moves: the
/// rapid ends at rest (the cut starts at a corner), which the smoothing stage knows as soon as
/// the first cut move is read. The planner plans the rapid to rest then, without waiting for
/// the first smoothing window of the cut (which reads its whole reach ahead first), so the
/// first motion does not wait for the smoothing. The motion is the same as without.
#[test]
fn a_rapid_into_a_cut_is_planned_before_the_cut_is_smoothed() {
    let mut text = String::from("G21 G90 G17\nG0 X60 Y0 Z0\nG64 P0.01\nG1 F3000\n");
    for i in 1..=20_000 {
        let u = i as f64 * 0.002;
        text.push_str(&format!("X{:.4} Y{u:.4}\n", 60.0 + 0.5 * (u * 0.8).sin()));
    }
    text.push_str("M30\n");
    let settings = with_lookahead(200.0);
    let mut feed = Feed::builder(&settings).open_text("rapid.ngc", text.clone()).expect("opens");
    feed.start().expect("starts");
    feed.plan(1e-9).expect("plans");
    let first = feed.progress();
    let mut got = Vec::new();
    while let Some(s) = feed.pop_segment() {
        got.push(s);
    }
    let to_mm = got.last().map_or(0.0, |s| s.s1_mm());
    assert!((to_mm - 60.0).abs() < 1e-9, "the first plan hands on up to s = {to_mm} mm, not the rapid");
    assert!(got.last().is_some_and(|s| s.at(s.dt_s).v.abs() < 1e-9), "the rapid does not end at rest");
    // The cut's first smoothing window reads some 50 mm of it; the rapid was planned after a
    // few of its lines.
    assert!(first.lines_read < 100, "{} lines read before the rapid was planned", first.lines_read);
    got.extend(plan_all(&mut feed, 1e-9, false));
    // The same motion as when the program is read a look-ahead ahead first, so the planner
    // takes the cut's first element before it plans the rapid.
    let reference = plan_all(&mut Feed::builder(&settings).open_text("rapid.ngc", text).expect("opens"), 1e-9, true);
    let (t, t_ref) = (profile_duration(&got), profile_duration(&reference));
    assert!((t - t_ref).abs() <= 1e-9 * t_ref, "motion {t} s, planned whole {t_ref} s");
}

/// What the reading thread runs first in these tests.
fn no_scheduling() {}

/// Read by a thread of its own, a program gives the same motion to the last bit as read in the
/// caller's thread, however it is asked for; modal changes and messages come through in order.
#[test]
fn a_program_read_in_a_thread_of_its_own_gives_the_same_motion() {
    let mut text = cam_program(2_000).replace("M30\n", "");
    text.push_str("(MSG, half way)\nG0 X0 Y0\nG1 X10 F3000\nM30\n");
    let settings = with_lookahead(20.0);
    let reference =
        plan_all(&mut Feed::builder(&settings).open_text("cam.ngc", text.clone()).expect("opens"), 1e-9, false);
    for (need_s, ahead) in [(1e-9, false), (1e-9, true), (0.05, true), (1e9, false)] {
        let mut feed =
            Feed::builder(&settings).read_in_thread(no_scheduling).open_text("cam.ngc", text.clone()).expect("opens");
        let got = plan_all(&mut feed, need_s, ahead);
        assert!(got == reference, "asking for {need_s} s, reading ahead {ahead}: the motion differs");
        let message = feed.take_message().expect("the message comes through the thread");
        assert!(message.text.contains("half way"), "{message:?}");
        assert_eq!(feed.progress().lines_read, feed.summary().expect("summary").lines);
        assert!(feed.summary().is_some_and(|s| s.program_end && s.messages == 1));
    }
}

/// A read error found by the reading thread is returned where the planner reaches it, after
/// the same elements as read in the caller's thread; dropping a feed whose thread is still
/// reading does not wait for it.
#[test]
fn the_reading_thread_keeps_an_error_for_the_planner_and_is_not_waited_for() {
    let text = stops_then_a_bad_line();
    let (plain, plain_error) =
        elements_until_error(&mut Feed::builder(&settings()).open_text("t.ngc", text.clone()).expect("opens"));
    let mut feed = Feed::builder(&settings()).read_in_thread(no_scheduling).open_text("t.ngc", text).expect("opens");
    feed.read_ahead(later());
    let (got, error) = elements_until_error(&mut feed);
    assert_eq!(got.len(), plain.len());
    assert_eq!(error, plain_error);

    let big = cam_program(19_000);
    let mut feed =
        Feed::builder(&with_lookahead(1e6)).read_in_thread(no_scheduling).open_text("big.ngc", big).expect("opens");
    // Sets the thread's target (the whole program) and takes nothing.
    feed.read_ahead(Instant::now());
    std::thread::sleep(Duration::from_millis(20));
    let dropped = Instant::now();
    drop(feed);
    assert!(dropped.elapsed() < Duration::from_millis(50), "the drop waited {:?}", dropped.elapsed());
}
