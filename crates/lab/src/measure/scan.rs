//! Looking for instruments again from a running daemon, as `lightbooth
//! instruments --probe` does: the serial ports listed, each asked its
//! harmless identity command in parallel within [`PROBE_DEADLINE`] (never a
//! measuring command or a settings write), on the blocking pool. The port
//! this daemon's instrument is on is not asked. One scan at a time per lab
//! (a scan opens every serial port); another asked meanwhile is refused.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use serde::Serialize;

use crate::error::LabError;
use crate::measure::queue::InstrumentStatus;
use crate::LabHandle;
use lightbooth_instrument::discovery::{self, ProbeResult, ProbeTarget};

/// How long each port's probe may take.
pub const PROBE_DEADLINE: Duration = Duration::from_secs(2);

/// One serial port as a scan found it.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ScannedPort {
    /// `/dev/ttyACM0`.
    pub port: String,
    /// `vendor:product` (hex) when the port is USB.
    pub usb_ids: Option<String>,
    /// Which instruments its USB descriptors suggest, in words.
    pub suggestion: Option<String>,
    /// `identified`, `silent`, `busy`, `unrecognised`, `not-probed`,
    /// `this-daemon` (the port this daemon's instrument is on), …
    pub status: String,
    /// What it answered, or what to do about it.
    pub message: String,
    pub model: Option<String>,
    pub serial: Option<String>,
    /// How long its probe took, ms.
    pub probe_ms: u64,
}

#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct InstrumentScan {
    /// Every serial port of this computer, probed in parallel within `deadline_s`.
    pub ports: Vec<ScannedPort>,
    pub deadline_s: f64,
}

/// Whether a scan is under way (one per lab); cheap to clone.
#[derive(Clone, Default)]
pub struct ScanGate(Arc<AtomicBool>);

impl LabHandle {
    /// Every serial port of this computer and who answers on it (see the
    /// module doc); a conflict while another scan runs.
    pub async fn scan_instruments(&self) -> Result<InstrumentScan, LabError> {
        let gate = self.scan_gate().0.clone();
        if gate.swap(true, Ordering::AcqRel) {
            return Err(LabError::Conflict(
                "a scan is under way: wait for its answer (at most a few seconds)".into(),
            ));
        }
        /// Opens the gate when the scan ends, however it ends.
        struct Done(Arc<AtomicBool>);
        impl Drop for Done {
            fn drop(&mut self) {
                self.0.store(false, Ordering::Release);
            }
        }
        let done = Done(gate);
        let own_port = match &self.instrument().status() {
            InstrumentStatus::Idle { port, .. } => Some(port.clone()),
            _ => None,
        };
        let ports = tokio::task::spawn_blocking(move || {
            let _done = done;
            scan(own_port.as_deref())
        })
        .await
        .map_err(|e| LabError::Internal(format!("the scan stopped: {e}")))?;
        Ok(InstrumentScan {
            ports,
            deadline_s: PROBE_DEADLINE.as_secs_f64(),
        })
    }
}

/// Every serial port, each but `own_port` probed (blocking).
fn scan(own_port: Option<&str>) -> Vec<ScannedPort> {
    let ports = discovery::list_ports(std::path::Path::new("/sys")).unwrap_or_default();
    let targets: Vec<ProbeTarget> = ports
        .iter()
        .filter(|p| Some(p.path.as_str()) != own_port)
        .map(|p| ProbeTarget {
            path: p.path.clone(),
            plan: p.probe_plan(),
        })
        .collect();
    let outcomes = discovery::probe_ports(&targets, PROBE_DEADLINE);
    ports
        .iter()
        .map(|p| {
            let outcome = outcomes.iter().find(|o| o.path == p.path);
            let (status, message, model, serial, ms) = match outcome {
                None => (
                    "this-daemon".to_string(),
                    "this daemon's instrument is on this port".to_string(),
                    None,
                    None,
                    0,
                ),
                Some(o) => {
                    let (model, serial) = match &o.result {
                        ProbeResult::Identified(id) => (Some(id.model.clone()), id.serial.clone()),
                        _ => (None, None),
                    };
                    (
                        o.result.status().to_string(),
                        o.result.to_string(),
                        model,
                        serial,
                        o.elapsed.as_millis() as u64,
                    )
                }
            };
            ScannedPort {
                port: p.path.clone(),
                usb_ids: p.usb.as_ref().map(|u| u.ids()),
                suggestion: p.suggestion.as_ref().map(|s| s.instruments.to_string()),
                status,
                message,
                model,
                serial,
                probe_ms: ms,
            }
        })
        .collect()
}
