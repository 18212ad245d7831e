//! `lightbooth instruments`: the serial ports, what their USB descriptors
//! suggest is attached, and with `--probe` what answers each one's
//! harmless identity command, every port in parallel under a hard
//! deadline. A table, or `--json`. The listing and probing are
//! [`lightbooth::instrument::discovery`]; this is only arguments and output.

use std::path::PathBuf;
use std::time::Duration;

use clap::Args;
use serde_json::{json, Value};

use lightbooth::instrument::discovery::{self, ProbeOutcome, ProbeResult, ProbeTarget, SerialPortInfo};

#[derive(Args, Debug)]
pub struct InstrumentsArgs {
    /// One JSON array: per port `port`, `name`, `driver`, `usb`, `suggestion`, `probe`, `probe_ms`.
    #[arg(long)]
    json: bool,
    /// Ask each port who it is with each plausible family's identity command (never a
    /// measurement, never a settings write), all ports in parallel.
    #[arg(long)]
    probe: bool,
    /// A port to consider besides those listed (repeatable): a device sysfs does not list,
    /// or the pseudo-terminal a `mock-…` command prints.
    #[arg(long = "port", value_name = "PATH")]
    ports: Vec<String>,
    /// Longest a port's probe may take, seconds (0.2–10); the command returns within about
    /// this (plus half a second), however many ports there are.
    #[arg(long, default_value_t = 2.0, value_parser = deadline)]
    deadline: f64,
    /// The sysfs tree to list ports from (a test's fake tree).
    #[arg(long, value_name = "DIR", default_value = "/sys")]
    sysfs: PathBuf,
}

/// A deadline in seconds, 0.2–10.
fn deadline(s: &str) -> Result<f64, String> {
    super::finite_in(s, 0.2, 10.0, "seconds")
}

pub fn run(args: InstrumentsArgs) -> anyhow::Result<()> {
    let mut ports = match discovery::list_ports(&args.sysfs) {
        Ok(ports) => ports,
        Err(e) if !args.ports.is_empty() => {
            eprintln!("warning: {e}");
            Vec::new()
        }
        Err(e) => return Err(e.into()),
    };
    for path in &args.ports {
        if !ports.iter().any(|p| &p.path == path) {
            ports.push(SerialPortInfo::given(path, &args.sysfs));
        }
    }
    let outcomes: Option<Vec<ProbeOutcome>> = args.probe.then(|| {
        let targets: Vec<ProbeTarget> = ports
            .iter()
            .map(|p| ProbeTarget {
                path: p.path.clone(),
                plan: p.probe_plan(),
            })
            .collect();
        discovery::probe_ports(&targets, Duration::from_secs_f64(args.deadline))
    });
    if args.json {
        let rows: Vec<Value> = ports
            .iter()
            .enumerate()
            .map(|(i, p)| port_json(p, outcomes.as_ref().map(|o| &o[i])))
            .collect();
        println!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        print!("{}", table(&ports, outcomes.as_deref()));
    }
    Ok(())
}

fn port_json(port: &SerialPortInfo, outcome: Option<&ProbeOutcome>) -> Value {
    let probe = outcome.map(|o| {
        let identity = match &o.result {
            ProbeResult::Identified(id) => Some(id),
            _ => None,
        };
        json!({
            "status": o.result.status(),
            "family": identity.map(|id| id.family),
            "model": identity.map(|id| id.model.clone()),
            "serial": identity.and_then(|id| id.serial.clone()),
            "firmware": identity.and_then(|id| id.firmware.clone()),
            "message": o.result.to_string(),
        })
    });
    json!({
        "port": port.path,
        "name": port.name,
        "driver": port.driver,
        "usb": port.usb,
        "suggestion": port.suggestion,
        "probe": probe,
        "probe_ms": outcome.map(|o| o.elapsed.as_millis() as u64),
    })
}

fn table(ports: &[SerialPortInfo], outcomes: Option<&[ProbeOutcome]>) -> String {
    if ports.is_empty() {
        return "no serial ports found: plug the instrument in (ls /dev/ttyUSB* /dev/ttyACM*), or name a port with \
                --port\n"
            .into();
    }
    let mut rows = vec![vec!["PORT".to_string(), "USB".to_string(), "SUGGESTS".to_string()]];
    if outcomes.is_some() {
        rows[0].push("PROBE".into());
    }
    for (i, p) in ports.iter().enumerate() {
        let usb = match &p.usb {
            Some(u) => {
                let mut text = u.ids();
                let words: Vec<&str> = [&u.manufacturer, &u.product]
                    .into_iter()
                    .filter_map(|s| s.as_deref())
                    .collect();
                if !words.is_empty() {
                    text.push_str(&format!(" {}", words.join(" ")));
                }
                if let Some(serial) = &u.serial {
                    text.push_str(&format!(" (serial {serial})"));
                }
                text
            }
            None => "-".into(),
        };
        let suggestion = p
            .suggestion
            .as_ref()
            .map(|s| s.instruments.to_string())
            .unwrap_or_else(|| "-".into());
        let mut row = vec![p.path.clone(), usb, suggestion];
        if let Some(outcomes) = outcomes {
            let o = &outcomes[i];
            let took = match o.result {
                ProbeResult::NotProbed { .. } => String::new(),
                _ => format!(" [{} ms]", o.elapsed.as_millis()),
            };
            row.push(format!("{}{took}", o.result));
        }
        rows.push(row);
    }
    let columns = rows[0].len();
    let widths: Vec<usize> = (0..columns)
        .map(|c| rows.iter().map(|r| r[c].chars().count()).max().unwrap_or(0))
        .collect();
    let mut out = String::new();
    for row in rows {
        let cells: Vec<String> = row
            .iter()
            .enumerate()
            .map(|(c, cell)| {
                if c + 1 == columns {
                    cell.clone()
                } else {
                    format!("{cell:<width$}", width = widths[c])
                }
            })
            .collect();
        out.push_str(cells.join("  ").trim_end());
        out.push('\n');
    }
    out
}
