//! Finding attached instruments without ever hanging: which serial ports
//! exist, what their USB descriptors suggest is behind them, and (on
//! request) what answers each one's harmless identity command. Pure listing
//! and probing; the command line is `src/cli/instruments.rs`.
//!
//! Three layers, each testable alone:
//!
//! - this file: the listing. Linux names every serial port under
//!   `/sys/class/tty`; a port counts when its `device` link resolves:
//!   `ttyUSB*` (USB-serial adapters), `ttyACM*` (USB CDC-ACM instruments)
//!   and `ttyS*` only when a UART is there: its `type` is not 0
//!   (`PORT_UNKNOWN`), or, on kernels without that file, its driver is not
//!   `serial8250`, whose placeholders exist whether or not a UART does. From the tty's device
//!   directory the listing walks up to the USB device directory (the first
//!   with `idVendor`) and reads `idVendor`, `idProduct`, `serial`,
//!   `manufacturer` and `product`. [`suggest`] turns those into a family.
//! - [`identity`]: each family's identity replies, parsed (pure, no I/O).
//! - [`probe`]: the conversations, one thread per port, each under a hard
//!   deadline measured with `Instant`.
//!
//! Where the USB facts come from (each suggestion names its basis):
//!
//! - FTDI `0403:6001` (FT232R USB-UART, the usual RS-232 adapter): the PR-650
//!   and the LS-100/CS-100A have RS-232 ports only, so a lab reaches them
//!   through such an adapter. Neither has an identity command (the PR-650
//!   answers only within 5 s of power-on; the LS-100 knows only `MDS` and
//!   `MES`, psychopy-minolta 0.0.2 `minolta.py:171-196`), so an adapter is
//!   listed, never probed.
//! - Photo Research PR-655/PR-670: USB CDC-ACM; PsychoPy picks the port by
//!   its descriptor text, so the manufacturer string containing
//!   `Photo Research` is the basis (the product id is not published).
//! - Konica Minolta CS-2000/CS-2000A/CS-3000: vendor `0x132b` is Konica
//!   Minolta's USB vendor id (the SANE `magicolor` backend lists KONICA
//!   MINOLTA devices under `0x132b`); colour-specio 0.4.1 finds the unit by
//!   the descriptor text `CS-2000` (`konica_minolta.py:194`), which is also
//!   a basis here. No public source gives the CS-2000's product id.
//! - Colorimetry Research CR-250/CR-300: USB CDC-ACM; colour-specio finds it
//!   by `ACM` on Linux and `Colorimetry` in the descriptor on Windows
//!   (`colorimetry_research.py:211-217`): the manufacturer string containing
//!   `Colorimetry Research` is the basis.
//! - CRS ColorCAL MkII: vendor `0x0861` (Cambridge Research Systems),
//!   product `0x1001` (Psychtoolbox's `PsychHIDColorCal2` header:
//!   `kColorCal2VendorID 0x0861`, `kColorCal2ProductID 0x1001`). Other
//!   `0x0861` products (`0x1003` is the SpectroCAL MkII behind an FTDI chip)
//!   are named as CRS devices and not probed.
//!
//! Unknown ids are listed without a guess (and probed with every family's
//! identity command, when asked).

pub mod identity;
pub mod probe;

use std::path::{Path, PathBuf};

use serde::Serialize;

pub use identity::{Family, Identity};
pub use probe::{probe_ports, ProbeOutcome, ProbeResult, ProbeTarget};

/// What a USB device says about itself in its descriptors.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct UsbDevice {
    /// `idVendor`, e.g. 0x0403.
    #[serde(serialize_with = "hex4")]
    pub vendor_id: u16,
    /// `idProduct`, e.g. 0x6001.
    #[serde(serialize_with = "hex4")]
    pub product_id: u16,
    pub serial: Option<String>,
    pub manufacturer: Option<String>,
    pub product: Option<String>,
}

fn hex4<S: serde::Serializer>(v: &u16, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&format!("{v:04x}"))
}

impl UsbDevice {
    /// `0403:6001`, as lsusb prints it.
    pub fn ids(&self) -> String {
        format!("{:04x}:{:04x}", self.vendor_id, self.product_id)
    }
}

/// What a port's USB descriptors suggest is behind it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Suggestion {
    /// The instruments, in words: "Photo Research PR-655 or PR-670".
    pub instruments: &'static str,
    /// Which descriptor field said so.
    pub basis: &'static str,
    /// The family whose identity command may be asked; `None` when the
    /// instruments have none (then `not_probed` says why).
    pub family: Option<Family>,
    pub not_probed: Option<&'static str>,
}

/// Why a USB-serial adapter is never probed.
pub const ADAPTER_NOT_PROBED: &str = "the PR-650 and the LS-100/CS-100A have no identity command (the PR-650 \
     answers only within 5 s of power-on, the LS-100 only MDS and MES): name the model with `measure --model`";

/// The family the descriptors suggest, or `None` for ids lightbooth does not know.
pub fn suggest(usb: &UsbDevice) -> Option<Suggestion> {
    let contains = |field: &Option<String>, word: &str| {
        field
            .as_deref()
            .is_some_and(|s| s.to_ascii_lowercase().contains(&word.to_ascii_lowercase()))
    };
    let probe = |instruments, basis, family| Suggestion {
        instruments,
        basis,
        family: Some(family),
        not_probed: None,
    };
    if contains(&usb.manufacturer, "Photo Research") {
        return Some(probe(
            "Photo Research PR-655 or PR-670",
            "manufacturer string",
            Family::Pr655,
        ));
    }
    if contains(&usb.manufacturer, "Colorimetry Research") {
        return Some(probe(
            "Colorimetry Research CR-250 or CR-300",
            "manufacturer string",
            Family::ColorimetryResearch,
        ));
    }
    if contains(&usb.product, "CS-2000") || contains(&usb.product, "CS-3000") {
        return Some(probe(
            "Konica Minolta CS-2000, CS-2000A or CS-3000",
            "product string",
            Family::Cs2000,
        ));
    }
    match (usb.vendor_id, usb.product_id) {
        (0x0861, 0x1001) => Some(probe("CRS ColorCAL MkII", "vendor and product id", Family::ColorCal)),
        (0x0861, _) => Some(Suggestion {
            instruments: "a Cambridge Research Systems device other than the ColorCAL MkII",
            basis: "vendor id",
            family: None,
            not_probed: Some("lightbooth knows no identity command for this CRS product"),
        }),
        (0x132b, _) => Some(probe(
            "Konica Minolta CS-2000, CS-2000A or CS-3000",
            "vendor id (Konica Minolta)",
            Family::Cs2000,
        )),
        (0x0403, 0x6001) => Some(Suggestion {
            instruments: "a USB-serial adapter (PR-650 via RS-232, LS-100/CS-100A)",
            basis: "vendor and product id (FTDI FT232R)",
            family: None,
            not_probed: Some(ADAPTER_NOT_PROBED),
        }),
        _ => None,
    }
}

/// One serial port as listed.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct SerialPortInfo {
    /// The device to open: `/dev/ttyUSB0`, or a path given with `--port`.
    pub path: String,
    /// The kernel's name, `ttyUSB0`.
    pub name: String,
    /// The tty's device driver (`ftdi_sio`, `cdc_acm`), when known.
    pub driver: Option<String>,
    pub usb: Option<UsbDevice>,
    pub suggestion: Option<Suggestion>,
}

impl SerialPortInfo {
    /// A port named on the command line, described from `sysfs` when its
    /// name is there (`/dev/ttyACM0`), else bare (a pseudo-terminal).
    pub fn given(path: &str, sysfs: &Path) -> SerialPortInfo {
        let name = Path::new(path)
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| path.to_string());
        let mut info = describe(sysfs, &name).unwrap_or(SerialPortInfo {
            path: String::new(),
            name,
            driver: None,
            usb: None,
            suggestion: None,
        });
        info.path = path.to_string();
        info
    }

    /// The families to ask, or why none is asked.
    pub fn probe_plan(&self) -> Result<Vec<Family>, &'static str> {
        match &self.suggestion {
            Some(Suggestion {
                family: Some(family), ..
            }) => Ok(vec![*family]),
            Some(Suggestion {
                not_probed: Some(why), ..
            }) => Err(why),
            _ => Ok(Family::UNKNOWN_PORT_ORDER.to_vec()),
        }
    }
}

/// What went wrong reading the sysfs tree.
#[derive(Debug, thiserror::Error)]
pub enum ListingError {
    #[error(
        "cannot read {dir}: {source}. Serial ports are listed from Linux's sysfs; on another system, \
         name the ports with --port"
    )]
    Sysfs {
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Every serial port under `sysfs` (normally `/sys`), sorted by name, with
/// device paths under `/dev`.
pub fn list_ports(sysfs: &Path) -> Result<Vec<SerialPortInfo>, ListingError> {
    let dir = sysfs.join("class/tty");
    let entries = std::fs::read_dir(&dir).map_err(|source| ListingError::Sysfs {
        dir: dir.clone(),
        source,
    })?;
    let mut ports: Vec<SerialPortInfo> = entries
        .filter_map(Result::ok)
        .filter_map(|e| describe(sysfs, &e.file_name().to_string_lossy()))
        .collect();
    ports.sort_by_key(|p| natural_key(&p.name));
    Ok(ports)
}

/// `ttyUSB10` after `ttyUSB9`.
fn natural_key(name: &str) -> (String, u64) {
    let digits = name.len() - name.trim_end_matches(|c: char| c.is_ascii_digit()).len();
    let (stem, number) = name.split_at(name.len() - digits);
    (stem.to_string(), number.parse().unwrap_or(0))
}

/// The port `class/tty/<name>` describes, if it is a serial port with a device.
fn describe(sysfs: &Path, name: &str) -> Option<SerialPortInfo> {
    let kind_ok = ["ttyUSB", "ttyACM", "ttyS"]
        .iter()
        .any(|p| name.strip_prefix(p).is_some_and(|n| !n.is_empty()));
    if !kind_ok {
        return None;
    }
    let device = std::fs::canonicalize(sysfs.join("class/tty").join(name).join("device")).ok()?;
    let driver = std::fs::canonicalize(device.join("driver"))
        .ok()
        .and_then(|d| d.file_name().map(|n| n.to_string_lossy().into_owned()));
    if name.starts_with("ttyS") && is_placeholder_uart(&sysfs.join("class/tty").join(name), driver.as_deref()) {
        return None;
    }
    let root = std::fs::canonicalize(sysfs).unwrap_or_else(|_| sysfs.to_path_buf());
    let usb = usb_device_above(&device, &root);
    let suggestion = usb.as_ref().and_then(suggest);
    Some(SerialPortInfo {
        path: format!("/dev/{name}"),
        name: name.to_string(),
        driver,
        usb,
        suggestion,
    })
}

/// Whether a `ttyS*` is one of the kernel's placeholders without a UART:
/// its `type` is 0 (`PORT_UNKNOWN`; since Linux 6.5 every 8250 port's
/// driver is `port`, placeholders included), or, without a `type` file,
/// its driver is `serial8250` (older kernels) or none.
fn is_placeholder_uart(class_dir: &Path, driver: Option<&str>) -> bool {
    match std::fs::read_to_string(class_dir.join("type")) {
        Ok(kind) => kind.trim() == "0",
        Err(_) => matches!(driver, None | Some("serial8250")),
    }
}

/// The first directory at or above `device` (inside `root`) with an
/// `idVendor`: the USB device the tty's interface belongs to.
fn usb_device_above(device: &Path, root: &Path) -> Option<UsbDevice> {
    let mut dir = Some(device);
    while let Some(d) = dir {
        if !d.starts_with(root) || d == root {
            return None;
        }
        if let Some(vendor_id) = read_hex(&d.join("idVendor")) {
            let text = |file: &str| {
                std::fs::read_to_string(d.join(file))
                    .ok()
                    .map(|s| s.trim().to_string())
                    .filter(|s| !s.is_empty())
            };
            return Some(UsbDevice {
                vendor_id,
                product_id: read_hex(&d.join("idProduct")).unwrap_or(0),
                serial: text("serial"),
                manufacturer: text("manufacturer"),
                product: text("product"),
            });
        }
        dir = d.parent();
    }
    None
}

/// A sysfs id file: four hex digits and a newline.
fn read_hex(path: &Path) -> Option<u16> {
    let text = std::fs::read_to_string(path).ok()?;
    u16::from_str_radix(text.trim().trim_start_matches("0x"), 16).ok()
}

impl Identity {
    /// The `--model` flag of the model this identity names (`pr670`,
    /// `cs2000a`, `cr250`, `colorcal`), when lightbooth drives it.
    pub fn model_flag(&self) -> Option<&'static str> {
        let flag = self
            .model
            .to_ascii_lowercase()
            .replace(['-', ' '], "")
            .replace("mkii", "");
        super::MODEL_FLAGS.iter().copied().find(|f| *f == flag)
    }
}

/// The one instrument attached, for `serve --instrument auto`: lists the
/// ports (under `sysfs`, plus `extra` ports), probes them in parallel within
/// `deadline`, and returns the port and model flag of the single instrument
/// that identified itself. None, or several, is an error that lists what
/// each port answered and says what to do.
pub fn find_one_instrument(
    sysfs: &Path,
    extra: &[String],
    deadline: std::time::Duration,
) -> Result<(String, &'static str), String> {
    let mut ports = list_ports(sysfs).or_else(|e| {
        if extra.is_empty() {
            Err(e.to_string())
        } else {
            Ok(Vec::new())
        }
    })?;
    for path in extra {
        if !ports.iter().any(|p| &p.path == path) {
            ports.push(SerialPortInfo::given(path, sysfs));
        }
    }
    let targets: Vec<ProbeTarget> = ports
        .iter()
        .map(|p| ProbeTarget {
            path: p.path.clone(),
            plan: p.probe_plan(),
        })
        .collect();
    let outcomes = probe_ports(&targets, deadline);
    let found: Vec<(String, &'static str)> = outcomes
        .iter()
        .filter_map(|o| match &o.result {
            ProbeResult::Identified(id) => id.model_flag().map(|flag| (o.path.clone(), flag)),
            _ => None,
        })
        .collect();
    let report = || {
        outcomes
            .iter()
            .map(|o| format!("{}: {}", o.path, o.result))
            .collect::<Vec<_>>()
            .join("; ")
    };
    match found.as_slice() {
        [one] => Ok(one.clone()),
        [] if outcomes.is_empty() => Err(
            "no serial ports found: connect the instrument (and switch it on), or name \
                                          its settings file with --instrument FILE"
                .into(),
        ),
        [] => Err(format!(
            "no instrument identified itself ({}). A PR-650 or an LS-100/CS-100A cannot be found this way (they have \
             no identity command): name its settings file with --instrument FILE",
            report()
        )),
        several => Err(format!(
            "{} instruments answered ({}): name the one to use with --instrument FILE",
            several.len(),
            report()
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn usb(vendor_id: u16, product_id: u16, manufacturer: Option<&str>, product: Option<&str>) -> UsbDevice {
        UsbDevice {
            vendor_id,
            product_id,
            serial: None,
            manufacturer: manufacturer.map(str::to_string),
            product: product.map(str::to_string),
        }
    }

    #[test]
    fn each_known_id_suggests_its_family_and_unknown_ids_nothing() {
        let family = |u: &UsbDevice| suggest(u).and_then(|s| s.family);
        assert_eq!(family(&usb(0x0861, 0x1001, None, None)), Some(Family::ColorCal));
        assert_eq!(family(&usb(0x132b, 0x0001, None, None)), Some(Family::Cs2000));
        assert_eq!(
            family(&usb(0x1234, 0x5678, None, Some("CS-2000"))),
            Some(Family::Cs2000)
        );
        assert_eq!(
            family(&usb(0x1234, 0x5678, Some("PHOTO RESEARCH, Inc."), None)),
            Some(Family::Pr655)
        );
        assert_eq!(
            family(&usb(0x1234, 0x5678, Some("Colorimetry Research, Inc."), None)),
            Some(Family::ColorimetryResearch)
        );
        let adapter = suggest(&usb(0x0403, 0x6001, Some("FTDI"), Some("FT232R USB UART"))).unwrap();
        assert_eq!(adapter.family, None);
        assert!(adapter.not_probed.unwrap().contains("no identity command"));
        assert!(adapter.instruments.contains("PR-650"));
        assert_eq!(suggest(&usb(0x1d6b, 0x0002, Some("Linux"), None)), None);
        assert_eq!(suggest(&usb(0x0403, 0x6015, None, None)), None);
    }

    #[test]
    fn ports_sort_by_number_not_by_text() {
        let mut names = ["ttyUSB10", "ttyACM0", "ttyUSB9", "ttyUSB1"];
        names.sort_by_key(|n| natural_key(n));
        assert_eq!(names, ["ttyACM0", "ttyUSB1", "ttyUSB9", "ttyUSB10"]);
    }
}
