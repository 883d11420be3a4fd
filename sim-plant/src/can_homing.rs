//! Homing mode (0x6060 = 6) of the simulated CiA 402 drive: the drive moves its axis itself,
//! on the SYNC clock (its own time: one step per communication cycle), at the speeds of 0x6099
//! and the acceleration of 0x609A, until it has found the home position of the method in 0x6098.
//!
//! - Methods 35 and 37: the current position is the home position (no motion).
//! - Method 3: positive home switch and index pulse, home at the first index pulse below the
//!   switch edge. From below the edge (switch inactive) the axis searches the switch upward at
//!   the switch speed, reverses and passes the edge downward at the zero speed to that pulse;
//!   from above it moves down at the zero speed.
//! - Method 4: home at the first index pulse above the switch edge. From below the axis moves
//!   up through the edge, then on at the zero speed to the pulse; from above it first moves
//!   down at the switch speed until the switch turns off, then reverses.
//!
//! The home switch is active at positions at or above its edge; the index pulses lie at whole
//! multiples of the pitch (one encoder revolution), both in the plant's coordinates. Like the
//! touch probe of a real drive, the crossing of the pulse is latched exactly; the axis then
//! stops and moves back onto it, so it stands at the home position when homing is attained.
//! Leaving the travel (the limit switches at the axis's `min_pos`/`max_pos`) or a method the
//! drive does not implement is a homing error: the axis stops at the homing acceleration.

/// Homing methods this drive implements.
pub const METHODS: [i8; 4] = [3, 4, 35, 37];

/// The parameters of one homing run, converted to axis units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HomingParams {
    pub method: i8,
    /// 0x6099:1, axis units/s.
    pub speed_switch: f64,
    /// 0x6099:2, axis units/s.
    pub speed_zero: f64,
    /// 0x609A, axis units/s².
    pub acceleration: f64,
}

/// What the axis has to find home: its switch, its encoder's index pulses and its travel, in
/// plant coordinates (axis units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisSensors {
    /// The home switch is active at and above this position; `None`: there is no switch.
    pub home_switch: Option<f64>,
    /// Distance between index pulses (> 0).
    pub index_pitch: f64,
    /// The limit switches: leaving `[min, max]` is a homing error.
    pub travel: (f64, f64),
}

/// One leg of the search: move in `dir` at `speed` until the commanded position crosses `until`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Leg {
    dir: f64,
    speed: f64,
    until: f64,
}

#[derive(Debug, Clone, PartialEq)]
enum Phase {
    /// The legs still to run (the last one ends at the home position).
    Search(Vec<Leg>),
    /// The home position is latched; the axis stops, then moves back onto it.
    Return,
    /// Commanded onto the home position: one cycle for the axis to get there.
    Settle,
    /// Standing at the home position: homing attained.
    Attained,
    /// Stopping after an error, then standing.
    Error,
    /// Stopping because the master took bit 4 away (homing interrupted), then standing.
    Halt,
}

/// How a homing run stands after a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HomingState {
    Running,
    /// At the home position (plant coordinates).
    Attained {
        home: f64,
    },
    /// The run failed (the reason); the axis stops or stands.
    Failed(HomingError),
}

/// Why a homing run failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HomingError {
    /// 0x6098 holds a method this drive does not implement.
    UnsupportedMethod(i8),
    /// The axis reached the end of its travel without finding the home position.
    TravelEnd,
    /// A speed or the acceleration is zero.
    ZeroSpeed,
}

/// A homing run in progress.
#[derive(Debug, Clone, PartialEq)]
pub struct Homing {
    p: HomingParams,
    travel: (f64, f64),
    /// Commanded position and velocity, plant coordinates.
    pos: f64,
    vel: f64,
    phase: Phase,
    home: f64,
    error: Option<HomingError>,
}

impl Homing {
    /// Starts homing with the axis standing at `pos` (plant coordinates).
    pub fn start(p: HomingParams, sensors: &AxisSensors, pos: f64) -> Homing {
        let mut h = Homing { p, travel: sensors.travel, pos, vel: 0.0, phase: Phase::Attained, home: pos, error: None };
        let moving = !matches!(p.method, 35 | 37);
        let bad_speed = !(p.speed_switch > 0.0 && p.speed_zero > 0.0 && p.acceleration > 0.0);
        if moving && bad_speed {
            h.fail(HomingError::ZeroSpeed);
            return h;
        }
        let pitch = sensors.index_pitch;
        // Without a switch the search goes on until the travel ends.
        let edge = sensors.home_switch.unwrap_or(f64::INFINITY);
        let below = pos < edge;
        let (sw, zero) = (p.speed_switch, p.speed_zero);
        let legs = match p.method {
            35 | 37 => return h,
            3 => {
                let home = ((edge / pitch).ceil() - 1.0) * pitch;
                h.home = home;
                if below {
                    vec![Leg { dir: 1.0, speed: sw, until: edge }, Leg { dir: -1.0, speed: zero, until: home }]
                } else {
                    vec![Leg { dir: -1.0, speed: zero, until: home }]
                }
            }
            4 => {
                let home = ((edge / pitch).floor() + 1.0) * pitch;
                h.home = home;
                if below {
                    vec![Leg { dir: 1.0, speed: sw, until: edge }, Leg { dir: 1.0, speed: zero, until: home }]
                } else {
                    vec![Leg { dir: -1.0, speed: sw, until: edge }, Leg { dir: 1.0, speed: zero, until: home }]
                }
            }
            m => {
                h.fail(HomingError::UnsupportedMethod(m));
                return h;
            }
        };
        h.phase = Phase::Search(legs.into_iter().rev().collect());
        h
    }

    /// The master ended the run before it was done (controlword bit 4 low): the axis stops at
    /// the homing acceleration; homing is not attained.
    pub fn halt(&mut self) {
        if matches!(self.phase, Phase::Search(_) | Phase::Return | Phase::Settle) {
            self.phase = Phase::Halt;
        }
    }

    /// Whether the axis still moves under this run (searching, returning or stopping).
    pub fn is_moving(&self) -> bool {
        !matches!(self.phase, Phase::Attained | Phase::Error | Phase::Halt) || self.vel != 0.0
    }

    /// Whether the run has found the home position and commands it.
    pub fn is_attained(&self) -> bool {
        self.phase == Phase::Attained
    }

    fn fail(&mut self, e: HomingError) {
        self.error = Some(e);
        self.phase = Phase::Error;
    }

    /// The commanded position, plant coordinates.
    pub fn position(&self) -> f64 {
        self.pos
    }

    /// One communication cycle of `dt_s`: the new commanded position and the state.
    pub fn step(&mut self, dt_s: f64) -> HomingState {
        let acc = self.p.acceleration;
        match &mut self.phase {
            Phase::Search(legs) => {
                let Some(&leg) = legs.last() else {
                    self.phase = Phase::Return;
                    return HomingState::Running;
                };
                let before = self.pos;
                let (pos, vel) = accelerate(self.pos, self.vel, leg.dir * leg.speed, acc, dt_s);
                (self.pos, self.vel) = (pos, vel);
                let crossed = if leg.dir > 0.0 {
                    before < leg.until && pos >= leg.until
                } else {
                    before > leg.until && pos <= leg.until
                };
                if crossed {
                    legs.pop();
                    if legs.is_empty() {
                        // The index pulse is latched where it was crossed.
                        self.phase = Phase::Return;
                    }
                }
                if pos < self.travel.0 || pos > self.travel.1 {
                    self.fail(HomingError::TravelEnd);
                }
            }
            Phase::Return => {
                // Stop, then a move at the zero speed onto the latched position.
                let to_go = self.home - self.pos;
                let reach = (2.0 * acc * to_go.abs()).sqrt().min(self.p.speed_zero);
                let heading_away = self.vel * to_go < 0.0;
                let v_des = if heading_away { 0.0 } else { to_go.signum() * reach };
                self.accelerate_toward(v_des, acc, dt_s);
                let remaining = self.home - self.pos;
                if remaining.abs() <= acc * dt_s * dt_s || (remaining * to_go < 0.0 && !heading_away) {
                    self.pos = self.home;
                    self.vel = 0.0;
                    self.phase = Phase::Settle;
                }
            }
            Phase::Settle => self.phase = Phase::Attained,
            Phase::Attained | Phase::Error | Phase::Halt => {
                self.accelerate_toward(0.0, if acc > 0.0 { acc } else { f64::INFINITY }, dt_s);
            }
        }
        match (&self.phase, self.error) {
            (_, Some(e)) => HomingState::Failed(e),
            (Phase::Attained, None) => HomingState::Attained { home: self.home },
            _ => HomingState::Running,
        }
    }

    fn accelerate_toward(&mut self, v_des: f64, acc: f64, dt_s: f64) {
        (self.pos, self.vel) = accelerate(self.pos, self.vel, v_des, acc, dt_s);
    }
}

/// Velocity toward `v_des` by at most `acc · dt`, position by the mean velocity: the new
/// position and velocity.
fn accelerate(pos: f64, vel: f64, v_des: f64, acc: f64, dt_s: f64) -> (f64, f64) {
    let dv = (v_des - vel).clamp(-acc * dt_s, acc * dt_s);
    let v = vel + dv;
    (pos + 0.5 * (vel + v) * dt_s, v)
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 0.004;

    fn params(method: i8) -> HomingParams {
        HomingParams { method, speed_switch: 10.0, speed_zero: 1.0, acceleration: 100.0 }
    }

    fn sensors() -> AxisSensors {
        AxisSensors { home_switch: Some(12.5), index_pitch: 5.0, travel: (-100.0, 100.0) }
    }

    /// Runs to the end; the final state, the cycles and the extreme positions.
    fn run(h: &mut Homing) -> (HomingState, usize, f64, f64) {
        let (mut lo, mut hi) = (h.position(), h.position());
        for k in 1..200_000 {
            let s = h.step(DT);
            lo = lo.min(h.position());
            hi = hi.max(h.position());
            if s != HomingState::Running {
                // Standing: a few more cycles change nothing.
                return (s, k, lo, hi);
            }
        }
        panic!("homing does not end");
    }

    #[test]
    fn current_position_methods_attain_at_once() {
        for m in [35, 37] {
            let mut h = Homing::start(params(m), &sensors(), 3.25);
            assert_eq!(run(&mut h).0, HomingState::Attained { home: 3.25 });
            assert_eq!(h.position(), 3.25);
        }
    }

    #[test]
    fn method_3_homes_on_the_index_below_the_switch_from_either_side() {
        for start in [0.0, 20.0] {
            let mut h = Homing::start(params(3), &sensors(), start);
            let (s, cycles, _, hi) = run(&mut h);
            assert_eq!(s, HomingState::Attained { home: 10.0 }, "from {start}");
            assert_eq!(h.position(), 10.0);
            if start == 0.0 {
                assert!(hi > 12.5, "went up through the switch edge: {hi}");
            }
            assert!(cycles > 100, "{cycles}");
        }
    }

    #[test]
    fn method_4_homes_on_the_index_above_the_switch_from_either_side() {
        for start in [0.0, 30.0] {
            let mut h = Homing::start(params(4), &sensors(), start);
            let (s, _, lo, _) = run(&mut h);
            assert_eq!(s, HomingState::Attained { home: 15.0 }, "from {start}");
            assert_eq!(h.position(), 15.0);
            if start == 30.0 {
                assert!(lo < 12.5, "went down until the switch turned off: {lo}");
            }
        }
    }

    #[test]
    fn no_switch_ends_at_the_travel_and_unknown_methods_fail() {
        let none = AxisSensors { home_switch: None, ..sensors() };
        let mut h = Homing::start(params(3), &none, 0.0);
        let (s, _, _, hi) = run(&mut h);
        assert_eq!(s, HomingState::Failed(HomingError::TravelEnd));
        assert!(hi > 100.0 && hi < 101.0, "{hi}");
        let mut h = Homing::start(params(1), &sensors(), 0.0);
        assert_eq!(h.step(DT), HomingState::Failed(HomingError::UnsupportedMethod(1)));
        let mut h = Homing::start(HomingParams { speed_zero: 0.0, ..params(4) }, &sensors(), 0.0);
        assert_eq!(h.step(DT), HomingState::Failed(HomingError::ZeroSpeed));
    }
}
