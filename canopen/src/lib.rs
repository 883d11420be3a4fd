//! CANopen services beyond the frames of `interpd_protocol::cia301`, as pure state machines
//! (frames in, frames out, explicit times) so that they are tested without a bus and run on any
//! thread: the SDO client and server of CiA 301, an object dictionary, and the reader of CiA 306
//! EDS/DCF files.

pub mod boot;
pub mod eds;
pub mod ini;
pub mod od;
pub mod sdo_abort;
pub mod sdo_client;
pub mod sdo_frame;
pub mod sdo_server;

pub use sdo_abort::SdoAbort;
pub use sdo_frame::Address;
