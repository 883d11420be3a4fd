//! The optional sections owned by the daemon: planner, prep, control and real-time settings.

use crate::{ConfigError, Validator};
use serde::Deserialize;

/// `[planner]`: the look-ahead feedrate planner (Kopp et al. 2019).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct PlannerConfig {
    /// Look-ahead horizon in mm of path. The planner hands pieces on only when this much path
    /// lies ahead of them (or the program ends).
    pub lookahead_mm: f64,
    /// Optional cap on the horizon in samples (whichever is reached first).
    pub lookahead_samples: Option<usize>,
    /// Largest distance between path samples, mm.
    pub max_step_mm: f64,
    /// Smallest distance between path samples, mm.
    pub min_step_mm: f64,
    /// Largest tangent or orientation turn between samples, degrees.
    pub max_turn_deg: f64,
    /// Largest planned time per sample interval, ms (keeps jerk switching fine on long lines).
    pub max_interval_ms: f64,
    /// Fraction of the axis limits the planner aims at; the rest is headroom for the motion
    /// between samples and rounding. 0.99 plans to 99 % of each limit.
    pub limit_fraction: f64,
    /// Feed for G0 rapid moves, mm/s; the axis limits cap it. Unset: the axis limits alone.
    pub rapid_feed_mm_s: Option<f64>,
    /// At a curvature jump (G¹ joint without G², e.g. line into arc) the axis acceleration
    /// steps by ΔA″·v². The speed there is capped so the step is what the jerk limit moves in
    /// this time, ms. The default keeps sampled jerk within the limit down to 0.1 ms sampling;
    /// smoothing (G64) removes the jump instead.
    pub curvature_jump_ms: f64,
    /// On smoothed (G64) pieces, a sampling step the cubic interpolation of the limit checks
    /// would split is kept where the quintic one describes it (docs/planner.md, section 8):
    /// about a third of the nodes on tight smoothed CAM paths. `false` keeps the cubic
    /// interpolation everywhere.
    pub quintic_checks: bool,
}

impl Default for PlannerConfig {
    fn default() -> Self {
        Self {
            lookahead_mm: 500.0,
            lookahead_samples: None,
            max_step_mm: 2.0,
            min_step_mm: 1e-4,
            max_turn_deg: 2.0,
            max_interval_ms: 2.0,
            limit_fraction: 0.995,
            rapid_feed_mm_s: None,
            curvature_jump_ms: 0.002,
            quintic_checks: true,
        }
    }
}

impl PlannerConfig {
    pub(crate) fn validate(&self, v: &Validator) -> Result<(), ConfigError> {
        v.positive("planner.lookahead_mm", self.lookahead_mm)?;
        if let Some(n) = self.lookahead_samples {
            if n < 16 {
                return Err(v.err("planner.lookahead_samples", &format!("must be ≥ 16, got {n}")));
            }
        }
        v.positive("planner.max_step_mm", self.max_step_mm)?;
        v.positive("planner.min_step_mm", self.min_step_mm)?;
        if self.min_step_mm > self.max_step_mm {
            return Err(v.err("planner.min_step_mm", "must not exceed planner.max_step_mm"));
        }
        v.in_range("planner.max_turn_deg", self.max_turn_deg, 0.01, 30.0)?;
        v.in_range("planner.max_interval_ms", self.max_interval_ms, 0.1, 1000.0)?;
        v.in_range("planner.limit_fraction", self.limit_fraction, 0.5, 1.0)?;
        v.in_range("planner.curvature_jump_ms", self.curvature_jump_ms, 0.0, 100.0)?;
        if let Some(f) = self.rapid_feed_mm_s {
            v.positive("planner.rapid_feed_mm_s", f)?;
        }
        Ok(())
    }
}

/// How corners and polylines are prepared before planning.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PrepMode {
    /// Exact path (G61): corners are passed with v = a = 0.
    Exact,
    /// Tolerance-band smoothing (G64): corners and polylines are smoothed within the tolerance.
    Smooth,
}

/// How the smoothed points become a continuous path (Haas 2012, §4.5 and §4.6).
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum PrepMethod {
    /// Quintic Hermite pieces through the QP's points (§4.5): C², exact at the points.
    #[default]
    Hermite,
    /// A weighted least-squares quintic B-spline through the QP's points and derivatives
    /// (§4.6–4.8): C^`continuity_degree`, approximating.
    Bspline,
}

/// Where the QP points sit within a programmed block (Haas 2012, §3.5 and §4.8).
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum PointDistribution {
    /// Equidistant at `point_spacing_mm` (§4.8, Table 4.7: what the thesis finally uses).
    #[default]
    Equidistant,
    /// The cumulative density of eq. 3.13: as many points per block, crowded towards both of
    /// its ends.
    Cumulative,
}

/// Which solver takes the window QPs.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum QpSolver {
    /// The interior-point method on the QP's banded structure, with Clarabel for the windows it
    /// declines (nearly infeasible ones).
    Banded,
    /// Clarabel for every window (the general sparse solver).
    #[default]
    Clarabel,
}

/// `[prep]`: path preparation (tolerance-band smoothing, Haas 2012, §3–4): a windowed per-axis
/// QP moves the points of the path inside a lateral band, then quintic Hermite pieces join
/// them C².
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct PrepConfig {
    /// Mode at program start; G61 / G64 switch it within a program.
    pub mode: PrepMode,
    /// Lateral tolerance for G64 without P, mm.
    pub tolerance_mm: f64,
    /// Derivatives per point the QP carries: 2 (x, x′, x″), 3 (x … x‴) or 4 (x … x⁗). Hermite
    /// pieces are quintic and C² at any degree; the B-spline is C^degree.
    pub continuity_degree: u32,
    /// How the smoothed points become path pieces (`G64 … Q1` / `Q2` per program).
    pub method: PrepMethod,
    /// Continuity of the Hermite pieces: 2 (quintic from x … x″, Haas 2012, §4.5), 3 (degree 7
    /// from x … x‴) or 4 (degree 9 from x … x⁗); at most `continuity_degree`.
    pub hermite_continuity: u32,
    /// Weight of x⁗ in the QP objective at continuity degree 4 (Haas 2012, §3.4: 1e-8).
    pub weight_d4: f64,
    /// Least-squares weights of x, x′, x″, x‴, x⁗ when the B-spline is fitted to the QP's points
    /// (Haas 2012, §4.6: 1000, 100, 10, 1 for `lscov`; x⁗ at degree 4 continues the ratio).
    pub bspline_weights: [f64; 5],
    /// Multiplicity of the B-spline's inner knots (one at each QP point): the spline is
    /// C^(5 − m) there; 1 (C⁴) is Haas 2012's spline.
    pub bspline_knot_multiplicity: u32,
    /// Weights of x, x′, x″, x‴ in the QP objective (Haas 2012, §3.3 and variant 1 of §3.7;
    /// x‴ unused at degree 2), with the derivatives taken with respect to s / `weight_length_mm`. A position
    /// weight pulls the points towards the programmed path.
    pub weights: [f64; 4],
    /// Length that normalises the path parameter for the weights, mm (Haas 2012 normalises s over
    /// the optimised piece; the default is one window).
    pub weight_length_mm: f64,
    /// Length of one window segment (the unit that is committed), mm (Haas 2012, §3.6.3: 10 mm).
    pub segment_mm: f64,
    /// Segments per window (Haas 2012, §3.6.3: 5); one is committed per solve.
    pub window_segments: usize,
    /// Largest spacing of the QP points along the path, mm (Haas 2012, Table 4.7:
    /// ≥ 0.926 points/mm).
    pub point_spacing_mm: f64,
    /// Equidistant points, or the cumulative density of Haas 2012, eq. 3.13, within each block.
    pub point_distribution: PointDistribution,
    /// Largest tangent turn between two QP points on curves, degrees.
    pub max_turn_deg: f64,
    /// Vertices that turn the tangent by more than this are corners: a point sits on the vertex
    /// and the spacing shrinks towards it (down to the tolerance).
    pub corner_deg: f64,
    /// Corners that turn by more than this are not smoothed: exact stop. Within tolerances of
    /// 0.01–0.1 mm a sharper corner is jerk-bound at a few mm/s however it is blended, and the
    /// blend takes longer than stopping.
    pub max_corner_deg: f64,
    /// Share of the tolerance kept back from the QP band for the pieces between the points.
    pub band_margin: f64,
    /// A window solve slower than this counts as failed and takes the fallback, ms.
    pub max_solve_ms: f64,
    /// The window QPs' solver.
    pub qp_solver: QpSolver,
}

impl Default for PrepConfig {
    fn default() -> Self {
        Self {
            mode: PrepMode::Exact,
            tolerance_mm: 0.01,
            continuity_degree: 3,
            method: PrepMethod::Hermite,
            weight_d4: 1e-8,
            hermite_continuity: 2,
            bspline_weights: [1000.0, 100.0, 10.0, 1.0, 0.1],
            bspline_knot_multiplicity: 1,
            weights: [0.0, 1e-2, 1e-4, 1e-6],
            weight_length_mm: 50.0,
            segment_mm: 10.0,
            window_segments: 5,
            point_spacing_mm: 1.0,
            point_distribution: PointDistribution::Equidistant,
            max_turn_deg: 5.0,
            corner_deg: 2.0,
            max_corner_deg: 90.0,
            band_margin: 0.1,
            max_solve_ms: 50.0,
            qp_solver: QpSolver::Clarabel,
        }
    }
}

impl PrepConfig {
    pub(crate) fn validate(&self, v: &Validator) -> Result<(), ConfigError> {
        v.in_range("prep.tolerance_mm", self.tolerance_mm, 1e-6, 10.0)?;
        if !(2..=4).contains(&self.continuity_degree) {
            return Err(v.err("prep.continuity_degree", &format!("must be 2, 3 or 4, got {}", self.continuity_degree)));
        }
        for (i, w) in self.weights.iter().enumerate() {
            v.non_negative(&format!("prep.weights[{i}]"), *w)?;
        }
        v.non_negative("prep.weight_d4", self.weight_d4)?;
        for (i, w) in self.bspline_weights.iter().enumerate() {
            v.in_range(&format!("prep.bspline_weights[{i}]"), *w, 1e-12, 1e12)?;
        }
        if !(2..=self.continuity_degree).contains(&self.hermite_continuity) {
            return Err(v.err(
                "prep.hermite_continuity",
                &format!(
                    "must lie in 2..=continuity_degree ({}): the pieces need the QP's derivatives, got {}",
                    self.continuity_degree, self.hermite_continuity
                ),
            ));
        }
        if !(1..=3).contains(&self.bspline_knot_multiplicity) {
            return Err(v.err(
                "prep.bspline_knot_multiplicity",
                &format!("must be 1, 2 or 3 (C⁴, C³, C²), got {}", self.bspline_knot_multiplicity),
            ));
        }
        let all = [self.weights[0], self.weights[1], self.weights[2], self.weights[3], self.weight_d4];
        let used = &all[1..=self.continuity_degree as usize];
        if used.iter().all(|w| *w == 0.0) {
            return Err(v.err("prep.weights", "at least one derivative weight in use must be positive"));
        }
        v.in_range("prep.weight_length_mm", self.weight_length_mm, 1e-3, 1e5)?;
        v.in_range("prep.segment_mm", self.segment_mm, 1e-2, 1e4)?;
        if !(1..=50).contains(&self.window_segments) {
            return Err(v.err("prep.window_segments", &format!("must lie in 1..=50, got {}", self.window_segments)));
        }
        v.in_range("prep.point_spacing_mm", self.point_spacing_mm, 1e-3, 100.0)?;
        if self.point_spacing_mm > self.segment_mm {
            return Err(v.err("prep.point_spacing_mm", "must not exceed prep.segment_mm"));
        }
        v.in_range("prep.max_turn_deg", self.max_turn_deg, 0.1, 45.0)?;
        v.in_range("prep.corner_deg", self.corner_deg, 0.01, 90.0)?;
        v.in_range("prep.max_corner_deg", self.max_corner_deg, self.corner_deg, 180.0)?;
        v.in_range("prep.band_margin", self.band_margin, 0.0, 0.9)?;
        v.in_range("prep.max_solve_ms", self.max_solve_ms, 0.0, 1e5)
    }
}

/// `[control]`: the JSON-RPC control socket.
#[derive(Debug, Clone, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields, default)]
pub struct ControlConfig {
    /// Path of the Unix socket. Unset: `$XDG_RUNTIME_DIR/interpd.sock`, else `/tmp/interpd.sock`.
    pub socket: Option<String>,
    /// Stop the motion when the client that started it disconnects.
    pub stop_on_disconnect: bool,
}

impl ControlConfig {
    pub(crate) fn validate(&self, v: &Validator) -> Result<(), ConfigError> {
        if let Some(s) = &self.socket {
            if s.is_empty() {
                return Err(v.err("control.socket", "must not be empty"));
            }
        }
        Ok(())
    }

    /// The socket path to use.
    pub fn socket_path(&self) -> String {
        if let Some(s) = &self.socket {
            return s.clone();
        }
        match std::env::var("XDG_RUNTIME_DIR") {
            Ok(dir) if !dir.is_empty() => format!("{dir}/interpd.sock"),
            _ => "/tmp/interpd.sock".to_string(),
        }
    }
}

/// `[programs]`: where `program.load {"path"}` may read programs from, and how much text
/// `program.append` may hold ahead of the motion.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ProgramsConfig {
    /// The programs directory. Unset: the daemon's working directory. A path given to
    /// `program.load` must lie inside it (after symbolic links are resolved).
    pub dir: Option<String>,
    /// Program text appended and not yet read by the motion, at most, KiB: the back-pressure
    /// of `program.append`.
    pub append_buffer_kib: u32,
    /// Directories inside `dir` (relative to it) where `o<name> call` looks for `name.ngc`
    /// when the program defines no such subroutine; `"."` is `dir` itself.
    pub subroutine_path: Vec<String>,
    /// Iterations one O-word loop (`while`, `do`, `repeat`) may run, at most: a loop that runs
    /// longer is an error at its line (it most likely never ends).
    pub max_loop_iterations: u64,
    /// LinuxCNC's parameter file (`NUMBER VALUE` lines): the work offsets G54 … G59.3 with
    /// their rotations and the G28/G30 positions (#5161–#5390) are read from it at start-up
    /// and written to it by `offsets.set` and at the end of every program that changed them
    /// (G10 L2/L20, G28.1/G30.1). Relative to the configuration file's directory. Unset: no
    /// file, the offsets come from `[work_offsets]` and last until the daemon ends, and every
    /// program starts with the G28/G30 positions at 0.
    pub parameter_file: Option<String>,
}

impl Default for ProgramsConfig {
    fn default() -> Self {
        Self {
            dir: None,
            append_buffer_kib: 4096,
            subroutine_path: vec![".".to_string()],
            max_loop_iterations: 10_000_000,
            parameter_file: None,
        }
    }
}

impl ProgramsConfig {
    pub(crate) fn validate(&self, v: &Validator) -> Result<(), ConfigError> {
        if self.dir.as_deref().is_some_and(str::is_empty) {
            return Err(v.err("programs.dir", "must not be empty (leave it out for the working directory)"));
        }
        if self.parameter_file.as_deref().is_some_and(str::is_empty) {
            return Err(v.err("programs.parameter_file", "must not be empty (leave it out for no parameter file)"));
        }
        for p in &self.subroutine_path {
            let path = std::path::Path::new(p);
            if p.is_empty()
                || path.is_absolute()
                || path.components().any(|c| matches!(c, std::path::Component::ParentDir))
            {
                return Err(v.err(
                    "programs.subroutine_path",
                    &format!("'{p}' must be a directory inside programs.dir: relative, without '..'"),
                ));
            }
        }
        v.in_range("programs.max_loop_iterations", self.max_loop_iterations as f64, 1.0, 1e12)?;
        v.in_range("programs.append_buffer_kib", f64::from(self.append_buffer_kib), 1.0, 1_048_576.0)
    }

    /// The subroutine directories, each inside the programs directory (`dir`, or the working
    /// directory when unset).
    pub fn subroutine_dirs(&self) -> Vec<std::path::PathBuf> {
        let base = std::path::PathBuf::from(self.dir.as_deref().unwrap_or("."));
        self.subroutine_path.iter().map(|p| base.join(p)).collect()
    }

    /// For `interpd check` and `interpd plan`, which are given a file, not a name inside the
    /// programs directory: without a configured `dir`, the program's own directory is the
    /// programs directory, so `o<name> call` finds the subroutine files beside the program
    /// (as LinuxCNC's `rs274` does), wherever the command is run from.
    pub fn default_to_dir_of(&mut self, program: &std::path::Path) {
        if self.dir.is_none() {
            let parent = program.parent().filter(|p| !p.as_os_str().is_empty());
            self.dir = Some(parent.map_or_else(|| ".".to_string(), |p| p.to_string_lossy().into_owned()));
        }
    }

    /// The programs directory (the working directory when unset).
    pub fn base_dir(&self) -> std::path::PathBuf {
        std::path::PathBuf::from(self.dir.as_deref().unwrap_or("."))
    }

    /// [`ProgramsConfig::append_buffer_kib`] in bytes.
    pub fn append_buffer_bytes(&self) -> usize {
        self.append_buffer_kib as usize * 1024
    }
}

/// `[rt]`: scheduling of the interpolation thread.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct RtConfig {
    /// SCHED_FIFO priority (1–99) when permitted; 0 keeps the normal scheduler.
    pub priority: i32,
    /// CPU to pin the interpolation thread to; unset: the last CPU.
    pub cpu: Option<usize>,
    /// Lock all memory (mlockall) when permitted.
    pub lock_memory: bool,
    /// Nice value (−20–19) of the planner thread under the normal scheduler when permitted:
    /// below 0 it keeps its share of a CPU that busy processes compete for, so the queue of
    /// planned motion does not run dry (an underrun stops the machine along the path).
    pub planner_nice: i32,
}

impl Default for RtConfig {
    fn default() -> Self {
        Self { priority: 80, cpu: None, lock_memory: true, planner_nice: -10 }
    }
}

impl RtConfig {
    pub(crate) fn validate(&self, v: &Validator) -> Result<(), ConfigError> {
        if !(0..=99).contains(&self.priority) {
            return Err(v.err("rt.priority", &format!("must lie in 0..=99, got {}", self.priority)));
        }
        if !(-20..=19).contains(&self.planner_nice) {
            return Err(v.err("rt.planner_nice", &format!("must lie in -20..=19, got {}", self.planner_nice)));
        }
        Ok(())
    }
}

#[cfg(test)]
mod prep_tests {
    use crate::Config;

    const MACHINE: &str = "[machine]\n[[axis]]\nname = \"X\"\nkind = \"linear\"\nmax_vel = 100.0\nmax_acc = 1000.0\n\
                           max_jerk = 10000.0\nmin = -10.0\nmax = 10.0\n";

    fn prep(keys: &str) -> Result<Config, String> {
        Config::from_toml_str(&format!("{MACHINE}[prep]\n{keys}\n"), "m.toml").map_err(|e| e.to_string())
    }

    #[test]
    fn defaults_are_valid_and_keys_parse() {
        let c = prep("mode = \"smooth\"\ncontinuity_degree = 2\nweights = [0.0, 1.0, 1.0, 0.0]\nwindow_segments = 3")
            .unwrap();
        assert_eq!(c.prep.continuity_degree, 2);
        assert_eq!(c.prep.window_segments, 3);
        assert_eq!(c.prep.segment_mm, 10.0);
        assert_eq!(c.prep.method, crate::PrepMethod::Hermite);
        let c = prep("method = \"bspline\"\ncontinuity_degree = 4\nbspline_knot_multiplicity = 2").unwrap();
        assert_eq!(c.prep.method, crate::PrepMethod::Bspline);
        assert_eq!(c.prep.continuity_degree, 4);
        assert_eq!(c.prep.bspline_knot_multiplicity, 2);
    }

    #[test]
    fn bad_values_name_the_key() {
        for (text, key) in [
            ("continuity_degree = 5", "prep.continuity_degree"),
            ("method = \"nurbs\"", "prep"),
            ("bspline_weights = [1.0, 0.0, 1.0, 1.0, 1.0]", "prep.bspline_weights[1]"),
            ("weight_d4 = -1.0", "prep.weight_d4"),
            ("bspline_knot_multiplicity = 4", "prep.bspline_knot_multiplicity"),
            ("hermite_continuity = 4", "prep.hermite_continuity"),
            ("hermite_continuity = 1", "prep.hermite_continuity"),
            ("weights = [0.0, -1.0, 0.0, 0.0]", "prep.weights[1]"),
            ("weights = [1.0, 0.0, 0.0, 5.0]\ncontinuity_degree = 2", "prep.weights"),
            ("window_segments = 0", "prep.window_segments"),
            ("point_spacing_mm = 20.0", "prep.point_spacing_mm"),
            ("band_margin = 1.0", "prep.band_margin"),
            ("segment_mm = nan", "prep.segment_mm"),
            ("max_corner_deg = 1.0", "prep.max_corner_deg"),
        ] {
            let e = prep(text).expect_err(text);
            assert!(e.contains(key), "{text}: {e}");
        }
    }

    #[test]
    fn rt_section_ranges() {
        let rt = |keys: &str| {
            Config::from_toml_str(&format!("{MACHINE}[rt]\n{keys}\n"), "m.toml").map_err(|e| e.to_string())
        };
        assert_eq!(rt("planner_nice = -5").unwrap().rt.planner_nice, -5);
        assert_eq!(rt("").unwrap().rt.planner_nice, -10);
        for (text, key) in [
            ("planner_nice = -21", "rt.planner_nice"),
            ("planner_nice = 20", "rt.planner_nice"),
            ("priority = 100", "rt.priority"),
        ] {
            let e = rt(text).expect_err(text);
            assert!(e.contains(key), "{text}: {e}");
        }
    }
}
