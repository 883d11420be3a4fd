//! `tools.get/set` and `offsets.get/set`: the tool table and work offsets programs are read
//! with. They start as the machine file's and apply to programs loaded (and `mdi` blocks run)
//! after a change; a loaded or running program keeps the path it was read with, so a change is
//! allowed in every state.

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
}

impl Tooling {
    /// `settings` with this tool table and these work offsets.
    pub fn apply(&self, settings: &Settings) -> Settings {
        Settings { tools: self.tools.clone(), work_offsets: self.work_offsets.clone(), ..settings.clone() }
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

    /// Every system with every axis of the machine.
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
        WorkOffsets { offsets }
    }

    /// Replaces the systems given, each whole; the axis names must be the machine's.
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
            for (system, values) in offsets.offsets {
                let i = WORK_SYSTEMS.iter().position(|w| *w == system).expect("checked by the protocol");
                *next.work_offsets.systems_mut()[i] = values.into_iter().collect::<BTreeMap<_, _>>();
            }
            // Kept for good first: a change the file cannot take is refused whole.
            if let Some(store) = &self.shared.params {
                store.save(&next.work_offsets, axes).map_err(|e| ManualError::ParamFile {
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
    /// A program ran to its end: the work offsets its G10 L2/L20 left become the machine's
    /// (for programs loaded after it, as `offsets.set`) and go to the parameter file. Without a
    /// parameter file, a program's G10 changes the offsets for that program only.
    pub(super) fn keep_program_offsets(&self, offsets: &interpd_config::WorkOffsetsConfig) {
        let shared = self;
        let Some(store) = &shared.params else { return };
        let axes = &shared.settings.axes;
        let mut t = lock(&shared.tooling);
        if super::param_store::same_offsets(&t.work_offsets, offsets, axes) {
            return;
        }
        let mut next = (**t).clone();
        next.work_offsets = offsets.clone();
        match store.save(&next.work_offsets, axes) {
            Ok(()) => *t = Arc::new(next),
            Err(e) => {
                drop(t);
                let message = format!(
                    "cannot write the parameter file {}: {e}; the program's work offsets are not kept",
                    store.path().display()
                );
                tracing::error!("{message}");
                shared.emit(interpd_protocol::api::Event::Error { message });
            }
        }
    }
}
