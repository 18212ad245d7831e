//! A newcomer's first commands, run as a new user runs them: from a folder
//! other than the repository, piped into `head` (issue 32).

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn lightbooth() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lightbooth"))
}

/// `analyze nstep-error --json | head` panicked ("failed printing to
/// stdout: Broken pipe", exit 101) when its reader had gone: a one-shot
/// command ends quietly, as Unix tools do.
#[test]
fn analyze_into_a_closed_pipe_ends_without_a_panic() {
    for args in [
        &[
            "analyze",
            "nstep-error",
            "--reflectances",
            "colorchecker",
            "--illuminant",
            "D65",
            "--json",
        ][..],
        &[
            "analyze",
            "nstep-error",
            "--reflectances",
            "colorchecker",
            "--illuminant",
            "D65",
        ][..],
    ] {
        let mut child = lightbooth()
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("run lightbooth");
        // The reader goes before the command has written anything.
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert_ne!(out.status.code(), Some(101), "{args:?}: {stderr}");
    }
}

/// `color src/reference_data/…` failed outside the repository's root: the
/// book's table is built in, read the same from any folder, and a file
/// that is not there says where it was looked for and what is built in.
#[test]
fn color_reads_the_books_table_from_any_folder() {
    let elsewhere = tempfile::tempdir().unwrap();
    let out = lightbooth()
        .current_dir(elsewhere.path())
        .args([
            "color",
            "builtin:colorchecker_classic",
            "--unit",
            "reflectance",
            "--illuminant",
            "D65",
            "--white",
            "p19_white",
            "--reference",
            "p19_white",
        ])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        stdout.contains("p01_dark_skin") && stdout.contains("p19_white"),
        "{stdout}"
    );
    let out = lightbooth()
        .current_dir(elsewhere.path())
        .args(["color", "src/reference_data/colorchecker_classic.csv"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("no such file") && stderr.contains("builtin:colorchecker_classic"),
        "{stderr}"
    );
}

/// One GET on loopback: its status, or None when nothing answers.
fn get_status(addr: &str, path: &str) -> Option<u16> {
    let mut stream = TcpStream::connect(addr).ok()?;
    stream.set_read_timeout(Some(Duration::from_secs(10))).ok()?;
    write!(
        stream,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .ok()?;
    let mut answer = String::new();
    stream.read_to_string(&mut answer).ok()?;
    answer.split_whitespace().nth(1)?.parse().ok()
}

/// `serve --mock` from another folder printed the dashboard's URL and then
/// exited with "cannot read the scenes folder scenes", and had no
/// `--scenes`. From another folder it finds the repository's scenes and
/// serves them; a scenes folder that is not there stops it before any URL
/// is printed, naming the folder and the flag.
#[test]
fn serve_mock_from_another_folder_finds_its_scenes_or_says_so_before_the_url() {
    let elsewhere = tempfile::tempdir().unwrap();
    let db = format!("sqlite://{}", elsewhere.path().join("lab.sqlite").display());
    let common = [
        "serve",
        "--mock",
        "--mock-speed",
        "0",
        "--bind",
        "127.0.0.1:0",
        "--db",
        db.as_str(),
    ];

    let missing = elsewhere.path().join("no-such-scenes");
    let out = lightbooth()
        .current_dir(elsewhere.path())
        .args(common)
        .arg("--scenes")
        .arg(&missing)
        .output()
        .unwrap();
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(!out.status.success(), "{stdout}");
    assert!(
        !stdout.contains("dashboard"),
        "a URL printed before the failure: {stdout}"
    );
    assert!(
        stderr.contains(&missing.display().to_string()) && stderr.contains("--scenes"),
        "{stderr}"
    );

    // Its log in a file: a pipe nobody reads would fill and stop it.
    let log = elsewhere.path().join("serve.log");
    let mut child = lightbooth()
        .current_dir(elsewhere.path())
        .args(common)
        .stdout(Stdio::piped())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let addr = lines.by_ref().map_while(Result::ok).find_map(|l| {
        l.strip_prefix("lightbooth listening on http://")
            .map(|a| a.trim_end_matches('/').to_string())
    });
    let Some(addr) = addr else {
        let _ = child.kill();
        let _ = child.wait();
        panic!(
            "no address printed: {}",
            std::fs::read_to_string(&log).unwrap_or_default()
        );
    };
    let start = Instant::now();
    let status = loop {
        if let Some(exit) = child.try_wait().unwrap() {
            let stderr = std::fs::read_to_string(&log).unwrap_or_default();
            panic!("the daemon exited ({exit}) after printing {addr}: {stderr}");
        }
        match get_status(&addr, "/api/scenes") {
            Some(status) => break status,
            None if start.elapsed() < Duration::from_secs(120) => std::thread::sleep(Duration::from_millis(200)),
            None => break 0,
        }
    };
    let _ = child.kill();
    let _ = child.wait();
    assert_eq!(status, 200, "GET /api/scenes of the daemon started from another folder");
}
