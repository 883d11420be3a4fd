//! `machine.home`: the CAN master homes its drives one after the other through CiA 402 homing
//! mode (docs/can.md#homing). Runs in the caller's thread (a control API connection), never
//! in the real-time thread; every SDO transfer goes through the boot thread, which owns the
//! master's SDO channel, and the real-time sink adds controlword bit 4 while asked to. SYNC
//! keeps running throughout.
//!
//! Per drive: 0x607C home offset, 0x6098 method, 0x6099:1/2 speeds, 0x609A acceleration,
//! 0x6060 = 6 (checked in 0x6061); bit 4 until the statusword shows homing attained (bit 12)
//! or a homing error (bit 13), or the timeout; then, standing, the axis's setpoint is moved
//! onto the drive's position (its new reference), and 0x6060 = 8 (checked) returns it to CSP
//! without a jump.

use super::can_state::{BusShared, NodeShared};
use super::drive_command::{DriveCommandError, HomeOutcome, Reposition, SdoOp};
use crate::rt::clock;
use interpd_canopen::Address;
use interpd_protocol::api::HomedAxis;
use interpd_protocol::cia402::{controlword, statusword};
use std::sync::atomic::Ordering;
use std::time::Duration;

const MODES: Address = Address::new(0x6060, 0);
const MODES_DISPLAY: Address = Address::new(0x6061, 0);
const MODE_HOMING: i8 = 6;
const MODE_CSP: i8 = 8;
/// The drive stands when its position actual changed by at most this many increments over
/// this many TPDO1s.
const STAND_INCREMENTS: i32 = 1;
const STAND_TPDOS: u64 = 3;
/// Longest wait for the drive to stand after homing ended or was given up.
const STAND_WAIT: Duration = Duration::from_secs(5);

/// How one drive's homing ended.
enum Outcome {
    Attained,
    Error(u16),
    Timeout(u16),
}

impl BusShared {
    /// Homes every drive of `home_order`; see the module comment.
    pub fn home_command(&self, reposition: Reposition) -> HomeOutcome {
        let mut done = Vec::with_capacity(self.home_order.len());
        // Motion stays refused from the first axis to the last, also between two axes.
        for &i in &self.home_order {
            self.nodes[i].homing.store(true, Ordering::Release);
        }
        let result = self.home_all(reposition, &mut done);
        for &i in &self.home_order {
            self.nodes[i].homing_start.store(false, Ordering::Release);
            self.nodes[i].homing.store(false, Ordering::Release);
        }
        result.map(|()| done)
    }

    fn home_all(&self, reposition: Reposition, done: &mut Vec<HomedAxis>) -> Result<(), DriveCommandError> {
        for &i in &self.home_order {
            let n = &self.nodes[i];
            n.homed.store(false, Ordering::Release);
            let result = self.home_one(n, reposition);
            n.homing_start.store(false, Ordering::Release);
            match result {
                Ok(axis) => {
                    n.homed.store(true, Ordering::Release);
                    tracing::info!(
                        "{}: homed with method {} in {:.3} s, position actual {} ({} units)",
                        n.label(),
                        axis.method,
                        axis.duration_s,
                        axis.position_actual,
                        axis.position_units
                    );
                    done.push(axis);
                }
                Err(e) => {
                    tracing::error!("machine.home: {e}");
                    return Err(e);
                }
            }
        }
        Ok(())
    }

    fn home_one(&self, n: &NodeShared, reposition: Reposition) -> Result<HomedAxis, DriveCommandError> {
        let h = n.homing_params;
        let label = n.label();
        let fail = |what: String| DriveCommandError::Homing(format!("{label}: homing method {}: {what}", h.method));
        if n.power_state() != Some(interpd_protocol::cia402::PowerState::OperationEnabled) {
            return Err(fail(format!(
                "the drive is in state {}, not Operation enabled (see status.drives; drives.reset acknowledges a \
                 fault)",
                n.power_state().map_or("unknown", |s| s.name())
            )));
        }
        let k = n.scale.increments_per_unit().abs();
        let inc = |v: f64| (v * k).round();
        let offset = n.scale.to_increments(h.offset).map_err(|e| fail(format!("home offset: {e}")))?;
        let writes: [(Address, Vec<u8>); 5] = [
            (Address::new(0x607C, 0), offset.to_le_bytes().to_vec()),
            (Address::new(0x6098, 0), h.method.to_le_bytes().to_vec()),
            (Address::new(0x6099, 1), (inc(h.speed_switch) as u32).to_le_bytes().to_vec()),
            (Address::new(0x6099, 2), (inc(h.speed_zero) as u32).to_le_bytes().to_vec()),
            (Address::new(0x609A, 0), (inc(h.acceleration) as u32).to_le_bytes().to_vec()),
        ];
        for (at, data) in writes {
            self.sdo_command(n.node.get(), SdoOp::Write(at, data))?;
        }
        if let Err(e) = self.set_mode(n, MODE_HOMING) {
            // Whatever the drive took, it must follow the setpoint again (it stands at it).
            let back = self.set_mode(n, MODE_CSP).err().map(|b| format!("; back to CSP failed too: {b}"));
            return Err(fail(format!("{e}{}", back.unwrap_or_default())));
        }
        let t0 = clock::now_ns();
        n.homing_start.store(true, Ordering::Release);
        let outcome = self.await_homing(n);
        n.homing_start.store(false, Ordering::Release);
        let duration_s = clock::now_ns().saturating_sub(t0) as f64 * 1e-9;
        // Standing, the setpoint takes over the drive's position before CSP resumes (a homing
        // error or a timeout leaves the drive where it stopped: the same, without a new
        // reference).
        let stood = self.await_standstill(n);
        let actual = n.position_actual();
        let units = n.scale.to_units(actual);
        reposition(n.axis, units).map_err(|e| fail(format!("the axis's setpoint could not take its position: {e}")))?;
        self.set_mode(n, MODE_CSP).map_err(|e| fail(format!("back to cyclic synchronous position: {e}")))?;
        match outcome {
            Outcome::Attained if stood => Ok(HomedAxis {
                axis: n.axis_name.clone(),
                node: n.node.get(),
                method: h.method,
                position_actual: actual,
                position_units: units,
                duration_s,
            }),
            Outcome::Attained => {
                Err(fail(format!("homing attained, but the drive did not stand within {} s", STAND_WAIT.as_secs())))
            }
            Outcome::Error(sw) => Err(fail(format!(
                "the drive reports a homing error (statusword 0x{sw:04X}, bit 13) after {duration_s:.3} s; it stopped \
                 at {units} (position actual {actual}); nothing else moved"
            ))),
            Outcome::Timeout(sw) => Err(fail(format!(
                "not attained within [sinks.can] homing_timeout_ms = {} ms (statusword 0x{sw:04X}); homing was \
                 stopped at {units} (position actual {actual})",
                self.homing_timeout_ns / 1_000_000
            ))),
        }
    }

    /// Writes 0x6060 and reads 0x6061 back.
    fn set_mode(&self, n: &NodeShared, mode: i8) -> Result<(), DriveCommandError> {
        self.sdo_command(n.node.get(), SdoOp::Write(MODES, mode.to_le_bytes().to_vec()))?;
        let shown = self.sdo_command(n.node.get(), SdoOp::Read(MODES_DISPLAY))?;
        match shown.first() {
            Some(&m) if m as i8 == mode => Ok(()),
            other => Err(DriveCommandError::Homing(format!(
                "{}: 0x6060 = {mode} written, but 0x6061 shows {}",
                n.label(),
                other.map_or("nothing".into(), |m| (*m as i8).to_string())
            ))),
        }
    }

    /// Waits for bit 12 or 13 in a statusword that answers a controlword with bit 4 (the
    /// second TPDO1 after that RPDO1 went out, so it cannot be older than the start).
    fn await_homing(&self, n: &NodeShared) -> Outcome {
        let cycle = Duration::from_nanos(self.cycle_ns);
        let until = clock::now_ns() + self.homing_timeout_ns;
        let mut from: Option<u64> = None;
        loop {
            let sw = n.statusword().unwrap_or(0);
            if from.is_none() && n.controlword().is_some_and(|cw| cw & controlword::HOMING_START_BIT != 0) {
                from = Some(n.tpdo_count.load(Ordering::Acquire));
            }
            let answered = from.is_some_and(|c| n.tpdo_count.load(Ordering::Acquire) >= c + 2);
            if answered && sw & statusword::HOMING_ERROR_BIT != 0 {
                return Outcome::Error(sw);
            }
            if answered && sw & statusword::HOMING_ATTAINED_BIT != 0 {
                return Outcome::Attained;
            }
            if clock::now_ns() >= until {
                return Outcome::Timeout(sw);
            }
            std::thread::sleep(cycle);
        }
    }

    /// Waits until the drive's position actual stays put over a few TPDO1s; false if it does
    /// not within [`STAND_WAIT`].
    fn await_standstill(&self, n: &NodeShared) -> bool {
        let cycle = Duration::from_nanos(self.cycle_ns);
        let until = clock::now_ns() + STAND_WAIT.as_nanos() as u64;
        let mut last = (n.tpdo_count.load(Ordering::Acquire), n.position_actual());
        while clock::now_ns() < until {
            std::thread::sleep(cycle);
            let now = (n.tpdo_count.load(Ordering::Acquire), n.position_actual());
            if (now.1 - last.1).abs() > STAND_INCREMENTS {
                last = now;
            } else if now.0 >= last.0 + STAND_TPDOS {
                return true;
            }
        }
        false
    }
}
