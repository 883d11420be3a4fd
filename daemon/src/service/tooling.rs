//! `tools.get/set` and `offsets.get/set`: the tool table and work offsets programs are read
//! with. They start as the machine file's and apply to programs loaded (and `mdi` blocks run)
//! after a change; a loaded or running program keeps the path it was read with, so a change is
//! allowed in every state.

use super::param_store::Kept;
use super::{ServiceCore, lock};
use crate::config::{ToolConfig, WORK_SYSTEMS};
use crate::control::errors::ManualError;
use interpd_motion::Settings;
use interpd_protocol::api::{Method, Tool, ToolTable, WorkOffsets};
use std::collections::BTreeMap;
use std::sync::Arc;

/// The tool table and work offsets a program is read with (`tools.set`, `offsets.set`): taken
/// at `program.load`, so the motion reads the program as it was checked.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tooling {
    pub tools: Vec<interpd_config::ToolConfig>,
    pub work_offsets: interpd_config::WorkOffsetsConfig,
    /// The G28/G30 positions (the parameter file's; 0 without one).
    pub home_positions: interpd_motion::program::HomePositions,
}

impl Tooling {
    /// `settings` with this tool table, these work offsets and G28/G30 positions.
    pub fn apply(&self, settings: &Settings) -> Settings {
        Settings {
            tools: self.tools.clone(),
            work_offsets: self.work_offsets.clone(),
            home_positions: self.home_positions,
            ..settings.clone()
        }
    }

    /// What the parameter file keeps of it.
    fn kept(&self) -> Kept {
        Kept { work_offsets: self.work_offsets.clone(), home_positions: self.home_positions }
    }
}

impl ServiceCore {
    pub(crate) fn tool_table(&self) -> ToolTable {
        let t = lock(&self.shared.tooling);
        ToolTable {
            tools: t
                .tools
                .iter()
                .map(|c| Tool {
                    number: c.number,
                    diameter_mm: c.diameter_mm,
                    length_mm: c.length_mm,
                    name: c.name.clone(),
                })
                .collect(),
        }
    }

    /// Replaces the tool table (checked by the protocol: numbers unique and in range,
    /// diameters ≥ 0, values finite).
    pub(crate) fn set_tool_table(&self, table: ToolTable) -> ToolTable {
        let tools = table
            .tools
            .into_iter()
            .map(|t| ToolConfig { number: t.number, diameter_mm: t.diameter_mm, length_mm: t.length_mm, name: t.name })
            .collect();
        {
            // Copy on write: a loaded program keeps the table it was read with.
            let mut t = lock(&self.shared.tooling);
            let mut next = (**t).clone();
            next.tools = tools;
            *t = Arc::new(next);
        }
        tracing::info!("tool table replaced");
        self.tool_table()
    }

    /// Every system with every axis of the machine, and every system's rotation.
    pub(crate) fn work_offsets(&self) -> WorkOffsets {
        let t = lock(&self.shared.tooling);
        let axes = &self.shared.settings.axes;
        let offsets = WORK_SYSTEMS
            .iter()
            .enumerate()
            .map(|(i, name)| {
                let v = t.work_offsets.vector(i, axes);
                (name.to_string(), axes.iter().enumerate().map(|(k, a)| (a.name.to_string(), v[k])).collect())
            })
            .collect();
        let rotations_deg =
            WORK_SYSTEMS.iter().enumerate().map(|(i, name)| (name.to_string(), t.work_offsets.rotation(i))).collect();
        WorkOffsets { offsets, rotations_deg }
    }

    /// Replaces the systems given, each whole, and the rotations given; the axis names must be
    /// the machine's.
    pub(crate) fn set_work_offsets(&self, offsets: WorkOffsets) -> Result<WorkOffsets, ManualError> {
        let axes = &self.shared.settings.axes;
        for (system, values) in &offsets.offsets {
            if let Some(axis) = values.keys().find(|a| !axes.iter().any(|c| c.name.to_string() == **a)) {
                let names: Vec<String> = axes.iter().map(|a| a.name.to_string()).collect();
                return Err(ManualError::Param {
                    method: Method::OffsetsSet,
                    param: format!("offsets.{system}.{axis}"),
                    detail: format!("{axis:?} is not an axis of this machine (axes: {})", names.join(" ")),
                });
            }
        }
        {
            let mut t = lock(&self.shared.tooling);
            let mut next = (**t).clone();
            let index = |system: &str| WORK_SYSTEMS.iter().position(|w| *w == system).expect("checked by the protocol");
            for (system, values) in offsets.offsets {
                *next.work_offsets.systems_mut()[index(&system)] = values.into_iter().collect::<BTreeMap<_, _>>();
            }
            for (system, deg) in offsets.rotations_deg {
                next.work_offsets.set_rotation(index(&system), deg);
            }
            // Kept for good first: a change the file cannot take is refused whole.
            if let Some(store) = &self.shared.params {
                store.save(&next.kept(), axes).map_err(|e| ManualError::ParamFile {
                    file: store.path().display().to_string(),
                    message: e.to_string(),
                })?;
            }
            *t = Arc::new(next);
        }
        tracing::info!("work offsets changed");
        Ok(self.work_offsets())
    }
}

impl super::Shared {
    /// A program ran to its end: the work offsets its G10 L2/L20 left and the G28/G30
    /// positions its G28.1/G30.1 left become the machine's (for programs loaded after it, as
    /// `offsets.set`) and go to the parameter file. Without a parameter file, a program's G10
    /// and G28.1 change them for that program only.
    pub(super) fn keep_program_offsets(&self, kept: &Kept) {
        let shared = self;
        let Some(store) = &shared.params else { return };
        let axes = &shared.settings.axes;
        let mut t = lock(&shared.tooling);
        if t.kept().same_on(kept, axes) {
            return;
        }
        let mut next = (**t).clone();
        next.work_offsets = kept.work_offsets.clone();
        next.home_positions = kept.home_positions;
        match store.save(&next.kept(), axes) {
            Ok(()) => *t = Arc::new(next),
            Err(e) => {
                drop(t);
                let message = format!(
                    "cannot write the parameter file {}: {e}; the program's work offsets and G28/G30 positions are not kept",
                    store.path().display()
                );
                tracing::error!("{message}");
                shared.emit(interpd_protocol::api::Event::Error { message });
            }
        }
    }
}
