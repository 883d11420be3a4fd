//! O-word control flow as LinuxCNC 2.9 has it: `sub`/`endsub`/`call`/`return`,
//! `if`/`elseif`/`else`/`endif`, `while`/`endwhile`, `do`/`while`, `repeat`/`endrepeat`,
//! `break`, `continue`.
//!
//! Control flow executes as the lines are read: a loop goes back to the place of its head in
//! the program's text and reads on from there (as LinuxCNC seeks in its file), a call goes to
//! the body of its subroutine and back; lines of a branch not taken are skipped unread. Nothing
//! is unrolled, so memory is bounded by the nesting, not by the iterations. When the program's
//! loop iterations and calls together pass `[programs] max_loop_iterations`, the loop (or
//! call) that does is an error at its line, so nested loops cannot multiply into a hang; calls
//! nest at most
//! [`MAX_CALL_DEPTH`] deep. A subroutine is known once its definition has been read; a call of
//! one the program has not defined looks for `name.ngc` on `[programs] subroutine_path`,
//! inside the programs directory.

use super::Interpreter;
use crate::program::error::Diagnostics;
use crate::program::lexer::{OWord, o_args};
use crate::program::params::CALL_ARGS;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

/// Calls nest at most this deep (LinuxCNC's `INTERP_SUB_ROUTINE_LEVELS`).
pub(crate) const MAX_CALL_DEPTH: usize = 10;

/// Where a line starts: in the program (`source` None) or in a subroutine file.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LinePos {
    pub source: Option<Arc<PathBuf>>,
    /// Byte offset of the line's start.
    pub offset: u64,
    /// Its 1-based number.
    pub line: u32,
}

/// Where a line is and where the next one starts.
#[derive(Debug, Clone)]
pub(crate) struct LineAt {
    pub here: LinePos,
    pub next: LinePos,
}

#[derive(Debug, Clone)]
enum Kind {
    If { taken: bool },
    While { head: LinePos },
    Do { body: LinePos },
    Repeat { body: LinePos, left: u64 },
}

#[derive(Debug, Clone)]
struct OBlock {
    name: String,
    kind: Kind,
    line: u32,
    col: u32,
}

#[derive(Debug, Clone)]
struct Frame {
    name: String,
    /// An M98 call (Fanuc style): the parameters are shared with the caller, and the body
    /// runs again while repeats are left.
    fanuc: Option<(u64, LinePos)>,
    ret: LinePos,
    saved: [f64; CALL_ARGS],
    /// The caller's open blocks.
    blocks: Vec<OBlock>,
    line: u32,
    col: u32,
}

/// Lines are skipped until the O word `name` with one of `until`.
#[derive(Debug, Clone)]
struct Skip {
    name: String,
    until: &'static [&'static str],
    /// The matching line is executed (an `elseif` is evaluated) rather than only ending the skip.
    execute: bool,
    /// What is skipped ("o100 if"), and the error if the program ends first (None: the
    /// standard one), at line, column.
    what: String,
    missing: Option<String>,
    line: u32,
    col: u32,
}

/// The control-flow state of a program.
#[derive(Debug, Clone, Default)]
pub(crate) struct Flow {
    subs: HashMap<String, LinePos>,
    frames: Vec<Frame>,
    blocks: Vec<OBlock>,
    skip: Option<Skip>,
    /// A call into a subroutine file: its `o<name> sub` line opens the body instead of
    /// defining it.
    entering: Option<String>,
    /// Loop iterations and calls so far: `[programs] max_loop_iterations` bounds them for the
    /// whole program, so nested loops and calls cannot multiply past it either.
    steps: u64,
}

impl Flow {
    /// Call depth (`#<_call_level>`).
    pub(crate) fn depth(&self) -> usize {
        self.frames.len()
    }

    /// Whether lines are being skipped.
    pub(crate) fn skipping(&self) -> bool {
        self.skip.is_some()
    }
}

/// What ends the skip over a subprogram's definition.
const M99: &str = "m99";

fn o_name(name: &str) -> String {
    if name.bytes().all(|b| b.is_ascii_digit()) { format!("o{name}") } else { format!("o<{name}>") }
}

impl Interpreter {
    /// A line while skipping: only its O word is read; the line that ends the skip is executed
    /// if the skip says so.
    pub(in crate::program) fn skipped_line(
        &mut self,
        text: &str,
        at: Option<&LineAt>,
        d: &mut Diagnostics,
    ) -> Option<LinePos> {
        if self.flow.skip.as_ref().is_some_and(|s| s.until == [M99]) {
            if has_m99(text) {
                self.flow.skip = None;
            }
            return None;
        }
        let o = crate::program::lexer::o_word_only(text, &self.params)?;
        let skip = self.flow.skip.as_ref()?;
        if o.keyword == "sub" && skip.until == ["endsub"] {
            // As LinuxCNC: a definition inside a definition is an error where it starts.
            let line = at.map_or(self.current_line, |a| a.here.line);
            d.error(line, o.col, format!("nested subroutine definition: {} sub inside {}", o_name(&o.name), skip.what));
            self.flow.skip = None;
            return None;
        }
        if o.name != skip.name || !skip.until.contains(&o.keyword.as_str()) {
            return None;
        }
        let execute = skip.execute;
        self.flow.skip = None;
        if !execute {
            return None;
        }
        self.o_word(text, &o, at, d)
    }

    /// Executes an O-word line; a jump is where reading goes on.
    pub(in crate::program) fn o_word(
        &mut self,
        text: &str,
        o: &OWord,
        at: Option<&LineAt>,
        d: &mut Diagnostics,
    ) -> Option<LinePos> {
        let Some(at) = at else {
            d.error(
                self.current_line,
                o.col,
                "O words (subroutines, loops, conditions) are not supported in appended text or MDI",
            );
            return None;
        };
        let line = at.here.line;
        const KEYWORDS: [&str; 15] = [
            "sub",
            "endsub",
            "return",
            "call",
            "if",
            "elseif",
            "else",
            "endif",
            "while",
            "endwhile",
            "do",
            "repeat",
            "endrepeat",
            "break",
            "continue",
        ];
        if o.keyword.is_empty() {
            return self.fanuc_label(o, at, d);
        }
        if !KEYWORDS.contains(&o.keyword.as_str()) {
            let message = if o.keyword.is_empty() {
                format!("{} needs a keyword (sub, call, if, while, do, repeat …)", o_name(&o.name))
            } else {
                format!("unknown O word keyword '{}'", o.keyword)
            };
            d.error(line, if o.keyword.is_empty() { o.col } else { o.keyword_col }, message);
            return None;
        }
        let args = match o_args(text, o.rest_at, &self.params) {
            Ok(a) => a,
            Err(e) => {
                d.error(line, e.col, e.message);
                return None;
            }
        };
        let label = format!("{} {}", o_name(&o.name), o.keyword);
        let one_arg = |d: &mut Diagnostics| -> Option<f64> {
            match args.as_slice() {
                [v] => Some(*v),
                [] => {
                    d.error(line, o.keyword_col, format!("{label} needs its value in [ ]"));
                    None
                }
                _ => {
                    d.error(line, o.keyword_col, format!("{label} takes one value in [ ]"));
                    None
                }
            }
        };
        let max_iter = self.settings.programs.max_loop_iterations;
        let top_is =
            |f: &Flow, pred: &dyn Fn(&Kind) -> bool| f.blocks.last().is_some_and(|b| b.name == o.name && pred(&b.kind));
        match o.keyword.as_str() {
            "sub" => {
                if self.flow.entering.as_deref() == Some(o.name.as_str()) {
                    // Entering the sub a call is waiting for: known from here on.
                    self.flow.entering = None;
                    self.flow.subs.insert(o.name.clone(), at.next.clone());
                    return None;
                }
                if !args.is_empty() {
                    d.error(line, o.keyword_col, format!("{label} takes no value"));
                    return None;
                }
                self.flow.subs.insert(o.name.clone(), at.next.clone());
                self.skip(o, &["endsub"], false, &label, line);
                None
            }
            "endsub" | "return" => {
                // `return` may carry the name of a block inside the sub (LinuxCNC's own
                // examples write `o1010 return` inside `o1010 if`); `endsub` names the sub.
                let Some(frame) = self.flow.frames.last() else {
                    d.error(line, o.col, format!("{label} outside a subroutine call"));
                    return None;
                };
                if o.keyword == "endsub" && frame.name != o.name {
                    d.error(line, o.col, format!("{label} inside the call of {}", o_name(&frame.name)));
                    return None;
                }
                if args.len() > 1 {
                    d.error(line, o.keyword_col, format!("{label} takes at most one value"));
                    return None;
                }
                if frame.fanuc.is_some() {
                    d.error(line, o.col, format!("{label} in a subprogram called with M98 (end it with M99)"));
                    return None;
                }
                let frame = self.flow.frames.pop().expect("checked");
                self.leave_context_level(self.flow.depth() + 1, line, o.col, d);
                self.params.leave(&frame.saved);
                self.params.value_returned = !args.is_empty();
                self.params.value = args.first().copied().unwrap_or(0.0);
                self.flow.blocks = frame.blocks;
                Some(frame.ret)
            }
            "call" => {
                self.flow.steps += 1;
                if self.flow.steps >= max_iter {
                    d.error(line, o.col, loop_cap_message(&label, max_iter));
                    return None;
                }
                if args.len() > CALL_ARGS {
                    d.error(line, o.keyword_col, format!("{label}: at most {CALL_ARGS} arguments (#1 … #30)"));
                    return None;
                }
                if self.flow.frames.len() >= MAX_CALL_DEPTH {
                    d.error(
                        line,
                        o.col,
                        format!("{label}: calls nested deeper than {MAX_CALL_DEPTH} (endless recursion?)"),
                    );
                    return None;
                }
                let target = match self.flow.subs.get(&o.name) {
                    Some(p) => Some(p.clone()),
                    None => match self.subroutine_file(&o.name) {
                        Ok(Some(path)) => {
                            self.flow.entering = Some(o.name.clone());
                            Some(LinePos { source: Some(Arc::new(path)), offset: 0, line: 1 })
                        }
                        Ok(None) if at.here.source.is_none() => {
                            // As LinuxCNC: the sub may follow in the program; read on to it
                            // (skipping) and enter it there.
                            self.flow.entering = Some(o.name.clone());
                            None
                        }
                        Ok(None) => {
                            d.error(line, o.col, undefined_message(&o.name));
                            return None;
                        }
                        Err(m) => {
                            d.error(line, o.col, m);
                            return None;
                        }
                    },
                };
                let saved = self.params.enter(&args);
                let blocks = std::mem::take(&mut self.flow.blocks);
                self.flow.frames.push(Frame {
                    name: o.name.clone(),
                    fanuc: None,
                    ret: at.next.clone(),
                    saved,
                    blocks,
                    line,
                    col: o.col,
                });
                if target.is_none() {
                    self.skip(o, &["sub"], true, &label, line);
                    if let Some(s) = &mut self.flow.skip {
                        s.missing = Some(undefined_message(&o.name));
                    }
                }
                target
            }
            "if" => {
                let c = one_arg(d)?;
                self.push_block(o, Kind::If { taken: c != 0.0 }, line);
                if c == 0.0 {
                    self.skip(o, &["elseif", "else", "endif"], true, &label, line);
                }
                None
            }
            "elseif" | "else" => {
                let Some(b) = self.flow.blocks.last_mut().filter(|b| b.name == o.name) else {
                    d.error(line, o.col, format!("{label} without {} if", o_name(&o.name)));
                    return None;
                };
                let Kind::If { taken } = &mut b.kind else {
                    d.error(line, o.col, format!("{label} without {} if", o_name(&o.name)));
                    return None;
                };
                if *taken {
                    self.skip(o, &["endif"], true, &label, line);
                    return None;
                }
                let c = if o.keyword == "else" {
                    if !args.is_empty() {
                        d.error(line, o.keyword_col, format!("{label} takes no value"));
                        return None;
                    }
                    1.0
                } else {
                    one_arg(d)?
                };
                if c != 0.0 {
                    *taken = true;
                } else {
                    self.skip(o, &["elseif", "else", "endif"], true, &label, line);
                }
                None
            }
            "endif" => {
                if !top_is(&self.flow, &|k| matches!(k, Kind::If { .. })) {
                    d.error(line, o.col, format!("{label} without {} if", o_name(&o.name)));
                    return None;
                }
                self.flow.blocks.pop();
                None
            }
            "do" => {
                self.push_block(o, Kind::Do { body: at.next.clone() }, line);
                None
            }
            "while" => {
                let c = one_arg(d)?;
                // The end of a do-while loop.
                if top_is(&self.flow, &|k| matches!(k, Kind::Do { .. })) {
                    let b = self.flow.blocks.last_mut().expect("checked");
                    if c == 0.0 {
                        self.flow.blocks.pop();
                        return None;
                    }
                    self.flow.steps += 1;
                    if self.flow.steps >= max_iter {
                        let (l, col) = (b.line, b.col);
                        d.error(l, col, loop_cap_message(&label, max_iter));
                        return None;
                    }
                    let Kind::Do { body } = &b.kind else { unreachable!("checked") };
                    return Some(body.clone());
                }
                // The head of a while loop, read again after its endwhile.
                let again =
                    self.flow.blocks.last().is_some_and(
                        |b| matches!(&b.kind, Kind::While { head } if b.name == o.name && *head == at.here),
                    );
                if again {
                    if c == 0.0 {
                        self.flow.blocks.pop();
                        self.skip(o, &["endwhile"], false, &label, line);
                        return None;
                    }
                    self.flow.steps += 1;
                    if self.flow.steps >= max_iter {
                        d.error(line, o.col, loop_cap_message(&label, max_iter));
                    }
                    return None;
                }
                if c == 0.0 {
                    self.skip(o, &["endwhile"], false, &label, line);
                } else {
                    self.push_block(o, Kind::While { head: at.here.clone() }, line);
                }
                None
            }
            "endwhile" => {
                let head = match self.flow.blocks.last() {
                    Some(OBlock { name, kind: Kind::While { head }, .. }) if *name == o.name => head.clone(),
                    _ => {
                        d.error(line, o.col, format!("{label} without {} while", o_name(&o.name)));
                        return None;
                    }
                };
                Some(head)
            }
            "repeat" => {
                let n = one_arg(d)?;
                if n > max_iter as f64 {
                    d.error(line, o.col, loop_cap_message(&label, max_iter));
                    return None;
                }
                let n = n.round();
                if n < 1.0 {
                    self.skip(o, &["endrepeat"], false, &label, line);
                } else {
                    self.push_block(o, Kind::Repeat { body: at.next.clone(), left: n as u64 - 1 }, line);
                }
                None
            }
            "endrepeat" => {
                if !top_is(&self.flow, &|k| matches!(k, Kind::Repeat { .. })) {
                    d.error(line, o.col, format!("{label} without {} repeat", o_name(&o.name)));
                    return None;
                }
                let jump = self.next_repeat();
                if jump.is_some() && self.flow.steps >= max_iter {
                    d.error(line, o.col, loop_cap_message(&label, max_iter));
                    return None;
                }
                jump
            }
            "break" | "continue" => {
                let Some(k) =
                    self.flow.blocks.iter().rposition(|b| b.name == o.name && !matches!(b.kind, Kind::If { .. }))
                else {
                    d.error(line, o.col, format!("{label} outside a loop {}", o_name(&o.name)));
                    return None;
                };
                self.flow.blocks.truncate(k + 1);
                let b = self.flow.blocks.last().expect("kept").clone();
                let brk = o.keyword == "break";
                match (&b.kind, brk) {
                    (Kind::While { .. }, true) => {
                        self.flow.blocks.pop();
                        self.skip(o, &["endwhile"], false, &label, line);
                        None
                    }
                    (Kind::While { head }, false) => Some(head.clone()),
                    (Kind::Repeat { .. }, true) => {
                        self.flow.blocks.pop();
                        self.skip(o, &["endrepeat"], false, &label, line);
                        None
                    }
                    (Kind::Repeat { .. }, false) => {
                        let jump = self.next_repeat();
                        if jump.is_some() && self.flow.steps >= max_iter {
                            d.error(line, o.col, loop_cap_message(&label, max_iter));
                            return None;
                        }
                        if jump.is_none() {
                            self.skip(o, &["endrepeat"], false, &label, line);
                        }
                        jump
                    }
                    (Kind::Do { .. }, true) => {
                        self.flow.blocks.pop();
                        self.skip(o, &["while"], false, &label, line);
                        None
                    }
                    (Kind::Do { .. }, false) => {
                        // The do loop's `while` line decides.
                        self.skip(o, &["while"], true, &label, line);
                        None
                    }
                    (Kind::If { .. }, _) => unreachable!("loops only"),
                }
            }
            _ => unreachable!("checked above"),
        }
    }

    /// A bare `O<n>` line: the title of the main program when it comes first, the start of the
    /// subprogram an M98 call is reading on to, or else the definition of a subprogram (read
    /// on to its M99), as LinuxCNC 2.9.
    fn fanuc_label(&mut self, o: &OWord, at: &LineAt, _d: &mut Diagnostics) -> Option<LinePos> {
        if self.flow.entering.as_deref() == Some(o.name.as_str()) {
            self.flow.entering = None;
            self.flow.subs.insert(o.name.clone(), at.next.clone());
            if let Some((_, body)) = self.flow.frames.last_mut().and_then(|f| f.fanuc.as_mut()) {
                *body = at.next.clone();
            }
            return None;
        }
        if self.summary.blocks == 0 && self.flow.frames.is_empty() {
            return None; // the program's number
        }
        self.flow.subs.insert(o.name.clone(), at.next.clone());
        let label = format!("{} (subprogram)", o_name(&o.name));
        self.skip(o, &[M99], false, &label, at.here.line);
        None
    }

    /// `M98 P<n> [L<k>]`: calls subprogram `O<n>` k times (L0: not at all), sharing the
    /// parameters. `M99` ends it (or runs it again while repeats are left).
    pub(in crate::program) fn fanuc_call(
        &mut self,
        number: f64,
        repeats: u64,
        col: u32,
        at: Option<&LineAt>,
        d: &mut Diagnostics,
    ) -> Option<LinePos> {
        let Some(at) = at else {
            d.error(self.current_line, col, "M98 is not supported in appended text or MDI");
            return None;
        };
        let line = at.here.line;
        if repeats == 0 {
            return None;
        }
        let name = format!("{}", number as u64);
        let max_iter = self.settings.programs.max_loop_iterations;
        self.flow.steps += 1;
        if self.flow.steps >= max_iter {
            d.error(line, col, loop_cap_message(&format!("M98 P{name}"), max_iter));
            return None;
        }
        if self.flow.frames.len() >= MAX_CALL_DEPTH {
            d.error(line, col, format!("M98 P{name}: calls nested deeper than {MAX_CALL_DEPTH} (endless recursion?)"));
            return None;
        }
        let target = self.flow.subs.get(&name).cloned();
        let blocks = std::mem::take(&mut self.flow.blocks);
        self.flow.frames.push(Frame {
            name: name.clone(),
            fanuc: Some((repeats - 1, target.clone().unwrap_or_else(|| at.next.clone()))),
            ret: at.next.clone(),
            saved: [0.0; CALL_ARGS],
            blocks,
            line,
            col,
        });
        if target.is_some() {
            return target;
        }
        if at.here.source.is_some() {
            d.error(line, col, format!("M98 P{name}: no subprogram O{name} above this line"));
            return None;
        }
        // Read on to the subprogram (it may follow the main program).
        self.flow.entering = Some(name.clone());
        let o = OWord { name: name.clone(), col, keyword: String::new(), keyword_col: col, rest_at: 0 };
        self.skip(&o, &[""], true, &format!("M98 P{name}"), line);
        if let Some(s) = &mut self.flow.skip {
            s.missing = Some(format!("M98 P{name}: the program has no subprogram O{name}"));
        }
        None
    }

    /// `M99`: the end of an M98 subprogram.
    pub(in crate::program) fn fanuc_return(
        &mut self,
        col: u32,
        at: Option<&LineAt>,
        d: &mut Diagnostics,
    ) -> Option<LinePos> {
        let line = at.map_or(self.current_line, |a| a.here.line);
        let Some(frame) = self.flow.frames.last_mut().filter(|f| f.fanuc.is_some()) else {
            d.error(line, col, "M99 outside a subprogram called with M98 (an endless main program is not supported)");
            return None;
        };
        let (left, body) = frame.fanuc.as_mut().expect("filtered");
        if *left > 0 {
            *left -= 1;
            let body = body.clone();
            self.flow.steps += 1;
            let max_iter = self.settings.programs.max_loop_iterations;
            if self.flow.steps >= max_iter {
                d.error(line, col, loop_cap_message("M99", max_iter));
                return None;
            }
            self.flow.blocks.clear();
            return Some(body);
        }
        let frame = self.flow.frames.pop().expect("checked");
        self.leave_context_level(self.flow.depth() + 1, line, col, d);
        self.flow.blocks = frame.blocks;
        Some(frame.ret)
    }

    /// The next turn of the repeat loop on top, or its end (None, the block popped).
    fn next_repeat(&mut self) -> Option<LinePos> {
        let b = self.flow.blocks.last_mut()?;
        let Kind::Repeat { body, left } = &mut b.kind else { return None };
        if *left == 0 {
            self.flow.blocks.pop();
            return None;
        }
        *left -= 1;
        self.flow.steps += 1;
        Some(body.clone())
    }

    fn push_block(&mut self, o: &OWord, kind: Kind, line: u32) {
        self.flow.blocks.push(OBlock { name: o.name.clone(), kind, line, col: o.col });
    }

    fn skip(&mut self, o: &OWord, until: &'static [&'static str], execute: bool, what: &str, line: u32) {
        self.flow.skip = Some(Skip {
            name: o.name.clone(),
            until,
            execute,
            what: what.to_string(),
            missing: None,
            line,
            col: o.col,
        });
    }

    /// The file `name.ngc` on the subroutine path, inside the programs directory (None if there
    /// is none).
    fn subroutine_file(&self, name: &str) -> Result<Option<PathBuf>, String> {
        if name.contains('/') || name.contains('\\') || name.contains("..") || name.starts_with('.') {
            return Err(format!(
                "subroutine file name '{name}' is refused: it must name a file in the subroutine path (no '/', '..')"
            ));
        }
        let base = self.settings.programs.base_dir();
        let Ok(base) = base.canonicalize() else { return Ok(None) };
        for dir in self.settings.programs.subroutine_dirs() {
            let file = dir.join(format!("{name}.ngc"));
            let Ok(real) = file.canonicalize() else { continue };
            if !real.starts_with(&base) {
                return Err(format!(
                    "subroutine file {} lies outside the programs directory {}",
                    file.display(),
                    base.display()
                ));
            }
            if real.is_file() {
                return Ok(Some(real));
            }
        }
        Ok(None)
    }

    /// The end of a subroutine file before its `endsub`.
    pub(in crate::program) fn source_ended(&mut self, file: &str, d: &mut Diagnostics) {
        let what = match &self.flow.entering {
            Some(name) => format!("the file {file} defines no sub {}", o_name(name)),
            None => format!("the subroutine file {file} ends before its endsub"),
        };
        let (line, col) = self.flow.frames.last().map_or((0, 0), |f| (f.line, f.col));
        d.error(line, col, what);
        self.flow.entering = None;
    }

    /// At the end of the program: control flow left open is an error at its line.
    pub(in crate::program) fn finish_flow(&mut self, d: &mut Diagnostics) {
        if let Some(s) = self.flow.skip.take() {
            let wanted = s.until.join(" or ");
            let message = s.missing.unwrap_or_else(|| format!("{}: the program ends before its {wanted}", s.what));
            d.error(s.line, s.col, message);
            return;
        }
        if let Some(b) = self.flow.blocks.last() {
            d.error(b.line, b.col, format!("{} is not closed: the program ends inside it", o_name(&b.name)));
        }
        if let Some(f) = self.flow.frames.last() {
            d.error(f.line, f.col, format!("the program ends inside the call of {}", o_name(&f.name)));
        }
    }
}

fn undefined_message(name: &str) -> String {
    format!(
        "call of an undefined subroutine {}: no 'sub' of it in the program and no file {name}.ngc on the subroutine \
         path ([programs] subroutine_path)",
        o_name(name)
    )
}

fn loop_cap_message(label: &str, max: u64) -> String {
    format!(
        "{label}: the program's loops and calls have run {max} times ([programs] max_loop_iterations); this loop most \
         likely never ends"
    )
}

/// Whether a line holds the word M99 (outside comments).
fn has_m99(text: &str) -> bool {
    let mut code = String::new();
    let mut comment = false;
    for c in text.chars() {
        match c {
            '(' => comment = true,
            ')' => comment = false,
            ';' if !comment => break,
            c if !comment && !c.is_whitespace() => code.push(c.to_ascii_uppercase()),
            _ => {}
        }
    }
    code.match_indices("M99").any(|(i, _)| !code[i + 3..].starts_with(|c: char| c.is_ascii_digit() || c == '.'))
        && !code.contains("M990")
}
