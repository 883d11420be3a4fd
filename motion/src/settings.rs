//! What the motion library needs to know of a machine.

use interpd_config::{
    AxisConfig, AxisLetter, Config, ConfigError, PlannerConfig, PrepConfig, ProgramsConfig, ToolConfig,
    WorkOffsetsConfig,
};

/// The machine's axes with their limits, and the planner and smoothing settings: the part of
/// a machine file the motion library reads. The daemon's other sections (sinks, plant,
/// control, real-time) stay out of it.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Axes in machine order (the order of the setpoints' per-axis arrays).
    pub axes: Vec<AxisConfig>,
    pub planner: PlannerConfig,
    pub prep: PrepConfig,
    /// The tool table (G43 H, G41/G42 D).
    pub tools: Vec<ToolConfig>,
    /// The work coordinate systems G54 … G59.3 and their rotations.
    pub work_offsets: WorkOffsetsConfig,
    /// The G28/G30 positions a program starts with (0 unless a parameter file keeps them).
    pub home_positions: crate::program::HomePositions,
    /// Where subroutine files are found and how long a loop may run.
    pub programs: ProgramsConfig,
}

impl Settings {
    /// The motion sections of a validated configuration.
    pub fn from_config(config: &Config) -> Self {
        Self {
            axes: config.axes.clone(),
            planner: config.planner.clone(),
            prep: config.prep.clone(),
            tools: config.tools.clone(),
            work_offsets: config.work_offsets.clone(),
            home_positions: Default::default(),
            programs: config.programs.clone(),
        }
    }

    /// Reads, parses and validates a machine file and takes its motion sections.
    pub fn load(path: &std::path::Path) -> Result<Self, ConfigError> {
        Config::load(path).map(|c| Self::from_config(&c))
    }

    /// Parses and validates machine-file text; `origin` names it in error messages.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, ConfigError> {
        Config::from_toml_str(text, origin).map(|c| Self::from_config(&c))
    }

    /// The embedded default machine (X Y Z).
    pub fn default_machine() -> Self {
        Self::from_config(&Config::default_machine())
    }

    /// The embedded five-axis example machine (X Y Z A B).
    pub fn five_axis_machine() -> Self {
        Self::from_config(&Config::five_axis_machine())
    }

    /// Index of the axis with this G-code letter, if the machine has it.
    pub fn axis_index(&self, letter: AxisLetter) -> Option<usize> {
        self.axes.iter().position(|a| a.name == letter)
    }

    /// The tool with this number, if the table has it.
    pub fn tool(&self, number: u32) -> Option<&ToolConfig> {
        self.tools.iter().find(|t| t.number == number)
    }

    /// Axis names in machine order.
    pub fn axis_names(&self) -> Vec<String> {
        self.axes.iter().map(|a| a.name.to_string()).collect()
    }
}

impl From<&Config> for Settings {
    fn from(config: &Config) -> Self {
        Self::from_config(config)
    }
}
