//! The result of `status`: the machine state, the motion, the timing of the cycles and the
//! CAN drives.
//!
//! Missing members deserialize to their defaults so that clients keep working when the daemon
//! adds members, and a daemon's newer members are ignored by older clients.

use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::fmt;

/// The machine state as `status` reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum State {
    /// No motion; a program may or may not be loaded.
    #[default]
    Idle,
    Running,
    /// Feed hold active or being approached (the path velocity is brought to zero on the path).
    Holding,
    /// A stop is being executed; the state becomes `idle` when the machine stands.
    Stopping,
    /// The program ran to its end.
    Finished,
    /// Motion was aborted by an error (see `last_error`).
    Error,
    /// A manual motion (`motion.jog`, `motion.move_to`) is in progress.
    Jogging,
    /// The program stands at a program stop (M0, M1, M60) and waits for `motion.resume`.
    Paused,
}

impl State {
    pub const ALL: [State; 8] = [
        State::Idle,
        State::Running,
        State::Holding,
        State::Stopping,
        State::Finished,
        State::Error,
        State::Jogging,
        State::Paused,
    ];

    pub const fn as_str(self) -> &'static str {
        match self {
            State::Idle => "idle",
            State::Running => "running",
            State::Holding => "holding",
            State::Stopping => "stopping",
            State::Finished => "finished",
            State::Error => "error",
            State::Jogging => "jogging",
            State::Paused => "paused",
        }
    }
}

impl fmt::Display for State {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Percentiles of a per-cycle measurement, microseconds.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct Percentiles {
    pub p50: f64,
    pub p99: f64,
    pub p999: f64,
    pub max: f64,
}

/// Statistics of the interpolation cycles since motion started.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct CycleStats {
    /// Wake-up latency: actual wake-up time minus the cycle's deadline.
    pub wakeup_us: Percentiles,
    /// Time spent computing one cycle.
    pub compute_us: Percentiles,
    /// Cycles whose computation ran past the next deadline.
    pub overruns: u64,
    /// Cycles that started late (woke after their deadline by more than the allowed slack).
    pub late: u64,
}

/// The loaded program.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct ProgramInfo {
    /// The path it was loaded from, or the `name` given with inline text.
    pub name: String,
    /// Geometry elements (lines, arcs, spline spans, table rows).
    pub elements: u64,
    /// Path length, mm.
    pub length_mm: f64,
    /// Source lines.
    pub lines: u32,
    /// The program ends (M2, M30, a closing `%`; path tables always end). One without an end
    /// can be continued with `program.append`; running out of it stops the motion until more
    /// arrives.
    #[serde(default = "ended")]
    pub program_end: bool,
    /// Tools of the tool table the program uses (G43 H, G41/G42 D).
    pub tools: Vec<u32>,
    /// Work coordinate systems the program selects (G54 … G59; a program starts in G54).
    pub work_offsets: Vec<String>,
    /// The program compensates the cutter radius (G41/G42): its path is the tool centre's.
    pub cutter_compensation: bool,
}

fn ended() -> bool {
    true
}

/// The text `program.append` holds ahead of the motion (`status.program_buffer`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ProgramBuffer {
    /// Appended text not yet read by the motion, bytes.
    pub buffered_bytes: u64,
    /// `[programs] append_buffer_kib` in bytes.
    pub limit_bytes: u64,
    /// More text can be appended (the program has not ended).
    pub open: bool,
}

/// One CAN drive as the master sees it (`status.drives`). Members the master has not received
/// yet are `null`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct DriveStatus {
    /// Axis name, e.g. `"X"`.
    pub axis: String,
    /// CANopen node-ID, 1..=127.
    pub node: u8,
    /// CiA 402 state of the last statusword in snake case (`"operation_enabled"`, …),
    /// `"unknown"` before the first TPDO1, `"undefined_statusword"` for a bit pattern CiA 402
    /// does not define.
    pub state: String,
    /// Statusword of the last TPDO1.
    pub statusword: Option<u16>,
    /// NMT state of the last heartbeat (`"operational"`, `"pre-operational"`, …).
    pub nmt: Option<String>,
    /// Position actual value of the last TPDO1, increments.
    pub position_actual: i32,
    /// The same in axis units (mm or deg).
    pub position_actual_units: f64,
    /// Target position of the last RPDO1 sent, increments.
    pub target_position: i32,
    /// Controlword of the last RPDO1 sent.
    pub controlword: Option<u16>,
    /// TPDO1 frames received.
    pub tpdo_count: u64,
    pub last_tpdo_ms_ago: Option<f64>,
    pub last_heartbeat_ms_ago: Option<f64>,
    /// A heartbeat-lost fault was reported and no heartbeat came since.
    pub heartbeat_lost: bool,
    /// Emergency messages received.
    pub emcy_count: u64,
    /// Error code of the last EMCY, as `"0x8100"`.
    pub last_emcy_code: Option<String>,
    /// Its meaning (CiA 301 / CiA 402 0x603F), e.g. `"following error"`.
    #[serde(default)]
    pub last_emcy_text: Option<String>,
    /// The master has configured the drive over SDO (boot-up, PDOs, mode, heartbeat) since its
    /// last boot-up message.
    #[serde(default)]
    pub configured: bool,
    /// The last failed SDO transfer with the node (its configuration at boot, or
    /// `drives.sdo_read`/`drives.sdo_write`): node, object, abort code and its meaning.
    #[serde(default)]
    pub last_sdo_error: Option<String>,
    /// `machine.home` homed the drive, and it has not booted again or left NMT operational
    /// since.
    #[serde(default)]
    pub homed: bool,
}

/// The result of `status`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Status {
    pub state: State,
    /// Program line being executed (1-based, 0 if none).
    pub line: u32,
    /// Path position, mm.
    pub s_mm: f64,
    /// Current path velocity, mm/s (after the override).
    pub feed_mm_s: f64,
    /// Feed override factor in effect, 0.0..=2.0.
    #[serde(rename = "override")]
    pub feed_override: f64,
    /// Fill of the planner-to-interpolator profile queue, 0..=1.
    pub queue_fill: f64,
    /// Seconds of motion planned ahead in the queue.
    pub queue_s: f64,
    /// Interpolation cycle number (0 when motion starts).
    pub cycle: u64,
    pub cycles: CycleStats,
    pub last_error: Option<String>,
    pub program: Option<ProgramInfo>,
    /// For a loaded program without an end: the `program.append` buffer; `null` otherwise.
    pub program_buffer: Option<ProgramBuffer>,
    /// Axis names in configuration order.
    pub axes: Vec<String>,
    /// Commanded position per axis, in the order of `axes` (mm or deg).
    pub position: Vec<f64>,
    /// CAN drives, one per axis when the CAN sink runs (empty otherwise).
    pub drives: Vec<DriveStatus>,
    /// Every CAN drive is homed (`machine.home`); `null` without CAN drives.
    pub homed: Option<bool>,
    /// CAN bus counters of the master (frames sent and received, malformed frames by kind,
    /// send failures by errno class, error frames, candump log records); absent without CAN.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub can_bus: Option<Value>,
    /// The manual motion running or run last (`motion.jog`, `motion.move_to`); `null` until
    /// the first one, and again after a program or MDI start.
    pub manual: Option<ManualStatus>,
    /// The modal state `mdi` blocks run in: the active work coordinate system and tool length
    /// compensation; `null` before the first `mdi` call. (A program's own appear in
    /// `program`; cutter compensation ends with each `mdi` call.)
    pub mdi: Option<MdiModal>,
    /// The tool, offsets and cutter compensation of the program element the machine is
    /// executing now (`null` before the first program start, for path tables and law
    /// programs, and while MDI or manual motion runs).
    pub modal: Option<ProgramModal>,
    /// How far ahead of the machine the look-ahead stayed in the current or last motion.
    pub lookahead: LookaheadStatus,
    /// The optional-stop switch: M1 pauses the program (`motion.optional_stop`).
    pub optional_stop: bool,
    /// The program stop the program waits at (state `paused`); `null` otherwise.
    pub pause: Option<PauseStatus>,
}

/// The program stop a paused program waits at, in `status.pause`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct PauseStatus {
    pub line: u32,
    pub code: super::PauseCode,
}

/// How the look-ahead (the planner thread) kept up in the current or last motion, in
/// `status.lookahead`; reset when a motion starts or a held program resumes after an excursion.
/// Steps count from when the queue reaches its depth after each start from rest until the last
/// chunk is queued.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct LookaheadStatus {
    /// The longest single step of the planner thread (reading, smoothing and planning the
    /// motion of one chunk, or one slice of reading ahead), ms.
    pub step_max_ms: f64,
    /// The least motion that was queued ahead of the real-time thread when the planner thread
    /// began a step, s, as chunks × their nominal duration (`null` before the queue first
    /// reached its depth). A step longer than this runs the queue dry.
    pub queue_min_s: Option<f64>,
}

/// The tool and offset state of the executing program element, in `status.modal`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct ProgramModal {
    /// The program line it applies to (the element's line, as `status.line`).
    pub line: u32,
    /// `"G54"` … `"G59"`.
    pub work_offset: String,
    /// That system's offset per axis, in the order of `status.axes` (mm or deg).
    pub work_offset_values: Vec<f64>,
    /// The G92 offset per axis, in the order of `status.axes`, added to every work offset
    /// (zeros without G92).
    pub g92_offset: Vec<f64>,
    /// The tool in the spindle (`T` … `M6`); `null` before the first tool change.
    pub tool: Option<SpindleTool>,
    /// Tool length compensation (G43 H / G43.1); `null` with G49.
    pub tool_length: Option<ToolLength>,
    pub cutter: CutterStatus,
}

/// The tool in the spindle.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct SpindleTool {
    pub number: u32,
    /// From the tool table the program was loaded with; `null` if it has no such tool.
    pub length_mm: Option<f64>,
    pub radius_mm: Option<f64>,
}

/// Cutter radius compensation.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct CutterStatus {
    pub mode: CutterMode,
    /// The offset, mm (0 when off).
    pub radius_mm: f64,
    /// The tool of G41/G42 D; `null` for G41.1/G42.1 and when off.
    pub tool: Option<u32>,
}

/// Off (G40), left (G41, G41.1) or right (G42, G42.1) of the direction of travel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CutterMode {
    #[default]
    Off,
    Left,
    Right,
}

/// The tool state of `mdi` blocks, in `status.mdi`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct MdiModal {
    /// `"G54"` … `"G59"`.
    pub work_offset: String,
    /// Tool length compensation (G43 H / G43.1); `null` with G49.
    pub tool_length: Option<ToolLength>,
}

/// Active tool length compensation.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct ToolLength {
    /// The tool of G43 H; `null` for G43.1 (the length given in the block).
    pub tool: Option<u32>,
    /// The length added to Z, mm.
    pub length_mm: f64,
}

/// The manual motion in `status.manual`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ManualStatus {
    pub kind: super::ManualKind,
    /// Axes whose jog brakes to (or stands at) a soft limit, in configuration order.
    #[serde(default)]
    pub limit_reached: Vec<String>,
}

impl Default for Status {
    fn default() -> Status {
        Status {
            state: State::Idle,
            line: 0,
            s_mm: 0.0,
            feed_mm_s: 0.0,
            feed_override: 1.0,
            queue_fill: 0.0,
            queue_s: 0.0,
            cycle: 0,
            cycles: CycleStats::default(),
            last_error: None,
            program: None,
            program_buffer: None,
            axes: Vec::new(),
            position: Vec::new(),
            drives: Vec::new(),
            homed: None,
            can_bus: None,
            manual: None,
            mdi: None,
            modal: None,
            lookahead: LookaheadStatus::default(),
            optional_stop: true,
            pause: None,
        }
    }
}
