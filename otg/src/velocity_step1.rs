//! Step 1, velocity interface: reach a target velocity and acceleration (position free) in
//! minimum time; used for feed-override ramps and jogging. At most three phases: ramp, hold at
//! the acceleration limit, ramp (Ruckig RSS 2021, Sec. V-B). In the normalised frame
//! (j_max = a_max = 1) the peak acceleration of the ramp-up / ramp-down triangle is
//! ±sqrt(Δv + (a0² + a_f²)/2); with a hold at the limit the hold length is linear in Δv.

use crate::block::Block;
use crate::brake::BrakeProfile;
use crate::frame::{Candidate, Frame, Orientation, Polish};
use crate::position_step1::{Collector, opposite};
use crate::profile::{JerkSigns, PolishSpec, ReachedLimits};
use crate::{Limits, State};

/// Target accelerations below this (normalised) count as zero: then there is no blocked
/// interval and the first valid profile is the optimum.
const REST_EPS: f64 = f64::EPSILON;
const JERKS: [f64; 7] = [1.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0];
const ROWS: u8 = PolishSpec::END_A | PolishSpec::END_V;

/// Step 1 for one DoF from the (braked) start state.
pub(crate) fn calculate(start: &State, target: &State, limits: &Limits, brake: &BrakeProfile) -> Option<Block> {
    let mut col = Collector::new(*start, *target, limits, *brake, false);
    let zero = col.add_zero();
    let f_up = Frame::new(Orientation::Up, start, target, limits);
    if f_up.af.abs() < REST_EPS {
        if zero {
            return col.fastest().map(Block::single);
        }
        let first = if target.v >= start.v { Orientation::Up } else { Orientation::Down };
        for orientation in [first, opposite(first)] {
            let frame =
                if orientation == Orientation::Up { f_up } else { Frame::new(orientation, start, target, limits) };
            if triangle(&frame, &mut col) || trapezoid(&frame, &mut col) {
                return col.fastest().map(Block::single);
            }
        }
        None
    } else {
        let f_down = Frame::new(Orientation::Down, start, target, limits);
        for frame in [&f_up, &f_down] {
            triangle(frame, &mut col);
            trapezoid(frame, &mut col);
        }
        Block::from_profiles(col.found())
    }
}

/// Ramp up to a peak (either root), ramp down to a_f.
fn triangle(f: &Frame, col: &mut Collector) -> bool {
    let peak_sq = f.vf - f.v0 + 0.5 * (f.a0 * f.a0 + f.af * f.af);
    if !(peak_sq >= 0.0) {
        return false;
    }
    let mut found = false;
    for peak in [peak_sq.sqrt(), -peak_sq.sqrt()] {
        if peak > 1.0 || peak < f.a0 || peak < f.af {
            continue;
        }
        let c = Candidate {
            t: [peak - f.a0, 0.0, peak - f.af, 0.0, 0.0, 0.0, 0.0],
            j: JERKS,
            limits: ReachedLimits::None,
            signs: JerkSigns::Uddu,
            polish: Polish::new(&[0, 2], ROWS),
        };
        found |= col.add(f, &c);
        if peak == 0.0 {
            break;
        }
    }
    found
}

/// Ramp up to the acceleration limit, hold, ramp down to a_f.
fn trapezoid(f: &Frame, col: &mut Collector) -> bool {
    if f.a0 > 1.0 || f.af > 1.0 {
        return false;
    }
    let hold = f.vf - f.v0 + 0.5 * (f.a0 * f.a0 + f.af * f.af) - 1.0;
    if hold < 0.0 {
        return false;
    }
    let c = Candidate {
        t: [1.0 - f.a0, hold, 1.0 - f.af, 0.0, 0.0, 0.0, 0.0],
        j: JERKS,
        limits: ReachedLimits::Acc0,
        signs: JerkSigns::Uddu,
        polish: Polish::new(&[1], PolishSpec::END_V),
    };
    col.add(f, &c)
}
