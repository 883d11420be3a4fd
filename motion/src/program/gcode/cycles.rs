//! Canned drilling cycles G73 G81 G82 G83 G85 G89 (with G98/G99, R, Q, P, L; G80 cancels),
//! expanded into rapid and feed moves and dwells in the order LinuxCNC's `interp_cycles.cc`
//! makes them (`convert_cycle_xy` and the `convert_cycle_g8x` functions), our own code.
//!
//! In the active plane the cycle works on the plane's two axes (`aa`, `bb`) and the axis normal
//! to it (`cc`: Z in G17, Y in G18, X in G19). Coordinates here are program coordinates in
//! program units, as in LinuxCNC; the moves are converted at the end.

use super::{Block, Interpreter, POLAR_ANGLE, POLAR_RADIUS, polar_increment};
use crate::path::{Blend, Feed, Source};
use crate::program::error::Diagnostics;
use interpd_config::AxisLetter;

/// Which cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum CycleKind {
    G73,
    G81,
    G82,
    G83,
    G85,
    G89,
}

impl CycleKind {
    fn name(self) -> &'static str {
        match self {
            CycleKind::G73 => "G73",
            CycleKind::G81 => "G81",
            CycleKind::G82 => "G82",
            CycleKind::G83 => "G83",
            CycleKind::G85 => "G85",
            CycleKind::G89 => "G89",
        }
    }
}

/// What the cycles keep between blocks (LinuxCNC's `cycle_*` settings).
#[derive(Debug, Clone)]
pub(crate) struct CycleState {
    /// The normal axis' position where the cycles started (the G98 return level), while
    /// cycles follow each other.
    pub il: Option<f64>,
    pub r: f64,
    /// The last Z (normal axis) word, as given.
    pub cc: f64,
    pub p: f64,
    pub q: f64,
    /// G99 (LinuxCNC's interpreter's initial mode): retract to R; G98: to the level where
    /// the cycles started.
    pub retract_r: bool,
}

impl Default for CycleState {
    fn default() -> Self {
        Self { il: None, r: 0.0, cc: 0.0, p: 0.0, q: 0.0, retract_r: true }
    }
}

/// The peck drilling retract clearance of G73 and G83, mm: what LinuxCNC's interpreter (the
/// Debian package's `rs274` and `gcode` module, no INI) uses, in either unit system.
const PECK_CLEARANCE_MM: f64 = 0.254;

/// One move of a cycle, in program coordinates: rapid or feed, to (aa, bb, cc).
#[derive(Clone, Copy)]
enum Step {
    Rapid(f64, f64, f64),
    Feed(f64, f64, f64),
    Dwell(f64),
}

impl Interpreter {
    /// Executes the cycle `kind` for this block; `same` when the cycle was already the motion
    /// mode (R, Z, P, Q may then be left out).
    pub(in crate::program) fn canned_cycle(
        &mut self,
        kind: CycleKind,
        same: bool,
        block: &Block,
        source: Source,
        d: &mut Diagnostics,
    ) {
        let line = block.line;
        let col0 = block.words[0].col;
        let name = kind.name();
        if self.cutter.is_on() {
            d.error(
                line,
                col0,
                format!("{name}: canned cycles cannot run with cutter compensation on (program G40 first)"),
            );
            return;
        }
        if self.modal.inverse_time {
            d.error(line, col0, format!("{name}: canned cycles cannot run in inverse time (G93)"));
            return;
        }
        let Some(feed) = self.modal.feed_mm_s else {
            d.error(line, col0, format!("{name} without feed: program F (mm/min) before or in this block"));
            return;
        };
        let letters = self.cycle_letters();
        let Some(idx) = letters.map(|l| self.settings.axis_index(l)).into_iter().collect::<Option<Vec<_>>>() else {
            d.error(
                line,
                col0,
                format!(
                    "{name} in {} needs axes {} {} {} on this machine",
                    self.plane_name(),
                    letters[0],
                    letters[1],
                    letters[2]
                ),
            );
            return;
        };
        for w in block.words.iter() {
            if let Some(l) = AxisLetter::from_char(w.letter) {
                if !letters.contains(&l) {
                    d.error(
                        line,
                        w.col,
                        format!(
                            "{name}: only {} {} {} may move in a canned cycle in {}",
                            letters[0],
                            letters[1],
                            letters[2],
                            self.plane_name()
                        ),
                    );
                    return;
                }
            }
        }
        let unit = self.modal.unit_mm;
        let prog = |s: &Self, k: usize| s.program_coord(k) / unit;
        let (cur_a, cur_b, cur_c) = (prog(self, idx[0]), prog(self, idx[1]), prog(self, idx[2]));
        let word = |c: char| block.get(c);
        let (wa, wb, wc) = (word(letters[0].as_char()), word(letters[1].as_char()), word(letters[2].as_char()));
        // LinuxCNC's polar words (`convert_cycle_xy`): in G17 only, in place of X and Y.
        let (radius_w, angle_w) = (word(POLAR_RADIUS), word(POLAR_ANGLE));
        if let Some(pw) = radius_w.or(angle_w) {
            if letters[2] != AxisLetter::Z {
                d.error(line, pw.col, "polar coordinates (@ ^) are only valid in the XY plane (G17)");
                return;
            }
            if let Some(w) = wa.or(wb) {
                d.error(line, w.col, format!("{} and polar coordinates (@ ^) in one block", w.letter));
                return;
            }
        }
        let r_word = word('R');
        let l_word = word('L');
        let r_given = match r_word {
            Some(w) => w.value,
            None if same => self.cycle.r,
            None => {
                d.error(line, col0, format!("{name} needs R (the retract plane) when it starts"));
                return;
            }
        };
        let z_given = match wc {
            Some(w) => w.value,
            None if same => self.cycle.cc,
            None => {
                d.error(line, col0, format!("{name} needs {} (the bottom of the hole) when it starts", letters[2]));
                return;
            }
        };
        let repeats = match l_word {
            None => 1,
            Some(w) if w.value >= 1.0 && w.value.fract() == 0.0 && w.value <= 1e6 => w.value as u64,
            Some(w) => {
                d.error(line, w.col, format!("{name}: L (repeats) must be a positive integer, got {}", w.value));
                return;
            }
        };
        let dwell = if matches!(kind, CycleKind::G82 | CycleKind::G89) {
            match word('P') {
                Some(p) if p.value < 0.0 => {
                    d.error(line, p.col, format!("dwell time P must not be negative, got {}", p.value));
                    return;
                }
                Some(p) => p.value,
                None if same => self.cycle.p,
                None => {
                    d.error(line, col0, format!("{name} needs P (the dwell, seconds) when it starts"));
                    return;
                }
            }
        } else {
            0.0
        };
        let delta = if matches!(kind, CycleKind::G73 | CycleKind::G83) {
            let q = match word('Q') {
                Some(q) => q.value,
                None if same => self.cycle.q,
                None => {
                    d.error(line, col0, format!("{name} needs Q (the peck depth) when it starts"));
                    return;
                }
            };
            if q <= 0.0 {
                d.error(
                    line,
                    word('Q').map_or(col0, |w| w.col),
                    format!("{name}: Q (the peck depth) must be positive, got {q}"),
                );
                return;
            }
            q
        } else {
            0.0
        };
        let old_c = *self.cycle.il.get_or_insert(cur_c);
        let (mut aa, mut bb, a_inc, b_inc, r, cc) = if self.modal.absolute && (radius_w.is_some() || angle_w.is_some())
        {
            let radius = radius_w.map_or(cur_a.hypot(cur_b), |w| w.value);
            let theta = angle_w.map_or(cur_b.atan2(cur_a), |w| w.value.to_radians());
            (radius * theta.cos(), radius * theta.sin(), 0.0, 0.0, r_given, z_given)
        } else if self.modal.absolute {
            (wa.map_or(cur_a, |w| w.value), wb.map_or(cur_b, |w| w.value), 0.0, 0.0, r_given, z_given)
        } else {
            let r = r_given + old_c;
            (cur_a, cur_b, wa.map_or(0.0, |w| w.value), wb.map_or(0.0, |w| w.value), r, r + z_given)
        };
        if r < cc {
            d.error(
                line,
                r_word.map_or(col0, |w| w.col),
                format!("{name}: the retract plane R lies below the bottom {} of the hole", letters[2]),
            );
            return;
        }
        let mut steps = Vec::new();
        let (mut old_c, mut cur_c) = (old_c, cur_c);
        if old_c < r {
            steps.push(Step::Rapid(cur_a, cur_b, r));
            old_c = r;
            cur_c = r;
        }
        let clear = if self.cycle.retract_r { r } else { old_c };
        // G91: the polar increments apply at every repeat (LinuxCNC's `CYCLE_MACRO`; a zero
        // one is none).
        let polar_inc = if self.modal.absolute {
            (None, None)
        } else {
            (radius_w.map(|w| w.value).filter(|v| *v != 0.0), angle_w.map(|w| w.value).filter(|v| *v != 0.0))
        };
        for rep in 0..repeats {
            aa += a_inc;
            bb += b_inc;
            if polar_inc.0.is_some() || polar_inc.1.is_some() {
                if aa == 0.0 && bb == 0.0 {
                    d.error(
                        line,
                        col0,
                        format!("{name}: incremental polar coordinates (G91) are indeterminate at the origin"),
                    );
                    return;
                }
                (aa, bb) = polar_increment(aa, bb, polar_inc.0, polar_inc.1);
            }
            if rep == 0 && cur_c > r {
                steps.push(Step::Rapid(aa, bb, cur_c));
                steps.push(Step::Rapid(aa, bb, r));
            } else {
                steps.push(Step::Rapid(aa, bb, clear));
                if clear > r {
                    steps.push(Step::Rapid(aa, bb, r));
                }
            }
            match kind {
                CycleKind::G81 => steps.extend([Step::Feed(aa, bb, cc), Step::Rapid(aa, bb, clear)]),
                CycleKind::G82 => {
                    steps.extend([Step::Feed(aa, bb, cc), Step::Dwell(dwell), Step::Rapid(aa, bb, clear)])
                }
                CycleKind::G85 => {
                    steps.extend([Step::Feed(aa, bb, cc), Step::Feed(aa, bb, r), Step::Rapid(aa, bb, clear)])
                }
                CycleKind::G89 => steps.extend([Step::Feed(aa, bb, cc), Step::Dwell(dwell), Step::Feed(aa, bb, clear)]),
                CycleKind::G73 | CycleKind::G83 => {
                    let back = PECK_CLEARANCE_MM / unit;
                    let mut depth = r - delta;
                    while depth > cc {
                        // Checked per peck: a huge depth over a small Q would fill memory
                        // before the check after the hole.
                        if steps.len() > MAX_CYCLE_STEPS {
                            break;
                        }
                        steps.push(Step::Feed(aa, bb, depth));
                        if kind == CycleKind::G83 {
                            steps.push(Step::Rapid(aa, bb, r));
                        }
                        steps.push(Step::Rapid(aa, bb, depth + back));
                        depth -= delta;
                    }
                    steps.extend([Step::Feed(aa, bb, cc), Step::Rapid(aa, bb, clear)]);
                }
            }
            if steps.len() > MAX_CYCLE_STEPS {
                d.error(
                    line,
                    col0,
                    format!("{name}: the cycle makes more than {MAX_CYCLE_STEPS} moves (check Q and L)"),
                );
                return;
            }
        }
        // The cycle runs in exact path mode (LinuxCNC sets CANON_EXACT_PATH for it).
        let blend = std::mem::replace(&mut self.modal.blend, Blend::Exact);
        for step in steps {
            let (a, b, c, feed) = match step {
                Step::Dwell(s) => {
                    self.pending_dwell_s += s;
                    continue;
                }
                Step::Rapid(a, b, c) => (a, b, c, Feed::Rapid),
                Step::Feed(a, b, c) => (a, b, c, Feed::Programmed { mm_per_s: feed }),
            };
            let mut target = self.modal.pos;
            self.set_program_coords(&mut target, &[(idx[0], a * unit), (idx[1], b * unit), (idx[2], c * unit)]);
            for k in &idx {
                if let Some(msg) = self.travel_violation(*k, target[*k]) {
                    d.error(line, col0, format!("{name}: {msg}"));
                    self.modal.blend = blend;
                    return;
                }
            }
            self.linear_move(target, feed, source, col0, d);
        }
        self.modal.blend = blend;
        self.cycle.r = r_given;
        self.cycle.cc = z_given;
        self.cycle.p = dwell;
        self.cycle.q = delta;
    }
}

/// Most moves one cycle block makes: far beyond real drilling (a 1000-peck hole repeated ten
/// times), and it bounds the memory of a block with a tiny Q and a huge L.
const MAX_CYCLE_STEPS: usize = 100_000;
