//! The machining process and what the thesis measured around it (Schneider 2016): the milling
//! force on the load ([`milling`]), the force signal and the external position measurement
//! ([`measurement`]), the fast auxiliary actuator between load and tool ([`actuator`]), and the
//! static load test that identifies the deflection model from them ([`identify`]), and the
//! structure's coupled compliance between the axes and the tool ([`structure`]).

pub mod actuator;
pub mod identify;
pub mod measurement;
pub mod milling;
pub mod structure;
