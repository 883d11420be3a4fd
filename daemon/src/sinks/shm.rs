//! Setpoints over iceoryx2 shared memory: service `<prefix>/setpoints`, payload [`Setpoints`],
//! zero copy. The publisher is created in the thread that publishes (iceoryx2 ports of
//! `ipc::Service` stay in their thread).

use super::{SetpointSink, SinkError};
use iceoryx2::prelude::*;
use interpd_protocol::shm::{NodeOptions, Setpoints, open_service};

/// Publishes setpoints on `<prefix>/setpoints`.
pub struct ShmSink {
    publisher: iceoryx2::port::publisher::Publisher<ipc::Service, Setpoints, ()>,
    // The node owns the service; keep it alive as long as the publisher.
    _node: Node<ipc::Service>,
}

impl ShmSink {
    /// Creates the publisher on `<prefix>/setpoints`.
    pub fn create(prefix: &str) -> Result<Self, SinkError> {
        let setup = |message: String| SinkError::Setup { sink: "shm".into(), message };
        let node = NodeOptions::new().name("interpd").create().map_err(|e| setup(e.to_string()))?;
        let service = open_service::<Setpoints>(&node, prefix).map_err(|e| setup(e.to_string()))?;
        let publisher =
            service.publisher_builder().create().map_err(|e| setup(format!("cannot create the publisher: {e:?}")))?;
        Ok(Self { publisher, _node: node })
    }
}

impl SetpointSink for ShmSink {
    fn publish(&mut self, setpoint: &Setpoints) -> Result<(), SinkError> {
        let sample = self.publisher.loan_uninit().map_err(|_| SinkError::Publish)?;
        let mut sp = *setpoint;
        sp.publish_ns = crate::rt::clock::now_ns();
        sample.write_payload(sp).send().map_err(|_| SinkError::Publish)?;
        Ok(())
    }
}
