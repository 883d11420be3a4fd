//! The machining process and what the thesis measured around it (Schneider 2016): the milling
//! force on the load ([`milling`]), the force signal and the external position measurement
//! ([`measurement`]) and the fast auxiliary actuator between load and tool ([`actuator`]).

pub mod actuator;
pub mod measurement;
pub mod milling;
