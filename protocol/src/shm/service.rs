//! Opening the shared-memory services (feature `iceoryx2`).
//!
//! Every participant (the daemon's sink, recorder and replay, sim-plant, the tests and the
//! benchmarks) creates its node with [`NodeOptions`] and opens `<prefix>/setpoints` and
//! `<prefix>/feedback` with [`open_service`], so all of them ask for the same [`qos`] settings
//! and whichever process starts first creates a service the others can open.

use super::{ServicePayload, check_service_prefix, qos};
use iceoryx2::node::NodeCreationFailure;
use iceoryx2::prelude::*;
use iceoryx2::service::builder::publish_subscribe::{PublishSubscribeOpenError, PublishSubscribeOpenOrCreateError};
use iceoryx2::service::port_factory::publish_subscribe::PortFactory;

/// An opened publish-subscribe service of payload `T`: publishers and subscribers are built
/// from it. The node that opened it must outlive it.
pub type ServicePorts<T> = PortFactory<ipc::Service, T, ()>;

/// How a participant's iceoryx2 node is created.
///
/// The defaults suit a process that handles SIGINT/SIGTERM itself: iceoryx2 installs no signal
/// handlers, and it logs errors only unless `IOX2_LOG_LEVEL` says otherwise (without that, it
/// warns on every start that it runs on its built-in configuration, which is intended here).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct NodeOptions {
    name: Option<String>,
    handle_signals: bool,
    cleanup_dead_nodes: bool,
    keep_log_level: bool,
}

impl NodeOptions {
    /// An unnamed node with the defaults above.
    pub fn new() -> Self {
        Self::default()
    }

    /// The node name iceoryx2's tools show for this participant.
    pub fn name(mut self, name: &str) -> Self {
        self.name = Some(name.to_string());
        self
    }

    /// iceoryx2 handles SIGINT and SIGTERM: [`Node::wait`] then returns an error, which ends a
    /// loop that waits on the node.
    pub fn handle_signals(mut self) -> Self {
        self.handle_signals = true;
        self
    }

    /// Removes the resources that nodes of killed processes left behind when the node is
    /// created, so a crashed participant does not hold the services' capacity.
    pub fn cleanup_dead_nodes(mut self) -> Self {
        self.cleanup_dead_nodes = true;
        self
    }

    /// Leaves iceoryx2's log level as the process set it (for a program with a verbosity option).
    pub fn keep_log_level(mut self) -> Self {
        self.keep_log_level = true;
        self
    }

    /// Creates the node.
    pub fn create(&self) -> Result<Node<ipc::Service>, NodeError> {
        if !self.keep_log_level {
            set_log_level_from_env_or(LogLevel::Error);
        }
        let mode = if self.handle_signals {
            SignalHandlingMode::HandleTerminationRequests
        } else {
            SignalHandlingMode::Disabled
        };
        let mut builder = NodeBuilder::new().signal_handling_mode(mode);
        if let Some(name) = &self.name {
            let node_name =
                NodeName::new(name).map_err(|e| NodeError::Name { name: name.clone(), reason: format!("{e:?}") })?;
            builder = builder.name(&node_name);
        }
        let node =
            builder.create::<ipc::Service>().map_err(|cause| NodeError::Create { name: self.name.clone(), cause })?;
        if self.cleanup_dead_nodes {
            let cleaned = node.try_cleanup_dead_nodes();
            if cleaned.cleanups > 0 {
                tracing::debug!("removed the resources of {} dead iceoryx2 nodes", cleaned.cleanups);
            }
        }
        Ok(node)
    }
}

/// Why a node could not be created.
#[derive(Debug, Clone, thiserror::Error)]
pub enum NodeError {
    #[error("iceoryx2 node name {name:?}: {reason}")]
    Name { name: String, reason: String },
    #[error(
        "cannot create the iceoryx2 node{}: {cause:?} (check that this user can write to /dev/shm and to \
         iceoryx2's directory, /tmp/iceoryx2 by default)",
        name.as_deref().map(|n| format!(" {n:?}")).unwrap_or_default()
    )]
    Create { name: Option<String>, cause: NodeCreationFailure },
}

/// Why a service could not be opened. Each variant names the service (or the prefix that would
/// have named it) and says what to check.
#[derive(Debug, Clone, thiserror::Error)]
pub enum ServiceError {
    /// The prefix fails [`check_service_prefix`]; the message is that check's.
    #[error("{0}")]
    Prefix(String),
    #[error("iceoryx2 service name {service:?}: {reason}")]
    Name { service: String, reason: String },
    #[error("cannot open or create the iceoryx2 service {service:?}: {cause:?} ({})", open_hint(cause))]
    Open { service: String, cause: PublishSubscribeOpenOrCreateError },
}

impl ServiceError {
    /// Whether the prefix or the service name is at fault (the caller's input), rather than the
    /// system or another process.
    pub fn is_bad_name(&self) -> bool {
        matches!(self, ServiceError::Prefix(_) | ServiceError::Name { .. })
    }
}

/// What to check when opening a service failed.
fn open_hint(cause: &PublishSubscribeOpenOrCreateError) -> &'static str {
    use PublishSubscribeOpenError as E;
    let PublishSubscribeOpenOrCreateError::PublishSubscribeOpenError(open) = cause else {
        return SETTINGS_HINT;
    };
    match open {
        E::IncompatibleTypes | E::IncompatibleMessagingPattern | E::VersionMismatch => {
            "another process created it with a different payload type or layout: run the same interpd \
             version on all sides"
        }
        E::ExceedsMaxNumberOfNodes
        | E::DoesNotSupportRequestedAmountOfPublishers
        | E::DoesNotSupportRequestedAmountOfSubscribers
        | E::DoesNotSupportRequestedAmountOfNodes => {
            "the service is full or was created with smaller limits: stop a participant, or check that \
             all sides use interpd_protocol::shm::qos"
        }
        E::InsufficientPermissions => "this user may not open it: run all participants as the same user",
        _ => SETTINGS_HINT,
    }
}

/// The hint for every other failure: settings are the usual cause.
const SETTINGS_HINT: &str = "another process may have created it with a different payload layout or \
                             settings; all sides must use interpd_protocol::shm::qos";

/// Opens (or creates) the service of payload `T` under `prefix` (`<prefix>/setpoints` for
/// [`super::Setpoints`], `<prefix>/feedback` for [`super::Feedback`]) with the shared [`qos`].
pub fn open_service<T: ServicePayload>(
    node: &Node<ipc::Service>,
    prefix: &str,
) -> Result<ServicePorts<T>, ServiceError> {
    check_service_prefix(prefix).map_err(ServiceError::Prefix)?;
    let service = T::service_name(prefix);
    let name = ServiceName::new(&service)
        .map_err(|e| ServiceError::Name { service: service.clone(), reason: format!("{e:?}") })?;
    node.service_builder(&name)
        .publish_subscribe::<T>()
        .history_size(qos::HISTORY_SIZE)
        .subscriber_max_buffer_size(qos::SUBSCRIBER_BUFFER_SIZE)
        .max_publishers(qos::MAX_PUBLISHERS)
        .max_subscribers(qos::MAX_SUBSCRIBERS)
        .open_or_create()
        .map_err(|cause| ServiceError::Open { service, cause })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shm::{Feedback, Setpoints, feedback_service, setpoints_service};
    use iceoryx2::service::port_factory::PortFactory as _;
    use std::sync::atomic::{AtomicU32, Ordering};

    fn unique_prefix(test: &str) -> String {
        static N: AtomicU32 = AtomicU32::new(0);
        format!("interpd-test/protocol-{test}-{}-{}", std::process::id(), N.fetch_add(1, Ordering::Relaxed))
    }

    #[test]
    fn both_services_open_under_their_names_and_carry_samples() {
        let prefix = unique_prefix("open");
        let node = NodeOptions::new().name("interpd-protocol-test").create().expect("node");
        let sp = open_service::<Setpoints>(&node, &prefix).expect("setpoints");
        let fb = open_service::<Feedback>(&node, &prefix).expect("feedback");
        assert_eq!(sp.name().as_str(), setpoints_service(&prefix));
        assert_eq!(fb.name().as_str(), feedback_service(&prefix));
        // A second opening with the same settings finds the service the first created.
        let again = open_service::<Setpoints>(&node, &prefix).expect("opened again");
        let publisher = sp.publisher_builder().create().expect("publisher");
        let subscriber =
            again.subscriber_builder().buffer_size(qos::SUBSCRIBER_BUFFER_SIZE).create().expect("subscriber");
        let sent = Setpoints { cycle: 7, ..Setpoints::default() };
        publisher.loan_uninit().expect("loan").write_payload(sent).send().expect("send");
        assert_eq!(subscriber.receive().expect("receive").map(|s| *s), Some(sent));
    }

    #[test]
    fn a_bad_prefix_is_refused_before_anything_opens() {
        let node = NodeOptions::new().create().expect("node");
        let e = open_service::<Setpoints>(&node, "a b").map(|_| ()).unwrap_err();
        assert!(e.is_bad_name(), "{e}");
        assert!(e.to_string().contains("' '"), "{e}");
    }

    #[test]
    fn a_service_of_another_payload_type_is_named_in_the_error() {
        let prefix = unique_prefix("mismatch");
        let node = NodeOptions::new().create().expect("node");
        let service = setpoints_service(&prefix);
        let name = ServiceName::new(&service).expect("name");
        let _other = node
            .service_builder(&name)
            .publish_subscribe::<u64>()
            .history_size(qos::HISTORY_SIZE)
            .subscriber_max_buffer_size(qos::SUBSCRIBER_BUFFER_SIZE)
            .max_publishers(qos::MAX_PUBLISHERS)
            .max_subscribers(qos::MAX_SUBSCRIBERS)
            .create()
            .expect("a u64 service under the setpoint name");
        let e = open_service::<Setpoints>(&node, &prefix).map(|_| ()).unwrap_err();
        assert!(!e.is_bad_name());
        let text = e.to_string();
        assert!(text.contains(&service) && text.contains("payload type or layout"), "{text}");
    }
}
