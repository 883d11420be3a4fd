//! Proof that the real-time cycle never allocates: a counting global allocator counts every
//! allocation, reallocation and free made while a thread is inside a cycle (the loop marks
//! that in `interpd::rt::IN_CYCLE`), while the real service runs programs with a hold, a
//! resume, feed override changes, a stop and an underrun, and manual motion (move-to, jogs,
//! MDI, a jog from a hold and the resume back), publishing over real iceoryx2.

use interpd::config::Config;
use interpd::control::{Motion, ProgramSource};
use interpd::service::{Service, ServiceOptions};
use interpd_protocol::api::State;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

struct Counting;
static IN_CYCLE_ALLOCS: AtomicU64 = AtomicU64::new(0);
static ALL_ALLOCS: AtomicU64 = AtomicU64::new(0);

fn note() {
    ALL_ALLOCS.fetch_add(1, Ordering::Relaxed);
    // try_with: the thread-local may be gone while a thread shuts down.
    if interpd::rt::IN_CYCLE.try_with(|c| c.get()).unwrap_or(false) {
        IN_CYCLE_ALLOCS.fetch_add(1, Ordering::Relaxed);
    }
}

// SAFETY: forwards to the system allocator; counting has no effect on the memory handed out.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        note();
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

const PROGRAM: &str =
    "G21 G90 G17\nG1 X20 F6000\nG2 X40 Y0 I10 J0\nG1 X40 Y30\nG3 X20 Y30 I-10 J0\nG1 X0 Y0\nG4 P0.1\nG1 X10 Y10\nM30\n";

fn run(core: &interpd::service::ServiceCore, steps: &[(&str, u64)]) {
    core.load(ProgramSource::Text { name: "alloc.ngc".into(), text: PROGRAM.into() }, false).expect("load");
    core.start().expect("start");
    for &(what, after_ms) in steps {
        std::thread::sleep(Duration::from_millis(after_ms));
        match what {
            "hold" => core.hold().expect("hold"),
            "resume" => core.resume().expect("resume"),
            "stop" => core.stop().expect("stop"),
            "fast" => core.set_override(1.5).expect("override"),
            "slow" => core.set_override(0.4).expect("override"),
            _ => unreachable!(),
        }
    }
    let s = core.wait_for(&[State::Finished, State::Idle, State::Error], Duration::from_secs(30));
    assert!(matches!(s, State::Finished | State::Idle), "ended in {s}");
}

/// Manual motion: a move-to, a continuous jog changed while moving and stopped, a jog by a
/// distance, MDI blocks, and a jog from a held program followed by the resume back to it.
/// Program stops: paused at M0, resumed, paused at M1, stopped there; operator messages before
/// and after the stop and between moves (their markers are read in the cycle).
fn paused(core: &interpd::service::ServiceCore) {
    let text = "G1 X5 F1200\n(DEBUG,x=#5420)\nM0\n(MSG,on)\nG1 X10\n(PRINT,%d#5420)\nG1 X11\nM1\nG1 X0\nM2\n";
    core.load(ProgramSource::Text { name: "stops.ngc".into(), text: text.into() }, false).expect("load");
    core.start().expect("start");
    assert_eq!(core.wait_for(&[State::Paused], Duration::from_secs(30)), State::Paused);
    std::thread::sleep(Duration::from_millis(100));
    core.resume().expect("resume");
    std::thread::sleep(Duration::from_millis(20));
    assert_eq!(core.wait_for(&[State::Paused], Duration::from_secs(30)), State::Paused);
    std::thread::sleep(Duration::from_millis(100));
    core.stop().expect("stop");
    assert_eq!(core.wait_for(&[State::Idle], Duration::from_secs(30)), State::Idle);
}

fn manual(core: &interpd::service::ServiceCore) {
    use interpd_protocol::api::{JogMode, JogParams, MdiParams, MoveToParams};
    let axes = |pairs: &[(&str, f64)]| pairs.iter().map(|(a, v)| (a.to_string(), *v)).collect();
    let done = |states: &[State]| {
        let s = core.wait_for(states, Duration::from_secs(30));
        assert!(states.contains(&s), "ended in {s}");
    };
    let settle = || std::thread::sleep(Duration::from_millis(100));
    let target = axes(&[("X", 20.0), ("Y", -5.0)]);
    core.move_to(&MoveToParams { target, velocity: Default::default(), velocity_factor: 1.0 }).expect("move_to");
    settle();
    done(&[State::Idle]);
    core.jog(&JogParams { axes: axes(&[("X", 80.0)]), mode: JogMode::Velocity }).expect("jog");
    std::thread::sleep(Duration::from_millis(150));
    core.jog(&JogParams { axes: axes(&[("X", -40.0), ("Y", 30.0)]), mode: JogMode::Velocity }).expect("jog");
    std::thread::sleep(Duration::from_millis(150));
    core.jog_stop().expect("jog_stop");
    settle();
    done(&[State::Idle]);
    core.jog(&JogParams { axes: axes(&[("Z", 1.5)]), mode: JogMode::Distance }).expect("jog");
    settle();
    done(&[State::Idle]);
    core.mdi(&MdiParams { line: "G91 G1 X5 F3000\nY2".into() }).expect("mdi");
    settle();
    done(&[State::Finished]);
    core.load(ProgramSource::Text { name: "alloc.ngc".into(), text: PROGRAM.into() }, false).expect("load");
    core.start().expect("start");
    std::thread::sleep(Duration::from_millis(300));
    core.hold().expect("hold");
    std::thread::sleep(Duration::from_millis(300));
    core.jog(&JogParams { axes: axes(&[("Z", 3.0)]), mode: JogMode::Distance }).expect("jog from the hold");
    settle();
    done(&[State::Holding]);
    core.resume().expect("resume");
    done(&[State::Finished]);
}

/// The two tests share the counters: one at a time.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

#[test]
fn the_cycle_never_allocates() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    // The probe works: an allocation inside a (pretended) cycle is counted.
    interpd::rt::IN_CYCLE.with(|c| c.set(true));
    let probe = std::hint::black_box(vec![1u8; 64]);
    drop(probe);
    interpd::rt::IN_CYCLE.with(|c| c.set(false));
    assert!(
        IN_CYCLE_ALLOCS.swap(0, Ordering::Relaxed) >= 1,
        "the counting allocator does not see in-cycle allocations"
    );
    let mut config = Config::default_machine();
    config.sinks.shm_prefix = format!("interpd-test/alloc{}", std::process::id());
    let service = Service::start(ServiceOptions { config, shm: true }).expect("service");
    let core = service.core();
    // A whole program; one with hold, resume and override changes; one stopped midway; one
    // with a stalled planner (underrun); one paused at its program stops.
    run(&core, &[]);
    run(&core, &[("fast", 150), ("hold", 150), ("resume", 300), ("slow", 100)]);
    run(&core, &[("stop", 250)]);
    core.debug_stall_planner(0.2, 0.4);
    run(&core, &[]);
    paused(&core);
    manual(&core);
    let report = service.shutdown();
    let in_cycle = IN_CYCLE_ALLOCS.load(Ordering::Relaxed);
    eprintln!(
        "{} cycles; allocations inside cycles: {in_cycle}; allocations elsewhere meanwhile: {}",
        report.totals.cycles,
        ALL_ALLOCS.load(Ordering::Relaxed)
    );
    assert!(report.totals.cycles > 500, "too few cycles ran: {}", report.totals.cycles);
    assert!(ALL_ALLOCS.load(Ordering::Relaxed) > 0, "the counting allocator saw nothing: the test could not fail");
    assert_eq!(in_cycle, 0, "the real-time cycle allocated or freed memory");
}

/// The cycle with the compensation stage (mid-ranging on X and Y, position control on nothing
/// else) against the real plant over iceoryx2: measurements in, actuator commands out, every
/// cycle, and still no allocation in it.
#[test]
fn the_compensation_stage_never_allocates() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    IN_CYCLE_ALLOCS.store(0, Ordering::Relaxed);
    let machine = include_str!("../../examples/milling_circle.toml");
    let text = format!(
        "{machine}\n[compensation]\n[compensation.measurement]\nforce_axes = [\"X\", \"Y\"]\nposition_axes = \
         [\"X\", \"Y\"]\nactuator_axes = [\"X\", \"Y\"]\n[[compensation.axis]]\nname = \"X\"\nstrategy = \
         \"position+actuator\"\n[[compensation.axis]]\nname = \"Y\"\nstrategy = \"position\"\n"
    );
    let mut config = Config::from_toml_str(&text, "milling").expect("config");
    let prefix = format!("interpd-test/comp-alloc{}", std::process::id());
    config.sinks.shm_prefix = prefix.clone();
    // The plant in a thread of this process, on the same services.
    let mut plant = sim_plant::Plant::from_config(&config).expect("plant");
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let plant_prefix = prefix.clone();
    let plant_thread = std::thread::spawn(move || {
        // iceoryx2 ports stay in the thread that creates them.
        let mut node = sim_plant::shm::ShmPlant::open(&plant_prefix).expect("plant node");
        node.open_process_io(&plant).expect("plant measurement");
        ready_tx.send(()).expect("ready");
        let options = sim_plant::shm::RunOptions { exit_on_finish: true, settle_s: 0.1, ..Default::default() };
        node.run(&mut plant, None, &options).expect("plant run");
        plant
    });
    ready_rx.recv().expect("the plant is ready");
    let service = Service::start(ServiceOptions { config, shm: true }).expect("service");
    let core = service.core();
    let program = "G21 G90 G17\nG1 X5 F600\nG3 X5 Y0 I-5 J0\nG1 X0 Y0\nM30\n";
    core.load(ProgramSource::Text { name: "comp.ngc".into(), text: program.into() }, false).expect("load");
    core.start().expect("start");
    let s = core.wait_for(&[State::Finished, State::Error], Duration::from_secs(30));
    assert_eq!(s, State::Finished);
    let plant = plant_thread.join().expect("plant thread");
    let report = service.shutdown();
    let in_cycle = IN_CYCLE_ALLOCS.load(Ordering::Relaxed);
    let comp = report.compensation.expect("the stage ran");
    eprintln!(
        "{} cycles; {comp:?}; actuator X used up to {:.4} mm",
        report.totals.cycles,
        plant.actuator(0).map_or(0.0, |a| a.max_abs_m() * 1e3)
    );
    assert!(comp.accepted > 500, "the stage saw too few measurements: {comp:?}");
    assert!(plant.actuator(0).is_some_and(|a| a.max_abs_m() > 0.0), "no actuator command reached the plant");
    assert_eq!(in_cycle, 0, "the real-time cycle with compensation allocated or freed memory");
}
