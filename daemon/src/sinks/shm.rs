//! Setpoints over iceoryx2 shared memory: service `<prefix>/setpoints` (DESIGN.md), payload
//! [`Setpoints`], zero copy. The publisher is created in the thread that publishes (iceoryx2
//! ports of `ipc::Service` stay in their thread).

use super::{SetpointSink, SinkError};
use iceoryx2::prelude::*;
use interpd_protocol::shm::{Setpoints, qos};

/// Publishes setpoints on `<prefix>/setpoints`.
pub struct ShmSink {
    publisher: iceoryx2::port::publisher::Publisher<ipc::Service, Setpoints, ()>,
    // The node owns the service; keep it alive as long as the publisher.
    _node: Node<ipc::Service>,
}

/// The node every interpd iceoryx2 participant uses: no signal handlers of its own (the daemon
/// handles SIGINT/SIGTERM itself).
pub fn node(name: &str) -> Result<Node<ipc::Service>, String> {
    // iceoryx2 warns on stderr that it runs on its built-in defaults; that is intended here
    // (IOX2_LOG_LEVEL overrides).
    set_log_level_from_env_or(LogLevel::Error);
    let node_name = NodeName::new(name).map_err(|e| format!("node name {name:?}: {e:?}"))?;
    NodeBuilder::new()
        .name(&node_name)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(|e| format!("cannot create the iceoryx2 node: {e:?}"))
}

/// The publish-subscribe service `<prefix>/<service>` of payload `T`, with the shared settings.
pub fn open_service<T: std::fmt::Debug + ZeroCopySend + 'static>(
    node: &Node<ipc::Service>,
    prefix: &str,
    service: &str,
) -> Result<iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, T, ()>, String> {
    let full = format!("{prefix}/{service}");
    let name: ServiceName = full.as_str().try_into().map_err(|e| format!("service name {full:?}: {e:?}"))?;
    node.service_builder(&name)
        .publish_subscribe::<T>()
        .history_size(qos::HISTORY_SIZE)
        .subscriber_max_buffer_size(qos::SUBSCRIBER_BUFFER_SIZE)
        .max_publishers(qos::MAX_PUBLISHERS)
        .max_subscribers(qos::MAX_SUBSCRIBERS)
        .open_or_create()
        .map_err(|e| format!("cannot open or create the iceoryx2 service {full:?}: {e:?}"))
}

impl ShmSink {
    /// Creates the publisher on `<prefix>/setpoints`.
    pub fn create(prefix: &str) -> Result<Self, SinkError> {
        let setup = |message: String| SinkError::Setup { sink: "shm".into(), message };
        let node = node("interpd").map_err(setup)?;
        let service = open_service::<Setpoints>(&node, prefix, "setpoints").map_err(setup)?;
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
