//! The update API is allocation-free: `Otg::calculate`, `Trajectory::at_time`, `state_of` and
//! `phase_at`, called every cycle, never touch the heap. A counting global allocator counts the
//! allocations this thread makes while the calls run, over every kind of problem of the
//! property test (brake pre-phases, step 2, the long-duration fallback, phase synchronisation,
//! velocity interface, discrete durations) and over rejected input.

mod common;

use common::{KINDS, Rng, random_problem};
use interpd_otg::{Input, MAX_DOFS, Otg, State, Trajectory};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// The system allocator, counting the allocations of threads that enabled counting.
struct Counting;

thread_local! {
    /// Whether this thread counts, and its count (per thread: tests run in parallel).
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

fn count() {
    if COUNTING.try_with(Cell::get).unwrap_or(false) {
        let _ = ALLOCATIONS.try_with(|n| n.set(n.get() + 1));
    }
}

// SAFETY: every call is forwarded unchanged to the system allocator; counting has no effect on
// the memory handed out.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations made by `f` on this thread.
fn allocations_in(f: impl FnOnce()) -> usize {
    let before = ALLOCATIONS.with(Cell::get);
    COUNTING.with(|c| c.set(true));
    f();
    COUNTING.with(|c| c.set(false));
    ALLOCATIONS.with(Cell::get) - before
}

/// One control cycle's worth of calls: calculate, then sample the trajectory.
fn cycle(otg: &mut Otg, traj: &mut Trajectory, input: &Input, states: &mut [State; MAX_DOFS]) -> usize {
    let mut touched = 0;
    if otg.calculate(input, traj).is_ok() {
        for k in 0..=16 {
            let t = traj.duration() * k as f64 / 16.0;
            traj.at_time(t, states);
            for dof in 0..traj.dofs() {
                let (s, _) = traj.state_of(dof, t);
                touched += usize::from(s.p.is_finite()) + traj.phase_at(dof, t);
            }
        }
    }
    touched
}

#[test]
fn the_counter_sees_allocations() {
    // Guards the test below: a counter that never counts would make it pass vacuously.
    let n = allocations_in(|| {
        let v: Vec<u64> = std::hint::black_box((0..100).collect());
        assert_eq!(v.len(), 100);
    });
    assert!(n >= 1, "counted {n}");
}

#[test]
fn calculate_and_sampling_do_not_allocate() {
    let mut rng = Rng::new(0xA110C);
    let mut inputs: Vec<Input> = Vec::new();
    for &kind in &KINDS {
        for i in 0..300 {
            inputs.push(random_problem(&mut rng, kind, [1, 2, 3, 6, MAX_DOFS][i % 5]));
        }
    }
    // Rejected input goes through the same call.
    let mut bad = inputs[0];
    bad.limits[0].j_max = f64::NAN;
    inputs.push(bad);
    let mut with_min_duration = inputs[1];
    with_min_duration.min_duration_s = Some(100.0);
    inputs.push(with_min_duration);

    let mut otg = Otg::new();
    let mut traj = Trajectory::default();
    let mut states = [State::default(); MAX_DOFS];
    let mut touched = 0;
    let n = allocations_in(|| {
        for input in &inputs {
            touched += cycle(&mut otg, &mut traj, input, &mut states);
        }
    });
    assert!(touched > 0);
    assert_eq!(n, 0, "{n} allocations in {} calculations", inputs.len());
}
