//! The plant as an iceoryx2 node: subscribes to `PREFIX/setpoints`, steps the models to each
//! setpoint's time and publishes `PREFIX/feedback` answering it (payloads in
//! [`interpd_protocol::shm`]).
//!
//! The plant runs on the setpoints' clock, not on the wall clock: a setpoint for time t makes
//! the drives interpolate from the previous setpoint to it and the models integrate up to t at
//! the servo rate, and the feedback reports the state at t. So the simulation is as fast as the
//! daemon publishes and a descheduled plant catches up without changing the result. The
//! subscriber is polled (the wire contract has no notification event); the node's wait returns
//! on SIGINT/SIGTERM, which ends [`ShmPlant::run`] cleanly.

use crate::PlantError;
use crate::metrics::Metrics;
use crate::plant::{AxisTarget, InputStats, MAX_GAP_S, Plant};
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use interpd_protocol::MAX_AXES;
use interpd_protocol::shm::{
    self, ActuatorCommand, Feedback, Measurement, NodeOptions, ServiceError, Setpoints, flags, open_service, qos,
};
use std::time::{Duration, Instant};
use tracing::warn;

/// Rejected setpoints logged individually; later ones are only counted.
const LOGGED_REJECTIONS: u64 = 10;
/// Without a setpoint for this long the node polls at [`IDLE_POLL`] instead of
/// [`RunOptions::poll`] (an idle plant should not cost a tenth of a core).
const IDLE_AFTER: Duration = Duration::from_millis(100);
/// Poll period while idle: delays only the first feedback of a new motion, by at most this.
const IDLE_POLL: Duration = Duration::from_millis(2);

/// How [`ShmPlant::run`] behaves.
#[derive(Debug, Clone, PartialEq)]
pub struct RunOptions {
    /// Sleep between polls of the subscriber while setpoints arrive (idle: 2 ms, or this if it is longer).
    pub poll: Duration,
    /// Stop after the first setpoint flagged FINISHED, once the plant has settled for
    /// `settle_s` more (simulated in-process, holding the last setpoint; not published).
    pub exit_on_finish: bool,
    /// Settling time simulated after FINISHED, s.
    pub settle_s: f64,
}

impl Default for RunOptions {
    fn default() -> Self {
        Self { poll: Duration::from_micros(200), exit_on_finish: false, settle_s: 1.0 }
    }
}

/// Why the run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopReason {
    /// SIGINT or SIGTERM.
    Signal,
    /// A FINISHED setpoint arrived with [`RunOptions::exit_on_finish`].
    Finished,
}

/// What a run did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunReport {
    pub stop: StopReason,
    /// Setpoint input counters.
    pub stats: InputStats,
    /// Feedback samples published.
    pub published: u64,
    /// Wall time of the run, s.
    pub wall_s: f64,
    /// Simulated plant time covered, s.
    pub simulated_s: f64,
    /// Time spent stepping the plant, s (simulated_s / compute_s is the real-time factor).
    pub compute_s: f64,
}

/// Running figures of [`ShmPlant::run`].
#[derive(Debug, Default)]
struct Progress {
    /// Plant time of the first accepted setpoint, ns.
    first_ns: Option<u64>,
    /// Time between the last two accepted setpoints, ns (the settling step).
    last_interval_ns: u64,
    compute: Duration,
    published: u64,
    /// Reused feedback payload.
    feedback: Feedback,
    /// Reused measurement payload.
    measurement: Measurement,
}

/// The iceoryx2 node with its setpoint subscriber and feedback publisher.
pub struct ShmPlant {
    node: Node<ipc::Service>,
    subscriber: Subscriber<ipc::Service, Setpoints, ()>,
    publisher: Publisher<ipc::Service, Feedback, ()>,
    /// `PREFIX/measurement` when the plant has sensors.
    measurement: Option<Publisher<ipc::Service, Measurement, ()>>,
    /// `PREFIX/actuator` when the plant has fast actuators.
    actuator: Option<Subscriber<ipc::Service, ActuatorCommand, ()>>,
    prefix: String,
    setpoints_name: String,
    feedback_name: String,
}

impl std::fmt::Debug for ShmPlant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShmPlant")
            .field("setpoints", &self.setpoints_name)
            .field("feedback", &self.feedback_name)
            .finish_non_exhaustive()
    }
}

/// The service prefix from the environment ([`shm::SERVICE_PREFIX_ENV`]) or the default.
pub fn prefix_from_env() -> String {
    std::env::var(shm::SERVICE_PREFIX_ENV).unwrap_or_else(|_| shm::DEFAULT_SERVICE_PREFIX.to_string())
}

impl ShmPlant {
    /// Creates the node and opens (or creates) both services under `prefix` with the shared
    /// [`qos`] settings. Errors name the service and say what to check.
    pub fn open(prefix: &str) -> Result<Self, PlantError> {
        // iceoryx2 handles SIGINT/SIGTERM here: the node's wait then ends `run`. The log level
        // is the one main set from `-v`.
        let node = NodeOptions::new()
            .handle_signals()
            .cleanup_dead_nodes()
            .keep_log_level()
            .create()
            .map_err(|e| PlantError::Transport(e.to_string()))?;
        let service_err = |e: ServiceError| {
            if e.is_bad_name() { PlantError::Input(e.to_string()) } else { PlantError::Transport(e.to_string()) }
        };
        let setpoints = open_service::<Setpoints>(&node, prefix).map_err(service_err)?;
        let feedback = open_service::<Feedback>(&node, prefix).map_err(service_err)?;
        let setpoints_name = shm::setpoints_service(prefix);
        let feedback_name = shm::feedback_service(prefix);
        let subscriber = setpoints
            .subscriber_builder()
            .buffer_size(qos::SUBSCRIBER_BUFFER_SIZE)
            .create()
            .map_err(|e| PlantError::Transport(format!("cannot subscribe to {setpoints_name}: {e:?}")))?;
        let publisher = feedback
            .publisher_builder()
            .create()
            .map_err(|e| PlantError::Transport(format!("cannot publish on {feedback_name}: {e:?}")))?;
        Ok(Self {
            node,
            subscriber,
            publisher,
            measurement: None,
            actuator: None,
            prefix: prefix.to_string(),
            setpoints_name,
            feedback_name,
        })
    }

    /// Opens `PREFIX/measurement` (publisher) when `plant` has sensors and `PREFIX/actuator`
    /// (subscriber) when it has fast actuators.
    pub fn open_process_io(&mut self, plant: &Plant) -> Result<(), PlantError> {
        let transport = |e: ServiceError| PlantError::Transport(e.to_string());
        if plant.has_sensors() {
            let service = open_service::<Measurement>(&self.node, &self.prefix).map_err(transport)?;
            let p = service
                .publisher_builder()
                .create()
                .map_err(|e| PlantError::Transport(format!("cannot publish on {}/measurement: {e:?}", self.prefix)))?;
            self.measurement = Some(p);
        }
        if (0..plant.n_axes()).any(|i| plant.actuator(i).is_some()) {
            let service = open_service::<ActuatorCommand>(&self.node, &self.prefix).map_err(transport)?;
            let sub =
                service.subscriber_builder().buffer_size(qos::SUBSCRIBER_BUFFER_SIZE).create().map_err(|e| {
                    PlantError::Transport(format!("cannot subscribe to {}/actuator: {e:?}", self.prefix))
                })?;
            self.actuator = Some(sub);
        }
        Ok(())
    }

    /// The setpoint service name.
    pub fn setpoints_service(&self) -> &str {
        &self.setpoints_name
    }
    /// The feedback service name.
    pub fn feedback_service(&self) -> &str {
        &self.feedback_name
    }

    /// Serves setpoints until SIGINT/SIGTERM (or FINISHED with `exit_on_finish`), recording
    /// every accepted setpoint into `metrics`. Rejected setpoints are counted in the report's
    /// stats and logged (the first few) with the reason.
    pub fn run(
        &self,
        plant: &mut Plant,
        mut metrics: Option<&mut Metrics>,
        options: &RunOptions,
    ) -> Result<RunReport, PlantError> {
        let start = Instant::now();
        let mut run = Progress { first_ns: plant.started().then(|| plant.time_ns()), ..Progress::default() };
        let mut last_receive: Option<Instant> = None;
        let finished = 'serve: loop {
            let active = last_receive.is_some_and(|t| t.elapsed() < IDLE_AFTER);
            if self.node.wait(if active { options.poll } else { IDLE_POLL.max(options.poll) }).is_err() {
                break 'serve None;
            }
            while let Some(sp) = self.receive()? {
                last_receive = Some(Instant::now());
                if self.serve(plant, metrics.as_deref_mut(), &sp, &mut run)?
                    && options.exit_on_finish
                    && sp.flags & flags::FINISHED != 0
                {
                    break 'serve Some(sp);
                }
            }
        };
        let stop = match finished {
            Some(sp) => {
                let t = Instant::now();
                settle(plant, metrics, &sp, run.last_interval_ns, options.settle_s)?;
                run.compute += t.elapsed();
                StopReason::Finished
            }
            None => StopReason::Signal,
        };
        Ok(RunReport {
            stop,
            stats: *plant.stats(),
            published: run.published,
            wall_s: start.elapsed().as_secs_f64(),
            simulated_s: run.first_ns.map_or(0.0, |t| plant.time_ns().saturating_sub(t) as f64 * 1e-9),
            compute_s: run.compute.as_secs_f64(),
        })
    }

    /// The next setpoint waiting in the subscriber queue.
    fn receive(&self) -> Result<Option<Setpoints>, PlantError> {
        let sample = self
            .subscriber
            .receive()
            .map_err(|e| PlantError::Transport(format!("receive on {}: {e:?}", self.setpoints_name)))?;
        Ok(sample.map(|s| *s))
    }

    /// Steps the plant to `sp` and publishes the answer; `false` if `sp` was rejected.
    fn serve(
        &self,
        plant: &mut Plant,
        metrics: Option<&mut Metrics>,
        sp: &Setpoints,
        run: &mut Progress,
    ) -> Result<bool, PlantError> {
        let (prev_ns, was_started) = (plant.time_ns(), plant.started());
        // The actuator commands of this cycle are published before its setpoints.
        if let Some(sub) = &self.actuator {
            while let Some(c) = sub
                .receive()
                .map_err(|e| PlantError::Transport(format!("receive on {}/actuator: {e:?}", self.prefix)))?
            {
                plant.take_actuator_command(&c);
            }
        }
        let t = Instant::now();
        let result = plant.step_setpoint(sp).map(|_| ());
        run.compute += t.elapsed();
        if let Err(e) = result {
            let n = plant.stats().rejected();
            if n <= LOGGED_REJECTIONS {
                let more = if n == LOGGED_REJECTIONS { " (further rejections only counted)" } else { "" };
                warn!("setpoint cycle {} rejected: {e}{more}", sp.cycle);
            }
            return Ok(false);
        }
        if was_started && plant.time_ns() > prev_ns {
            run.last_interval_ns = plant.time_ns() - prev_ns;
        }
        run.first_ns.get_or_insert(plant.time_ns());
        plant.fill_feedback(sp, &mut run.feedback);
        self.publish(&run.feedback)?;
        run.published += 1;
        while plant.pop_measurement(&mut run.measurement) {
            if let Some(p) = &self.measurement {
                let err = |e: &dyn std::fmt::Debug| {
                    PlantError::Transport(format!("publish on {}/measurement: {e:?}", self.prefix))
                };
                let sample = p.loan_uninit().map_err(|e| err(&e))?;
                sample.write_payload(run.measurement).send().map_err(|e| err(&e))?;
            }
        }
        if let Some(m) = metrics {
            m.record_plant(plant);
        }
        Ok(true)
    }

    fn publish(&self, feedback: &Feedback) -> Result<(), PlantError> {
        let err = |e: &dyn std::fmt::Debug| PlantError::Transport(format!("publish on {}: {e:?}", self.feedback_name));
        let sample = self.publisher.loan_uninit().map_err(|e| err(&e))?;
        sample.write_payload(*feedback).send().map_err(|e| err(&e))?;
        Ok(())
    }
}

/// Holds the last setpoint for `settle_s` more, stepping at the last setpoint interval, so the
/// metrics see the residual vibration after the motion end.
fn settle(
    plant: &mut Plant,
    mut metrics: Option<&mut Metrics>,
    last: &Setpoints,
    interval_ns: u64,
    settle_s: f64,
) -> Result<(), PlantError> {
    let n_axes = plant.n_axes();
    let dt_s = if interval_ns > 0 { interval_ns as f64 * 1e-9 } else { 0.004 };
    if !(settle_s.is_finite() && settle_s > 0.0) || dt_s > MAX_GAP_S {
        return Ok(());
    }
    let mut targets = [AxisTarget::default(); MAX_AXES];
    for (i, t) in targets.iter_mut().enumerate().take(n_axes) {
        t.pos = last.pos[i];
    }
    let steps = (settle_s / dt_s).ceil() as u64;
    for _ in 0..steps {
        plant.step(&targets[..n_axes], dt_s)?;
        if let Some(m) = metrics.as_deref_mut() {
            m.record_plant(plant);
        }
    }
    Ok(())
}
