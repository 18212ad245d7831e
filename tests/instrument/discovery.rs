//! `lightbooth instruments`: the listing from a fake sysfs tree (ids,
//! descriptor strings, suggestions), and probes on real pseudo-terminals
//! that misbehave (silent, garbage, echo, held by another program), each
//! reported as such within its deadline; the simulated PR-655 and PR-670
//! found by their identity through the command line; five ports probed in
//! about one deadline, not five.
//!
//! Every probe's measured time is printed (`--nocapture` shows them).

use std::io::{BufRead, BufReader, Read, Write};
use std::os::unix::fs::symlink;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use serde_json::Value;
use serialport::{SerialPort, TTYPort};

use lightbooth::instrument::discovery::{self, Family, ProbeResult, ProbeTarget};

/// The upper bound every probe must meet: its deadline and this margin.
const MARGIN: Duration = Duration::from_millis(1500);

// ---- a fake sysfs tree --------------------------------------------------------

/// A USB device directory with its descriptor files, and its tty under `interface`.
struct FakeUsb<'a> {
    tty: &'a str,
    /// Path under `devices/` of the USB device.
    device: &'a str,
    ids: (&'a str, &'a str),
    serial: Option<&'a str>,
    manufacturer: Option<&'a str>,
    product: Option<&'a str>,
    driver: &'a str,
    /// Whether `device` points at the interface (CDC-ACM) or a child named after the tty (usb-serial).
    acm: bool,
}

fn write(path: &Path, text: &str) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, text).unwrap();
}

fn add_usb(sysfs: &Path, usb: &FakeUsb) {
    let device = sysfs.join("devices").join(usb.device);
    write(&device.join("idVendor"), &format!("{}\n", usb.ids.0));
    write(&device.join("idProduct"), &format!("{}\n", usb.ids.1));
    for (file, value) in [
        ("serial", usb.serial),
        ("manufacturer", usb.manufacturer),
        ("product", usb.product),
    ] {
        if let Some(value) = value {
            write(&device.join(file), &format!("{value}\n"));
        }
    }
    let interface = device.join(format!("{}:1.0", device.file_name().unwrap().to_string_lossy()));
    let tty_device = if usb.acm {
        interface.clone()
    } else {
        interface.join(usb.tty)
    };
    std::fs::create_dir_all(&tty_device).unwrap();
    let driver = sysfs.join("bus/usb/drivers").join(usb.driver);
    std::fs::create_dir_all(&driver).unwrap();
    symlink(&driver, tty_device.join("driver")).unwrap();
    add_tty(sysfs, usb.tty, Some(&tty_device));
}

fn add_tty(sysfs: &Path, name: &str, device: Option<&Path>) {
    let class = sysfs.join("class/tty").join(name);
    std::fs::create_dir_all(&class).unwrap();
    if let Some(device) = device {
        symlink(device, class.join("device")).unwrap();
    }
}

/// A tree with one port of every kind the listing must tell apart.
fn fake_sysfs(root: &Path) {
    let hub = "pci0000:00/0000:00:14.0/usb1";
    let usb = |tty, port, ids, manufacturer, product, serial, driver, acm| FakeUsb {
        tty,
        device: Box::leak(format!("{hub}/{port}").into_boxed_str()),
        ids,
        serial,
        manufacturer,
        product,
        driver,
        acm,
    };
    for fake in [
        usb(
            "ttyUSB0",
            "1-1",
            ("0403", "6001"),
            Some("FTDI"),
            Some("FT232R USB UART"),
            Some("A6008isP"),
            "ftdi_sio",
            false,
        ),
        usb(
            "ttyUSB1",
            "1-6",
            ("10c4", "ea60"),
            Some("Silicon Labs"),
            Some("CP2102 USB to UART"),
            None,
            "cp210x",
            false,
        ),
        usb(
            "ttyACM0",
            "1-2",
            ("0861", "1001"),
            Some("Cambridge Research Systems"),
            Some("ColorCAL MKII"),
            Some("00041234"),
            "cdc_acm",
            true,
        ),
        usb(
            "ttyACM1",
            "1-3",
            ("1234", "0655"),
            Some("Photo Research, Inc."),
            Some("PR-670"),
            Some("67065106"),
            "cdc_acm",
            true,
        ),
        usb(
            "ttyACM2",
            "1-4",
            ("132b", "1000"),
            Some("KONICA MINOLTA"),
            Some("CS-2000"),
            Some("10012345"),
            "cdc_acm",
            true,
        ),
        usb(
            "ttyACM3",
            "1-5.2",
            ("04d8", "000a"),
            Some("Colorimetry Research"),
            Some("CR-250"),
            None,
            "cdc_acm",
            true,
        ),
    ] {
        add_usb(root, &fake);
    }
    // Placeholder UARTs (serial8250, or type 0) are not ports; a UART is.
    let platform = root.join("devices/platform/serial8250/tty/ttyS0");
    std::fs::create_dir_all(&platform).unwrap();
    std::fs::create_dir_all(root.join("bus/platform/drivers/serial8250")).unwrap();
    symlink(root.join("bus/platform/drivers/serial8250"), platform.join("driver")).unwrap();
    add_tty(root, "ttyS0", Some(&platform));
    let pci_uart = root.join("devices/pci0000:00/0000:00:16.3/tty/ttyS4");
    std::fs::create_dir_all(&pci_uart).unwrap();
    std::fs::create_dir_all(root.join("bus/pci/drivers/exar_serial")).unwrap();
    symlink(root.join("bus/pci/drivers/exar_serial"), pci_uart.join("driver")).unwrap();
    add_tty(root, "ttyS4", Some(&pci_uart));
    write(&root.join("class/tty/ttyS4/type"), "4\n");
    // Since Linux 6.5 every 8250 port's driver is `port`; a placeholder's type is 0.
    let modern = root.join("devices/platform/serial8250/serial8250:0/serial8250:0.1");
    std::fs::create_dir_all(&modern).unwrap();
    std::fs::create_dir_all(root.join("bus/serial-base/drivers/port")).unwrap();
    symlink(root.join("bus/serial-base/drivers/port"), modern.join("driver")).unwrap();
    add_tty(root, "ttyS1", Some(&modern));
    write(&root.join("class/tty/ttyS1/type"), "0\n");
    // Virtual consoles have no device; a vanished adapter's link dangles.
    add_tty(root, "tty0", None);
    add_tty(root, "ttyUSB9", Some(&root.join("devices/gone/ttyUSB9")));
}

#[test]
fn a_fake_sysfs_lists_every_serial_port_with_its_ids_strings_and_suggestion() {
    let dir = tempfile::tempdir().unwrap();
    fake_sysfs(dir.path());
    let ports = discovery::list_ports(dir.path()).unwrap();
    let names: Vec<&str> = ports.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(
        names,
        ["ttyACM0", "ttyACM1", "ttyACM2", "ttyACM3", "ttyS4", "ttyUSB0", "ttyUSB1"]
    );

    // The command line says the same, as JSON with stable keys.
    let out = lightbooth(&["instruments", "--json", "--sysfs", dir.path().to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let rows: Vec<Value> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(rows.len(), 7);
    let row = |name: &str| rows.iter().find(|r| r["name"] == name).unwrap().clone();
    for r in &rows {
        let mut keys: Vec<&str> = r.as_object().unwrap().keys().map(String::as_str).collect();
        keys.sort();
        assert_eq!(
            keys,
            ["driver", "name", "port", "probe", "probe_ms", "suggestion", "usb"]
        );
        assert!(
            r["probe"].is_null() && r["probe_ms"].is_null(),
            "nothing is probed without --probe"
        );
    }

    let ftdi = row("ttyUSB0");
    assert_eq!(ftdi["port"], "/dev/ttyUSB0");
    assert_eq!(ftdi["driver"], "ftdi_sio");
    assert_eq!(ftdi["usb"]["vendor_id"], "0403");
    assert_eq!(ftdi["usb"]["product_id"], "6001");
    assert_eq!(ftdi["usb"]["serial"], "A6008isP");
    assert_eq!(ftdi["usb"]["manufacturer"], "FTDI");
    assert_eq!(ftdi["usb"]["product"], "FT232R USB UART");
    assert_eq!(
        ftdi["suggestion"]["instruments"],
        "a USB-serial adapter (PR-650 via RS-232, LS-100/CS-100A)"
    );
    assert!(ftdi["suggestion"]["family"].is_null());
    assert!(ftdi["suggestion"]["not_probed"]
        .as_str()
        .unwrap()
        .contains("no identity command"));

    let family = |name: &str| row(name)["suggestion"]["family"].clone();
    assert_eq!(family("ttyACM0"), "color-cal");
    assert_eq!(row("ttyACM0")["usb"]["serial"], "00041234");
    assert_eq!(row("ttyACM0")["driver"], "cdc_acm");
    assert_eq!(family("ttyACM1"), "pr655");
    assert_eq!(
        row("ttyACM1")["suggestion"]["instruments"],
        "Photo Research PR-655 or PR-670"
    );
    assert_eq!(family("ttyACM2"), "cs2000");
    assert_eq!(family("ttyACM3"), "colorimetry-research");
    assert_eq!(row("ttyACM3")["usb"]["vendor_id"], "04d8");
    // Unknown ids are listed without a guess; a UART without USB has no ids.
    assert!(row("ttyUSB1")["suggestion"].is_null());
    assert_eq!(row("ttyUSB1")["usb"]["manufacturer"], "Silicon Labs");
    assert!(row("ttyS4")["usb"].is_null());
    assert_eq!(row("ttyS4")["driver"], "exar_serial");

    // The table names the same things.
    let out = lightbooth(&["instruments", "--sysfs", dir.path().to_str().unwrap()]);
    let table = String::from_utf8_lossy(&out.stdout);
    println!("{table}");
    assert!(table.starts_with("PORT"), "{table}");
    assert!(
        table.contains("/dev/ttyUSB0  0403:6001 FTDI FT232R USB UART (serial A6008isP)"),
        "{table}"
    );
    assert!(table.contains("CRS ColorCAL MkII"), "{table}");
    assert!(!table.contains("PROBE"), "{table}");

    // A tree without class/tty is an error that says what to do.
    let empty = tempfile::tempdir().unwrap();
    let out = lightbooth(&["instruments", "--sysfs", empty.path().to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--port"));
}

#[test]
fn a_suggested_family_is_the_only_one_asked_and_an_adapter_is_never_probed() {
    let dir = tempfile::tempdir().unwrap();
    fake_sysfs(dir.path());
    let ports = discovery::list_ports(dir.path()).unwrap();
    let plan = |name: &str| ports.iter().find(|p| p.name == name).unwrap().probe_plan();
    assert_eq!(plan("ttyACM0"), Ok(vec![Family::ColorCal]));
    assert_eq!(plan("ttyACM2"), Ok(vec![Family::Cs2000]));
    assert!(plan("ttyUSB0").unwrap_err().contains("PR-650"));
    assert_eq!(plan("ttyUSB1"), Ok(Family::UNKNOWN_PORT_ORDER.to_vec()));
    // A not-probed port takes no time and no thread.
    let outcomes = discovery::probe_ports(
        &[ProbeTarget {
            path: "/dev/ttyUSB0".into(),
            plan: plan("ttyUSB0"),
        }],
        Duration::from_secs(2),
    );
    assert!(matches!(outcomes[0].result, ProbeResult::NotProbed { .. }));
    assert_eq!(outcomes[0].elapsed, Duration::ZERO);
}

// ---- misbehaving ports on real ptys --------------------------------------------

#[derive(Clone, Copy, Debug)]
enum Behaviour {
    /// Reads everything, answers nothing.
    Silent,
    /// Answers anything with bytes no instrument sends.
    Garbage,
    /// Sends back what it gets.
    Echo,
}

/// A pty whose far end behaves so; stopped and joined on drop.
struct FakePort {
    path: String,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    _slave: TTYPort,
}

impl Drop for FakePort {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn fake_port(behaviour: Behaviour) -> FakePort {
    let (mut master, slave) = TTYPort::pair().unwrap();
    let path = slave.name().unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let thread = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            master.set_timeout(Duration::from_millis(20)).unwrap();
            let mut buf = [0u8; 256];
            while !stop.load(Ordering::Relaxed) {
                let Ok(n) = master.read(&mut buf) else { continue };
                match behaviour {
                    Behaviour::Silent => {}
                    Behaviour::Garbage => {
                        let _ = master.write_all(b"\x00\xff#?garbage\x1b[0m\r\n");
                    }
                    Behaviour::Echo => {
                        let _ = master.write_all(&buf[..n]);
                    }
                }
            }
        })
    };
    FakePort {
        path,
        stop,
        thread: Some(thread),
        _slave: slave,
    }
}

/// A pty another program holds as serialport and pyserial's `exclusive` do
/// (`TIOCEXCL` and an exclusive `flock`).
struct HeldPort {
    path: String,
    holder: TTYPort,
    _fake: FakePort,
}

fn held_port() -> HeldPort {
    let fake = fake_port(Behaviour::Echo);
    let holder = serialport::new(&fake.path, 9600).open_native().unwrap();
    assert!(holder.exclusive());
    HeldPort {
        path: fake.path.clone(),
        holder,
        _fake: fake,
    }
}

/// Whether the tty behind `port` is still in exclusive mode (`TIOCGEXCL`).
fn still_exclusive(port: &TTYPort) -> bool {
    use std::os::fd::AsRawFd;
    let mut exclusive: libc::c_int = 0;
    // SAFETY: TIOCGEXCL writes one int through the pointer; the fd is open.
    let rc = unsafe { libc::ioctl(port.as_raw_fd(), libc::TIOCGEXCL, &mut exclusive as *mut libc::c_int) };
    rc == 0 && exclusive != 0
}

fn probe_one(path: &str, deadline: Duration) -> (ProbeResult, Duration) {
    probe_with(path, Family::UNKNOWN_PORT_ORDER.to_vec(), deadline)
}

/// One port asked `plan`, within `deadline` and the margin.
fn probe_with(path: &str, plan: Vec<Family>, deadline: Duration) -> (ProbeResult, Duration) {
    let started = Instant::now();
    let outcome = discovery::probe_ports(
        &[ProbeTarget {
            path: path.to_string(),
            plan: Ok(plan),
        }],
        deadline,
    )
    .remove(0);
    let wall = started.elapsed();
    assert!(
        wall <= deadline + MARGIN,
        "{path}: the probe took {wall:?}, beyond its deadline {deadline:?} + {MARGIN:?}"
    );
    (outcome.result, outcome.elapsed)
}

#[test]
fn a_silent_a_garbage_an_echoing_and_a_busy_port_are_each_reported_as_such_within_the_deadline() {
    let deadline = Duration::from_secs(2);

    let silent = fake_port(Behaviour::Silent);
    let (result, took) = probe_one(&silent.path, deadline);
    println!("silent pty: {took:?}: {result}");
    assert!(matches!(result, ProbeResult::Silent { .. }), "{result:?}");
    assert!(
        result
            .to_string()
            .contains("no answer within 2.0 s: check power, cable"),
        "{result}"
    );
    // It waited for the instruments (most of its deadline), not a moment.
    assert!(took >= deadline - Duration::from_millis(300), "{took:?}");

    let garbage = fake_port(Behaviour::Garbage);
    let (result, took) = probe_one(&garbage.path, deadline);
    println!("garbage pty: {took:?}: {result}");
    match &result {
        ProbeResult::Unrecognised {
            first_bytes,
            asked,
            pr650_reply,
        } => {
            assert!(!pr650_reply, "garbage is no PR-650 report");
            assert!(
                first_bytes.starts_with("\\0\u{fffd}#?garbage\\u{1b}[0m\\r\\n"),
                "{first_bytes}"
            );
            assert_eq!(asked.len(), 4, "every family heard garbage: {asked:?}");
        }
        other => panic!("{other:?}"),
    }
    assert!(result.to_string().starts_with("answered `"), "{result}");
    assert!(
        result
            .to_string()
            .contains("but no instrument that identifies itself: a PR-650 or an LS-100"),
        "{result}"
    );

    let echo = fake_port(Behaviour::Echo);
    let (result, took) = probe_one(&echo.path, deadline);
    println!("echoing pty: {took:?}: {result}");
    match &result {
        // Its own commands, echoed, are nobody's identity.
        ProbeResult::Unrecognised { first_bytes, .. } => {
            assert!(first_bytes.starts_with("RC Model\\n"), "{first_bytes}")
        }
        other => panic!("{other:?}"),
    }

    let held = held_port();
    let (result, took) = probe_one(&held.path, deadline);
    println!("busy pty: {took:?}: {result}");
    assert_eq!(result, ProbeResult::Busy);
    assert!(result.to_string().starts_with("busy: held by another program"));
    assert!(
        took < Duration::from_millis(200),
        "a busy port is known at once: {took:?}"
    );
    // The holder keeps its exclusive hold: the probe did not clear it.
    assert!(still_exclusive(&held.holder));

    // Permission denied and a vanished port say what to do.
    let (result, _) = probe_one("/dev/lightbooth-no-such-port", deadline);
    assert_eq!(result, ProbeResult::Missing);
    let (result, _) = probe_one("/dev/null", deadline);
    assert_eq!(result, ProbeResult::NotSerial);
    assert!(ProbeResult::PermissionDenied
        .to_string()
        .contains("sudo usermod -aG dialout $USER"));
}

#[test]
fn a_short_deadline_is_kept_too() {
    let silent = fake_port(Behaviour::Silent);
    let deadline = Duration::from_millis(300);
    let (result, took) = probe_one(&silent.path, deadline);
    println!("silent pty, 0.3 s deadline: {took:?}: {result}");
    assert!(matches!(result, ProbeResult::Silent { .. }));
    assert!(took <= deadline + Duration::from_millis(150), "{took:?}");
}

// ---- the simulated PR-655 and PR-670, through the command line ---------------

fn lightbooth(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .args(args)
        .output()
        .expect("run lightbooth")
}

/// A `lightbooth mock-…` process; killed (by its own handle) when dropped.
struct Mock {
    child: Child,
    path: String,
}

impl Drop for Mock {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn spawn_mock(command: &str, args: &[&str]) -> Mock {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .arg(command)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let path = line.trim().to_string();
    assert!(path.starts_with("/dev/"), "{command}: `{path}`");
    Mock { child, path }
}

/// A sysfs tree with no ports, so only the `--port`s are probed.
fn no_ports() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("class/tty")).unwrap();
    dir
}

fn probe_json(sysfs: &Path, ports: &[&str], deadline: &str) -> (Vec<Value>, Duration) {
    let mut args = vec!["instruments", "--probe", "--json", "--deadline", deadline, "--sysfs"];
    args.push(sysfs.to_str().unwrap());
    for p in ports {
        args.extend(["--port", p]);
    }
    let started = Instant::now();
    let out = lightbooth(&args);
    let wall = started.elapsed();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    (serde_json::from_slice(&out.stdout).unwrap(), wall)
}

#[test]
fn a_simulated_pr655_and_pr670_are_found_by_model_and_serial() {
    let pr655 = spawn_mock("mock-pr655", &["--speed", "0", "--serial", "65512345"]);
    let pr670 = spawn_mock("mock-pr670", &["--speed", "0", "--serial", "67054321"]);
    let sysfs = no_ports();
    let (rows, wall) = probe_json(sysfs.path(), &[&pr655.path, &pr670.path], "2");
    println!("two simulators probed in {wall:?}: {rows:#?}");
    assert!(wall <= Duration::from_secs(2) + MARGIN, "{wall:?}");
    for (row, path, model, serial) in [
        (&rows[0], &pr655.path, "PR-655", "65512345"),
        (&rows[1], &pr670.path, "PR-670", "67054321"),
    ] {
        assert_eq!(row["port"], path.as_str());
        assert_eq!(row["probe"]["status"], "identified", "{row:#}");
        assert_eq!(row["probe"]["family"], "pr655");
        assert_eq!(row["probe"]["model"], model);
        assert_eq!(row["probe"]["serial"], serial);
        assert!(row["probe_ms"].as_u64().unwrap() <= 2000 + MARGIN.as_millis() as u64);
        assert!(row["usb"].is_null() && row["suggestion"].is_null());
    }
    // The probe left the unit as it found it (`Q`: local mode), so a measurement works.
    let out = lightbooth(&[
        "measure",
        "--model",
        "pr655",
        "--port",
        &pr655.path,
        "--samples",
        "1",
        "--json",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let m: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(m["instrument"]["serial"], "65512345");
    // And the table shows model and serial.
    let out = lightbooth(&[
        "instruments",
        "--probe",
        "--sysfs",
        sysfs.path().to_str().unwrap(),
        "--port",
        &pr670.path,
    ]);
    let table = String::from_utf8_lossy(&out.stdout);
    println!("{table}");
    assert!(table.contains("PR-670 serial 67054321"), "{table}");
}

#[test]
fn four_bad_ports_and_a_good_one_are_probed_in_about_one_deadline() {
    let pr670 = spawn_mock("mock-pr670", &["--speed", "0"]);
    let silent = fake_port(Behaviour::Silent);
    let garbage = fake_port(Behaviour::Garbage);
    let echo = fake_port(Behaviour::Echo);
    let held = held_port();
    let sysfs = no_ports();
    let ports = [&silent.path, &garbage.path, &echo.path, &held.path, &pr670.path];
    let ports: Vec<&str> = ports.iter().map(|p| p.as_str()).collect();
    let (rows, wall) = probe_json(sysfs.path(), &ports, "2");
    for row in &rows {
        println!("{} [{} ms]: {}", row["port"], row["probe_ms"], row["probe"]["message"]);
    }
    println!("five ports in {wall:?}");
    // In parallel: one deadline (2 s) and the margin, not five deadlines.
    assert!(wall <= Duration::from_secs(2) + MARGIN, "{wall:?}");
    let status: Vec<&str> = rows.iter().map(|r| r["probe"]["status"].as_str().unwrap()).collect();
    assert_eq!(status, ["silent", "unrecognised", "unrecognised", "busy", "identified"]);
    assert_eq!(rows[4]["probe"]["model"], "PR-670");
    assert_eq!(rows[4]["probe"]["serial"], "67065106");
}

// ---- the simulated CS-2000 (the library's simulator, on a real pty) --------

/// The CS-2000A is found by `IDDR` among every family's questions, and the
/// probe never writes its flash (the simulator counts every write).
#[test]
fn a_simulated_cs2000a_is_found_by_its_identity_without_a_flash_write() {
    use lightbooth::instrument::cs2000::Model;
    use lightbooth::instrument::sim::{spawn_mock, MockConfig};

    let mut config = MockConfig::cs2000(crate::common::pr655_wire::d65_radiance(), Model::Cs2000A);
    config.speed = 0.0;
    let mock = spawn_mock(config).unwrap();
    let path = mock.device_path().to_str().unwrap().to_string();
    for plan in [Family::UNKNOWN_PORT_ORDER.to_vec(), vec![Family::Cs2000]] {
        let asked = plan.len();
        let (result, took) = probe_with(&path, plan, Duration::from_secs(2));
        println!("simulated CS-2000A ({asked} families asked): {took:?}: {result}");
        match result {
            ProbeResult::Identified(id) => {
                assert_eq!(id.family, Family::Cs2000);
                assert_eq!(id.model, "CS-2000A");
                assert_eq!(id.serial.as_deref(), Some("20101234"));
            }
            other => panic!("{other:?}"),
        }
    }
    assert_eq!(
        mock.flash_writes(),
        0,
        "an identity probe must never write the CS-2000's flash"
    );
    assert_eq!(mock.measurements(), 0, "an identity probe must never measure");
}

/// Every simulated family that has an identity command is found by it
/// through the command line, among every family's questions, within one
/// deadline: the CS-2000 by `IDDR`, the CR-250 and CR-300 by `RC Model`,
/// the ColorCAL MkII by `IDR`.
/// The bug (issue 46): `instruments --probe` told a PR-650 that it
/// "answered … as a CS-2000: … is not OK00". The PR-650 answers the other
/// families' questions with its own report line, which says what it
/// probably is.
#[test]
fn a_pr650_was_told_it_answered_as_a_cs2000() {
    let pr650 = spawn_mock("mock-pr650", &["--speed", "0"]);
    let sysfs = no_ports();
    let (rows, _) = probe_json(sysfs.path(), &[pr650.path.as_str()], "2");
    let probe = &rows[0]["probe"];
    assert_eq!(probe["status"], "unrecognised", "{probe:#}");
    let message = probe["message"].as_str().unwrap_or_default();
    assert!(
        message.contains("probably a PR-650") && message.contains("--instrument instruments/pr650.toml"),
        "{probe:#}"
    );
    assert!(
        message.find("probably a PR-650") < message.find("as a Konica Minolta"),
        "the likeliest reading first: {message}"
    );
}

#[test]
fn every_simulated_family_is_found_by_its_identity_through_the_cli() {
    let cs2000 = spawn_mock("mock-cs2000", &["--speed", "0"]);
    let cr250 = spawn_mock("mock-cr250", &["--speed", "0"]);
    let cr300 = spawn_mock("mock-cr250", &["--speed", "0", "--model", "cr300"]);
    let colorcal = spawn_mock("mock-colorcal", &["--speed", "0"]);
    let sysfs = no_ports();
    let ports = [&cs2000.path, &cr250.path, &cr300.path, &colorcal.path];
    let ports: Vec<&str> = ports.iter().map(|p| p.as_str()).collect();
    let (rows, wall) = probe_json(sysfs.path(), &ports, "2");
    for row in &rows {
        println!("{} [{} ms]: {}", row["port"], row["probe_ms"], row["probe"]);
    }
    println!("four simulators probed in {wall:?}");
    assert!(wall <= Duration::from_secs(2) + MARGIN, "{wall:?}");
    let found: Vec<(&str, &str)> = rows
        .iter()
        .map(|r| {
            assert_eq!(r["probe"]["status"], "identified", "{r:#}");
            (
                r["probe"]["family"].as_str().unwrap(),
                r["probe"]["model"].as_str().unwrap(),
            )
        })
        .collect();
    assert_eq!(found[0].1, "CS-2000");
    assert_eq!(found[1].1, "CR-250");
    assert_eq!(found[2].1, "CR-300");
    assert!(found[3].1.contains("ColorCAL"), "{found:?}");
    assert_eq!(rows[0]["probe"]["serial"], "20101234");
    assert_eq!(rows[1]["probe"]["serial"], "25010042");
}
