//! Hostile scene input (issue 22, "Scene files"): numbers that overflow,
//! arrays that multiply work, files that never end or never open, and
//! files outside the scene's folder. Each is an error naming the file, the
//! line (or key) and the limit — never a panic, a hang or unbounded work —
//! and `lightbooth serve` started on such a scene refuses to start saying
//! so instead of panicking.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use glam::DVec3;
use lightbooth::render::input_file::MAX_INPUT_BYTES;
use lightbooth::render::load_scene;
use lightbooth::render::radiance::{MAX_PLACEMENTS, MAX_PRIMITIVES};
use lightbooth::render::scene::{load_radiance_scene, RadianceView, SceneError};

fn view() -> RadianceView {
    RadianceView {
        radiometer: DVec3::new(0.0, 0.0, 2.0),
        field_deg: 1.0,
        targets: vec![("t".into(), DVec3::ZERO)],
    }
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    if let Some(parent) = p.parent() {
        std::fs::create_dir_all(parent).unwrap();
    }
    std::fs::write(&p, text).unwrap();
    p
}

/// Runs `f` on another thread; an error if it has not returned within
/// `limit` (a generous bound: the regression is a hang, not slowness).
fn within<T: Send + 'static>(limit: Duration, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(limit).expect("the load hangs")
}

/// A floor the target lies on, for scenes that should load.
const FLOOR: &str = "void plastic grey 0 0 5 .5 .5 .5 0 0\ngrey polygon floor 0 0 12 -1 -1 0 1 -1 0 1 1 0 -1 1 0\n";

/// A TOML scene with one `[[radiance]]` file.
fn toml_with_radiance(dir: &Path, rad: &str) -> PathBuf {
    write(
        dir,
        "s.toml",
        &format!(
            "name = \"s\"\n[radiometer]\nposition = [0.0, 0.0, 2.0]\n[[target]]\nid = \"t\"\npoint = [0.0, 0.0, 0.0]\n\
             [cielab_white]\ntarget = \"t\"\n[[radiance]]\nfile = \"{rad}\"\n"
        ),
    )
}

#[test]
fn a_radiance_light_of_1e308_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    for (text, want) in [
        (
            "void light lamp 0 0 3 1e308 1e308 1e308\n",
            "lamp.rad:3: light lamp: the radiance 1e308",
        ),
        (
            "void spectrum sp 0 0 5 380 780 1 1 1\nsp light lamp 0 0 3 1e308 1e308 1e308\n",
            "lamp.rad:4: light lamp: grey 1e308",
        ),
        // A vertex that overflows once transformed.
        (
            "void plastic p 0 0 5 .5 .5 .5 0 0\n!xform -s 1e300 big.rad\n",
            "big.rad:1: polygon big: vertex 1 is not a finite number once placed",
        ),
        (
            "void plastic p 0 0 5 .5 .5 .5 0 0\n!xform -s 1e300 ball.rad\n",
            "ball.rad:1: sphere ball: its geometry is not a finite number once placed",
        ),
    ] {
        let text = format!("{FLOOR}{text}");
        write(dir.path(), "big.rad", "p polygon big 0 0 9 1e10 0 0 0 1e10 0 0 0 1\n");
        write(dir.path(), "ball.rad", "p sphere ball 0 0 4 1e10 0 0 1\n");
        let rad = write(dir.path(), "lamp.rad", &text);
        let e = load_radiance_scene(&rad, &view()).unwrap_err().to_string();
        assert!(e.contains(want), "{e}\nwanted: {want}");
        // The same through a TOML scene's [[radiance]].
        let toml = toml_with_radiance(dir.path(), "lamp.rad");
        let e = load_scene(&toml).unwrap_err();
        assert_eq!(e.key, "radiance[0].file");
        assert!(e.message.contains(want), "{e}");
    }
}

#[test]
fn a_toml_number_of_1e308_is_an_error_naming_its_key() {
    let dir = tempfile::tempdir().unwrap();
    for (extra, key) in [
        (
            "[materials]\ngrey = { reflectance = 0.5 }\n[[quad]]\ncorner = [-1.0, -1.0, 0.0]\n\
             edge_u = [1e308, 0.0, 0.0]\nedge_v = [0.0, 2.0, 0.0]\nmaterial = \"grey\"\n",
            "quad[0].edge_u[0]",
        ),
        (
            "[[light]]\nid = \"l\"\nposition = [0.0, 0.0, 1.0]\nintensity_cd = 1e300\nblackbody_k = 3000\n",
            "light[0].intensity_cd",
        ),
    ] {
        let e = load_scene(&toml_scene(dir.path(), extra)).unwrap_err();
        assert_eq!(e.key, key, "{e}");
        assert!(e.message.contains("MAX_SCENE_NUMBER"), "{e}");
    }
    // Within the limit, a light 1e-150 m from the CIELAB diffuser overflows: an error, not a panic.
    let e = load_scene(&toml_scene(
        dir.path(),
        "[materials]\ngrey = { reflectance = 0.5 }\n[[quad]]\ncorner = [-1.0, -1.0, 0.0]\nedge_u = [2.0, 0.0, 0.0]\n\
         edge_v = [0.0, 2.0, 0.0]\nmaterial = \"grey\"\n[[light]]\nid = \"l\"\nposition = [3.0, 3.0, 1e-150]\n\
         intensity_cd = 1e12\nblackbody_k = 3000\n[cielab_white]\nlight_on_perfect_diffuser = true\n\
         point = [3.0, 3.0, 2e-150]\nnormal = [0.0, 0.0, -1.0]\n",
    ))
    .unwrap_err();
    assert_eq!(e.key, "cielab_white.point", "{e}");
}

#[test]
fn an_ies_file_with_non_finite_or_overflowing_candela_is_an_error() {
    use lightbooth::render::ies::IesDistribution;
    let head = "IESNA:LM-63-2002\nTILT=NONE\n";
    for (body, want) in [
        (
            "1 1000 1 1 1000000000000000000 1 2 0 0 0\n1 1 10\n0\n0\n100\n",
            "need more numbers",
        ),
        (
            "1 1000 1e300 2 1 1 2 0 0 0\n1e300 1 10\n0 90\n0\n100 50\n",
            "not a finite number",
        ),
        (
            "1 1000 1 2 1 1 2 0 0 0\n1 1 10\n0 90\n0\n100 nan\n",
            "not a finite number",
        ),
        ("1 1000 -1 2 1 1 2 0 0 0\n1 1 10\n0 90\n0\n100 50\n", "must be positive"),
    ] {
        let e = IesDistribution::parse(&format!("{head}{body}"), "lamp.ies")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("lamp.ies") && e.contains(want), "{e}");
    }
}

/// The primitives of a `.rad` scene (it must load).
fn rad_primitives(rad: &Path) -> usize {
    load_radiance_scene(rad, &view()).unwrap().primitives.len()
}

#[test]
fn xform_arrays_are_linear_in_their_count() {
    // The whole array is one expansion of the file placed N times: N polygons
    // (2 triangles each), and the copies are where arrays put them.
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "tile.rad",
        "grey polygon tile 0 0 12 0 0 0 0.001 0 0 0.001 0.001 0 0 0.001 0\n",
    );
    for n in [10, 1000, 100_000] {
        let rad = write(
            dir.path(),
            "s.rad",
            &format!("{FLOOR}!xform -t 0 0 1 -a {n} -t 0.002 0 0 tile.rad\n"),
        );
        assert_eq!(rad_primitives(&rad), 2 + 2 * n, "-a {n}");
    }
    // Arrays nested through files multiply: 300 × 300 tiles.
    write(dir.path(), "row.rad", "!xform -a 300 -t 0.002 0 0 tile.rad\n");
    let rad = write(
        dir.path(),
        "s.rad",
        &format!("{FLOOR}!xform -t 0 0 1 -a 300 -t 0 0.002 0 row.rad\n"),
    );
    assert_eq!(rad_primitives(&rad), 2 + 2 * 300 * 300);
}

#[test]
fn nested_xform_arrays_are_bounded_in_primitives_and_placements() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "tile.rad",
        "grey polygon tile 0 0 12 0 0 0 0.001 0 0 0.001 0.001 0 0 0.001 0\n",
    );
    write(dir.path(), "row.rad", "!xform -a 100000 -t 0.002 0 0 tile.rad\n");
    let rad = write(
        dir.path(),
        "s.rad",
        &format!("{FLOOR}\n!xform -a 100000 -t 0 0.002 0 row.rad\n"),
    );
    let e = within(Duration::from_secs(120), move || load_radiance_scene(&rad, &view()))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("s.rad:4: !xform -a 100000") && e.contains(&format!("more than {MAX_PRIMITIVES} primitives")),
        "{e}"
    );
    // Arrays of an empty file add no primitives but cost work: bounded too.
    write(dir.path(), "empty.rad", "# nothing\n");
    let line = "!xform -a 100000 empty.rad\n";
    let rad = write(dir.path(), "s.rad", &format!("{FLOOR}{}", line.repeat(30)));
    let e = within(Duration::from_secs(120), move || load_radiance_scene(&rad, &view()))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("s.rad:23: !xform -a 100000 empty.rad") && e.contains(&format!("more than {MAX_PLACEMENTS} copies")),
        "{e}"
    );
    // Nesting depth is bounded and named.
    write(dir.path(), "self.rad", "!xform -a 2 self.rad\n");
    let rad = write(dir.path(), "s.rad", &format!("{FLOOR}!xform self.rad\n"));
    let e = load_radiance_scene(&rad, &view()).unwrap_err().to_string();
    assert!(e.contains("nests deeper than 16 files (MAX_DEPTH"), "{e}");
}

#[cfg(unix)]
fn mkfifo(path: &Path) {
    let status = Command::new("mkfifo").arg(path).status().unwrap();
    assert!(status.success());
}

#[cfg(unix)]
#[test]
fn a_fifo_as_an_included_file_is_refused_without_hanging() {
    let dir = tempfile::tempdir().unwrap();
    mkfifo(&dir.path().join("pipe.rad"));
    mkfifo(&dir.path().join("pipe.csv"));
    mkfifo(&dir.path().join("pipe.obj"));
    mkfifo(&dir.path().join("pipe.ies"));
    mkfifo(&dir.path().join("pipe.dat"));
    let rad = write(dir.path(), "s.rad", &format!("{FLOOR}!xform pipe.rad\n"));
    let e = within(Duration::from_secs(60), move || load_radiance_scene(&rad, &view()))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("s.rad:3") && e.contains("pipe.rad: it is a FIFO (named pipe), not a regular file"),
        "{e}"
    );
    let rad = write(
        dir.path(),
        "s.rad",
        "void specfile sp 1 pipe.dat 0 0\nsp plastic grey 0 0 5 .5 .5 .5 0 0\n",
    );
    let e = within(Duration::from_secs(60), move || load_radiance_scene(&rad, &view()))
        .unwrap_err()
        .to_string();
    assert!(e.contains("s.rad:1: specfile sp") && e.contains("FIFO"), "{e}");
    for (extra, key) in toml_references("pipe") {
        let toml = toml_scene(dir.path(), &extra);
        let e = within(Duration::from_secs(60), move || load_scene(&toml)).unwrap_err();
        assert_eq!(e.key, key, "{e}");
        assert!(e.message.contains("FIFO (named pipe), not a regular file"), "{e}");
    }
}

/// TOML that reads a spectra CSV, a mesh and an IES file named `{stem}.…`
/// (or `stem` itself when it has a folder), and the key each error names.
fn toml_references(stem: &str) -> Vec<(String, &'static str)> {
    let name = |ext: &str| {
        if stem.contains('/') {
            stem.to_string()
        } else {
            format!("{stem}.{ext}")
        }
    };
    vec![
        (
            format!("[materials]\nm = {{ reflectance = \"{}:x\" }}\n", name("csv")),
            "materials.m.reflectance",
        ),
        (
            format!(
                "[materials]\ngrey = {{ reflectance = 0.5 }}\n[[mesh]]\nfile = \"{}\"\nmaterial = \"grey\"\n",
                if stem.contains('/') { format!("{stem}.obj") } else { name("obj") }
            ),
            "mesh[0].file",
        ),
        (
            format!(
                "[[light]]\nid = \"l\"\nposition = [0.0, 0.0, 1.0]\naim = [0.0, 0.0, -1.0]\nies = \"{}\"\nblackbody_k = 3000\n",
                name("ies")
            ),
            "light[0].ies",
        ),
    ]
}

fn toml_scene(dir: &Path, extra: &str) -> PathBuf {
    write(
        dir,
        "s.toml",
        &format!(
            "name = \"s\"\n[radiometer]\nposition = [0.0, 0.0, 2.0]\n[[target]]\nid = \"t\"\npoint = [0.0, 0.0, 0.0]\n{extra}"
        ),
    )
}

#[cfg(unix)]
#[test]
fn dev_zero_and_dev_urandom_as_scene_files_are_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    for dev in ["/dev/zero", "/dev/urandom"] {
        let rad = write(dir.path(), "s.rad", &format!("{FLOOR}!xform {dev}\n"));
        let e = within(Duration::from_secs(60), move || load_radiance_scene(&rad, &view()))
            .unwrap_err()
            .to_string();
        assert!(e.contains(&format!("{dev}: it is a character device")), "{e}");
        let rad = write(
            dir.path(),
            "s.rad",
            &format!("void specfile sp 1 {dev} 0 0\nsp plastic grey 0 0 5 .5 .5 .5 0 0\n"),
        );
        let e = within(Duration::from_secs(60), move || load_radiance_scene(&rad, &view()))
            .unwrap_err()
            .to_string();
        assert!(e.contains("character device"), "{e}");
        for (extra, key) in [
            (format!("[materials]\nm = {{ reflectance = \"{dev}:x\" }}\n"), "materials.m.reflectance"),
            (
                format!("[[light]]\nid = \"l\"\nposition = [0.0, 0.0, 1.0]\naim = [0.0, 0.0, -1.0]\nies = \"{dev}\"\nblackbody_k = 3000\n"),
                "light[0].ies",
            ),
        ] {
            let toml = toml_scene(dir.path(), &extra);
            let e = within(Duration::from_secs(60), move || load_scene(&toml)).unwrap_err();
            assert_eq!(e.key, key, "{e}");
            assert!(e.message.contains(dev) && e.message.contains("character device"), "{e}");
        }
    }
}

#[test]
fn a_scene_file_larger_than_the_limit_is_refused_naming_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    // A sparse file: one byte over the limit, no disk used.
    let big = dir.path().join("big.csv");
    std::fs::File::create(&big)
        .unwrap()
        .set_len(MAX_INPUT_BYTES + 1)
        .unwrap();
    let toml = toml_scene(dir.path(), "[materials]\nm = { reflectance = \"big.csv:x\" }\n");
    let e: SceneError = load_scene(&toml).unwrap_err();
    assert_eq!(e.key, "materials.m.reflectance");
    assert!(
        e.message.contains("big.csv") && e.message.contains(&format!("more than the {MAX_INPUT_BYTES} bytes")),
        "{e}"
    );
}

#[test]
fn errors_about_files_outside_the_scene_folder_do_not_quote_them() {
    let root = tempfile::tempdir().unwrap();
    let secret = "SECRET-hunter2";
    let outside = root.path().join("outside");
    write(&outside, "t.csv", &format!("nm,{secret}\n380,{secret}\n"));
    write(
        &outside,
        "t.obj",
        &format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl {secret}\nf 1 2 3\n"),
    );
    write(
        &outside,
        "t.ies",
        &format!("IESNA:LM-63-2002\nTILT=NONE\n1 1000 1 {secret}\n"),
    );
    write(&outside, "t.rad", &format!("void plastic {secret} 0 0 5 .5 .5 x 0 0\n"));
    write(&outside, "t.dat", &format!("400 {secret}\n"));
    let scenes = root.path().join("scenes");
    std::fs::create_dir(&scenes).unwrap();
    for (extra, key) in toml_references("../outside/t") {
        let extra = extra
            .replace("../outside/t:x", "../outside/t.csv:x")
            .replace("\"../outside/t\"", "\"../outside/t.ies\"");
        let toml = toml_scene(&scenes, &extra);
        let e = load_scene(&toml).unwrap_err();
        assert_eq!(e.key, key, "{e}");
        let text = e.to_string();
        assert!(!text.contains("SECRET"), "{text}");
        assert!(
            text.contains("outside/t.") && text.contains("outside the scene's folder"),
            "{text}"
        );
    }
    let e = load_scene(&toml_with_radiance(&scenes, "../outside/t.rad"))
        .unwrap_err()
        .to_string();
    assert!(
        !e.contains("SECRET") && e.contains("outside/t.rad:1:") && e.contains("not quoted"),
        "{e}"
    );
    let rad = write(&scenes, "s.rad", &format!("{FLOOR}!xform ../outside/t.rad\n"));
    let e = load_radiance_scene(&rad, &view()).unwrap_err().to_string();
    assert!(!e.contains("SECRET") && e.contains("outside/t.rad:1:"), "{e}");
    let rad = write(
        &scenes,
        "s.rad",
        "void specfile sp 1 ../outside/t.dat 0 0\nsp plastic grey 0 0 5 .5 .5 .5 0 0\n",
    );
    let e = load_radiance_scene(&rad, &view()).unwrap_err().to_string();
    assert!(!e.contains("SECRET") && e.contains("outside/t.dat"), "{e}");
    // Inside the folder, errors quote as before.
    write(&scenes, "t.csv", &format!("nm,{secret}\n380,{secret}\n"));
    let e = load_scene(&toml_scene(&scenes, "[materials]\nm = { reflectance = \"t.csv:x\" }\n")).unwrap_err();
    assert!(e.to_string().contains("SECRET"), "{e}");
}

/// `lightbooth serve` on a scenes folder holding a scene whose RADIANCE
/// file has a `light` of 1e308 refuses to start, naming the file and the
/// line; it used to panic (`NonFiniteValue`).
#[test]
fn serve_with_a_1e308_light_in_its_scenes_folder_refuses_to_start_naming_the_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = dir.path().join("scenes");
    write(
        &scenes,
        "lamp.rad",
        &format!("{FLOOR}void light lamp 0 0 3 1e308 1e308 1e308\n"),
    );
    toml_with_radiance(&scenes, "lamp.rad");
    std::fs::write(dir.path().join("token"), "scene-limits-token-0123456789").unwrap();
    std::fs::write(
        dir.path().join("lightbooth.toml"),
        format!("scenes_dir = \"{}\"\n", scenes.display()),
    )
    .unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .current_dir(dir.path())
        .args([
            "serve",
            "--mock",
            "--bind",
            "127.0.0.1:0",
            "--config",
            "lightbooth.toml",
        ])
        .args(["--db", &format!("sqlite://{}", dir.path().join("lab.sqlite").display())])
        .args(["--token-file", dir.path().join("token").to_str().unwrap()])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = child.stderr.take().unwrap();
    let read = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut stderr, &mut s).unwrap();
        s
    });
    let deadline = std::time::Instant::now() + Duration::from_secs(60);
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if std::time::Instant::now() > deadline {
            child.kill().unwrap();
            panic!("serve kept running with a scene it cannot load");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let stderr = read.join().unwrap();
    assert!(!status.success(), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        stderr.contains("s.toml") && stderr.contains("lamp.rad:3: light lamp: the radiance 1e308"),
        "{stderr}"
    );
}
