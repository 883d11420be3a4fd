//! The parameters of RS274NGC as LinuxCNC 2.9 has them: numbered `#1`–`#5602`, named local
//! `#<x>` (one scope per subroutine call) and global `#<_x>`, and the predefined read-only
//! ones that report the interpreter's state (position #5420–#5428, `#<_metric>` …).
//!
//! The store is bounded: 5603 numbered values, and named ones only as the program's text
//! names them.

use std::collections::HashMap;

/// Highest parameter number (LinuxCNC's `RS274NGC_MAX_PARAMETERS` − 1).
pub(super) const MAX_NUMBERED: usize = 5602;
/// LinuxCNC's `#5599`: `(DEBUG,…)` comes out while it is above 0 (message.rs).
pub(super) const DEBUG_FLAG_PARAM: usize = 5599;
/// Call arguments are `#1` … `#30`, local to each call.
pub(super) const CALL_ARGS: usize = 30;
/// Numbers computed from the interpreter's state on every read; assigning them is an error.
const COMPUTED: [std::ops::RangeInclusive<usize>; 3] = [5210..=5220, 5221..=5390, 5400..=5428];

/// A parameter a program names.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum ParamRef {
    Numbered(usize),
    /// Lower case, blanks removed; a leading `_` makes it global.
    Named(String),
}

impl std::fmt::Display for ParamRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParamRef::Numbered(n) => write!(f, "#{n}"),
            ParamRef::Named(s) => write!(f, "#<{s}>"),
        }
    }
}

/// The interpreter's state as the predefined parameters report it, refreshed before a line
/// that reads parameters is evaluated. Lengths in program units.
#[derive(Debug, Clone, Default)]
pub(super) struct Snapshot {
    /// Position X Y Z A B C U V W in the active coordinate system (#5420–#5428, `#<_x>` …).
    pub pos: [f64; 9],
    /// Machine position (`#<_abs_x>` …).
    pub abs: [f64; 9],
    /// G92 offsets (#5211–#5219) and whether any is set (#5210).
    pub g92: [f64; 9],
    pub g92_on: bool,
    /// 1 = G54 … 9 = G59.3 (#5220).
    pub coord_index: usize,
    /// 540, 550 … 590, 591, 592, 593 (`#<_coord_system>`).
    pub coord_code: f64,
    pub metric: bool,
    pub absolute: bool,
    pub inverse_time: bool,
    pub tool: f64,
    pub selected_tool: f64,
    pub tool_offset_on: bool,
    /// The offsets X … W of the tool in the spindle as the tool table has them (#5401–#5409,
    /// LinuxCNC 2.9: G10 L1 on the loaded tool shows here before G43 applies it).
    pub loaded_tool_offset: [f64; 9],
    pub feed: f64,
    pub motion_code: f64,
    pub plane_code: f64,
    pub ccomp_code: f64,
    pub retract_r: bool,
    pub line: f64,
    pub call_level: f64,
    /// Work offsets G54 … G59.3, X … W (#5221 + 20·k …), in the machine's units (mm, deg) as
    /// LinuxCNC keeps them.
    pub work: [[f64; 9]; 9],
    /// The rotation of each work system about Z, degrees (#5230 + 20·k, G10 L2 R).
    pub rotation_deg: [f64; 9],
}

/// The parameter store.
#[derive(Debug, Clone)]
pub(crate) struct Params {
    numbered: Vec<f64>,
    globals: HashMap<String, f64>,
    /// Named locals, one scope per call level (the main program is level 0).
    locals: Vec<HashMap<String, f64>>,
    pub(super) snap: Snapshot,
    /// `#<_value>` and `#<_value_returned>`: what the last subroutine returned.
    pub(super) value: f64,
    pub(super) value_returned: bool,
}

impl Default for Params {
    fn default() -> Self {
        let mut numbered = vec![0.0; MAX_NUMBERED + 1];
        // `(DEBUG,…)` comes out (LinuxCNC starts with #5599 = 1).
        numbered[DEBUG_FLAG_PARAM] = 1.0;
        Self {
            numbered,
            globals: HashMap::new(),
            locals: vec![HashMap::new()],
            snap: Snapshot::default(),
            value: 0.0,
            value_returned: false,
        }
    }
}

impl Params {
    /// The value of a parameter: an unset numbered one reads 0 (as LinuxCNC), an undefined
    /// named one is an error (the message).
    pub(super) fn read(&self, p: &ParamRef) -> Result<f64, String> {
        match p {
            ParamRef::Numbered(n) => self.numbered(*n),
            ParamRef::Named(name) => {
                self.named(name).ok_or_else(|| format!("named parameter #<{name}> is not defined"))
            }
        }
    }

    pub(super) fn numbered(&self, n: usize) -> Result<f64, String> {
        if !(1..=MAX_NUMBERED).contains(&n) {
            return Err(format!("parameter number {n} is out of range (1 – {MAX_NUMBERED})"));
        }
        let s = &self.snap;
        Ok(match n {
            5210 => f64::from(u8::from(s.g92_on)),
            5211..=5219 => s.g92[n - 5211],
            5220 => s.coord_index as f64,
            5400 => s.tool,
            5401..=5409 => s.loaded_tool_offset[n - 5401],
            5420..=5428 => s.pos[n - 5420],
            5221..=5390 if (n - 5221) % 20 < 9 => s.work[(n - 5221) / 20][(n - 5221) % 20],
            5221..=5390 if (n - 5221) % 20 == 9 => s.rotation_deg[(n - 5221) / 20],
            _ => self.numbered[n],
        })
    }

    /// A named parameter: a predefined one, a local of the current call level, a global.
    pub(super) fn named(&self, name: &str) -> Option<f64> {
        if let Some(v) = self.predefined(name) {
            return Some(v);
        }
        if name.starts_with('_') {
            self.globals.get(name).copied()
        } else {
            self.locals.last().and_then(|l| l.get(name)).copied()
        }
    }

    /// Sets a parameter; an out-of-range number or a read-only parameter is an error.
    pub(super) fn set(&mut self, p: &ParamRef, v: f64) -> Result<(), String> {
        match p {
            ParamRef::Numbered(n) => {
                let n = *n;
                if !(1..=MAX_NUMBERED).contains(&n) {
                    return Err(format!("parameter number {n} is out of range (1 – {MAX_NUMBERED})"));
                }
                if COMPUTED.iter().any(|r| r.contains(&n)) {
                    return Err(format!("parameter #{n} is read-only: it reports the interpreter's state"));
                }
                self.numbered[n] = v;
            }
            ParamRef::Named(name) => {
                if self.predefined(name).is_some() {
                    return Err(format!("parameter #<{name}> is read-only: it reports the interpreter's state"));
                }
                if name.starts_with('_') {
                    self.globals.insert(name.clone(), v);
                } else if let Some(l) = self.locals.last_mut() {
                    l.insert(name.clone(), v);
                }
            }
        }
        Ok(())
    }

    /// Sets a numbered parameter the interpreter owns (G28.1, G30.1).
    pub(super) fn set_numbered(&mut self, n: usize, v: f64) {
        if let Some(slot) = self.numbered.get_mut(n) {
            *slot = v;
        }
    }

    /// A stored numbered parameter (0 when out of range).
    pub(super) fn stored(&self, n: usize) -> f64 {
        self.numbered.get(n).copied().unwrap_or(0.0)
    }

    /// Enters a subroutine: `#1` … `#30` become `args` (the rest 0) and a fresh scope of named
    /// locals opens. Returns the caller's `#1` … `#30`, to be given back to [`Params::leave`].
    pub(super) fn enter(&mut self, args: &[f64]) -> [f64; CALL_ARGS] {
        let mut saved = [0.0; CALL_ARGS];
        saved.copy_from_slice(&self.numbered[1..=CALL_ARGS]);
        for k in 0..CALL_ARGS {
            self.numbered[k + 1] = args.get(k).copied().unwrap_or(0.0);
        }
        self.locals.push(HashMap::new());
        saved
    }

    /// Leaves a subroutine: the caller's `#1` … `#30` and named locals come back.
    pub(super) fn leave(&mut self, saved: &[f64; CALL_ARGS]) {
        self.numbered[1..=CALL_ARGS].copy_from_slice(saved);
        if self.locals.len() > 1 {
            self.locals.pop();
        }
    }

    /// The predefined named parameters of LinuxCNC 2.9 that concern motion.
    fn predefined(&self, name: &str) -> Option<f64> {
        const AXES: [&str; 9] = ["x", "y", "z", "a", "b", "c", "u", "v", "w"];
        let s = &self.snap;
        let b = |v: bool| f64::from(u8::from(v));
        let rest = name.strip_prefix('_')?;
        if let Some(k) = AXES.iter().position(|a| *a == rest) {
            return Some(s.pos[k]);
        }
        if let Some(k) = rest.strip_prefix("abs_").and_then(|a| AXES.iter().position(|x| *x == a)) {
            return Some(s.abs[k]);
        }
        Some(match rest {
            "metric" => b(s.metric),
            "imperial" => b(!s.metric),
            "absolute" => b(s.absolute),
            "incremental" => b(!s.absolute),
            "inverse_time" => b(s.inverse_time),
            "units_per_minute" => b(!s.inverse_time),
            "units_per_rev" => 0.0,
            "coord_system" => s.coord_code,
            "tool_offset" => b(s.tool_offset_on),
            "retract_r" => b(s.retract_r),
            "retract_old" => b(!s.retract_r),
            "spindle_on" | "spindle_cw" | "mist" | "flood" | "feed_hold" | "adaptive_feed" | "rpm" => 0.0,
            "speed_override" | "feed_override" => 1.0,
            "feed" => s.feed,
            "current_tool" => s.tool,
            "selected_tool" => s.selected_tool,
            "current_pocket" | "selected_pocket" => 0.0,
            "line" => s.line,
            "motion_mode" => s.motion_code,
            "plane" => s.plane_code,
            "ccomp" => s.ccomp_code,
            "call_level" => s.call_level,
            "remap_level" => 0.0,
            "value" => self.value,
            "value_returned" => b(self.value_returned),
            // A program that asks runs in the interpreter of a machine (LinuxCNC's task).
            "task" => 1.0,
            "vmajor" => 2.0,
            "vminor" => 9.0,
            _ => return None,
        })
    }

    /// Whether a named parameter is defined (`EXISTS`).
    pub(super) fn exists(&self, name: &str) -> bool {
        self.named(name).is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbered_named_and_read_only() {
        let mut p = Params::default();
        assert_eq!(p.read(&ParamRef::Numbered(7)), Ok(0.0));
        p.set(&ParamRef::Numbered(7), 2.5).unwrap();
        assert_eq!(p.read(&ParamRef::Numbered(7)), Ok(2.5));
        assert!(p.read(&ParamRef::Named("x".into())).unwrap_err().contains("not defined"));
        p.set(&ParamRef::Named("x".into()), 1.0).unwrap();
        p.set(&ParamRef::Named("_g".into()), 3.0).unwrap();
        let saved = p.enter(&[9.0]);
        assert_eq!(p.read(&ParamRef::Numbered(1)), Ok(9.0));
        assert!(p.read(&ParamRef::Named("x".into())).is_err(), "locals are per call");
        assert_eq!(p.read(&ParamRef::Named("_g".into())), Ok(3.0));
        p.leave(&saved);
        assert_eq!(p.read(&ParamRef::Named("x".into())), Ok(1.0));
        assert!(p.set(&ParamRef::Numbered(5420), 1.0).unwrap_err().contains("read-only"));
        assert!(p.set(&ParamRef::Named("_metric".into()), 1.0).unwrap_err().contains("read-only"));
        assert!(p.set(&ParamRef::Numbered(5603), 1.0).unwrap_err().contains("out of range"));
    }
}
