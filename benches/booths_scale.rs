//! The scale test of issue 14 (a benchmark, not a test): on loopback, one
//! fresh PostgreSQL database and several `lightbooth serve --mock --booth`
//! processes (simulated booths). It submits scene-target measurements on
//! every booth through the REST API, waits until all are final with their
//! comparisons, and reports measurements lost, duplicated and comparisons
//! missing, the wall time and comparisons per second. Then the kill test:
//! one daemon is killed with SIGKILL mid-measurement (a slow one: many
//! samples), and a neighbour must mark it interrupted with its samples
//! while every other measurement completes. Exits non-zero when a check
//! fails. The harness is `tests/common/booths.rs`, shared with
//! `tests/daemon/booths_scale.rs` (the same checks with a small load, in CI).
//!
//! With `--workers N` the daemons leave their comparisons, renders and
//! studies to N render workers (`serve --renders workers`, `lightbooth
//! worker`); after the load one study runs (on a worker), and with two or
//! more workers the worker kill test runs first: a render asked of a booth
//! is running on a worker when that worker is killed with SIGKILL, and
//! another must finish it.
//!
//! ```text
//! cargo bench --bench booths_scale -- [--json] [--daemons 3] [--workers 0]
//!     [--per-booth 100] [--samples 3] [--mock-speed 0] [--render-samples 1024]
//!     [--kill-samples 99] [--beside-kill 5] [--no-kill]
//!     [--worker-kill-samples 1048576] [--no-study] [--db postgres://…]
//! ```
//!
//! Without `--db` the database is a fresh one on the test server
//! (`tests/setup.sh`; `$LIGHTBOOTH_TEST_PG` or target/pg-url).

#[path = "../tests/common/mod.rs"]
mod common;

use common::booths;

use std::time::Duration;

use serde_json::json;

struct Options {
    json: bool,
    db: Option<String>,
    daemons: usize,
    per_booth: usize,
    samples: usize,
    kill: bool,
    kill_samples: usize,
    beside_kill: usize,
    workers: usize,
    worker_kill_samples: u32,
    study: bool,
    serve: booths::ServeOptions,
}

fn value<T: std::str::FromStr>(flag: &str, v: Option<String>) -> T {
    let v = v.unwrap_or_else(|| panic!("{flag} needs a value"));
    v.parse().unwrap_or_else(|_| panic!("{flag} {v}: not a valid value"))
}

fn options() -> Options {
    let mut o = Options {
        json: false,
        db: None,
        daemons: 3,
        per_booth: 100,
        samples: 3,
        kill: true,
        kill_samples: 99,
        beside_kill: 5,
        workers: 0,
        worker_kill_samples: 1 << 20,
        study: true,
        serve: booths::ServeOptions::default(),
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--json" => o.json = true,
            "--db" => o.db = Some(value("--db", args.next())),
            "--daemons" => o.daemons = value("--daemons", args.next()),
            "--per-booth" => o.per_booth = value("--per-booth", args.next()),
            "--samples" => o.samples = value("--samples", args.next()),
            "--mock-speed" => o.serve.mock_speed = value("--mock-speed", args.next()),
            "--render-samples" => o.serve.render_samples = value("--render-samples", args.next()),
            "--kill-samples" => o.kill_samples = value("--kill-samples", args.next()),
            "--beside-kill" => o.beside_kill = value("--beside-kill", args.next()),
            "--no-kill" => o.kill = false,
            "--workers" => o.workers = value("--workers", args.next()),
            "--worker-kill-samples" => o.worker_kill_samples = value("--worker-kill-samples", args.next()),
            "--no-study" => o.study = false,
            // `cargo bench` passes `--bench`.
            "--bench" => {}
            other => panic!("unknown argument {other}"),
        }
    }
    assert!(
        o.daemons >= 2 || !o.kill,
        "the kill test needs a neighbour: --daemons 2 or more"
    );
    assert!(o.daemons >= 1, "--daemons 0: nothing to measure with");
    if o.workers > 0 {
        o.serve
            .extra_args
            .extend(["--renders".to_string(), "workers".to_string()]);
    }
    o
}

fn main() {
    let o = options();
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    let passed = rt.block_on(async move {
        let db = match &o.db {
            Some(url) => url.clone(),
            None => common::fresh_postgres_database().await,
        };
        let names = booths::booth_names(o.daemons);
        let mut lab = booths::start_lab(&db, &names, &o.serve).await;
        for _ in 0..o.workers {
            let w = booths::spawn_worker(&db, 0.5, 2.0).await;
            lab.workers.push(w);
        }
        eprintln!(
            "{} daemons up; submitting {} measurements per booth",
            lab.daemons.len(),
            o.per_booth
        );
        let codings = o.serve.codings.clone();
        let load = booths::run_load(&lab, "scale", o.per_booth, o.samples, &booths::TARGETS, &codings, Duration::from_secs(1800)).await;
        let a = &load.audit;
        let mut report = json!({
            "daemons": o.daemons,
            "workers": o.workers,
            "per_booth": o.per_booth,
            "samples": o.samples,
            "mock_speed": o.serve.mock_speed,
            "render_samples": o.serve.render_samples,
            "codings": codings,
            "load": load.to_json(),
        });
        if !o.json {
            println!(
                "load: {} measurements on {} booths ({} samples each): {} lost, {} duplicated, {} not complete, \
                 {} comparisons ({} missing); wall {:.1} s (submitting {:.1} s), {:.2} measurements/s, {:.2} comparisons/s",
                a.submitted,
                o.daemons,
                o.samples,
                a.lost.len(),
                a.duplicated.len(),
                a.not_complete.len(),
                a.comparisons,
                a.comparisons_missing.len(),
                load.wall_seconds,
                load.submit_seconds,
                a.submitted as f64 / load.wall_seconds,
                load.comparisons_per_second()
            );
            for e in a.lost.iter().chain(&a.duplicated).chain(&a.not_complete).chain(&a.mismatched).chain(&a.comparisons_missing).take(10) {
                println!("    {e}");
            }
        }
        let mut passed = a.passed();
        if o.workers >= 2 {
            let k = booths::kill_worker_test(&mut lab, o.worker_kill_samples).await;
            if !o.json {
                println!(
                    "kill -9 of worker {} mid-render {}: {} {:.1} s after the kill, finished by worker {:?} ({} claims)",
                    k.killed_worker, k.render_id, k.state_after, k.seconds_to_complete, k.finished_by, k.attempts
                );
                for f in &k.failures {
                    println!("    FAILED: {f}");
                }
            }
            passed &= k.failures.is_empty();
            report["worker_kill"] = k.to_json();
        }
        if o.study {
            let t = std::time::Instant::now();
            let study = booths::run_study(&lab, "white,red", Duration::from_secs(1800)).await;
            let seconds = t.elapsed().as_secs_f64();
            if !o.json {
                println!("one study (white, red; 1 seed): {} in {seconds:.1} s {}", study["state"], study["error"]);
            }
            passed &= study["state"] == "complete";
            report["study"] = json!({ "state": study["state"], "error": study["error"], "seconds": seconds });
        }
        if o.kill {
            let kill = booths::kill_test(&mut lab, "scale", o.kill_samples, o.beside_kill, &load.submissions, &codings).await;
            if !o.json {
                println!(
                    "kill -9 of booth {} mid-measurement {} ({} samples at the kill): {} after {:.1} s with {} samples \
                     ({}); {} measurements beside it: {} lost, {} not complete, {} comparisons missing; \
                     the load after the kill: {} lost, {} not complete",
                    kill.victim,
                    kill.measurement_id,
                    kill.samples_at_kill,
                    kill.state_after,
                    kill.recovery_seconds,
                    kill.samples_after,
                    kill.error,
                    kill.neighbours.submitted,
                    kill.neighbours.lost.len(),
                    kill.neighbours.not_complete.len(),
                    kill.neighbours.comparisons_missing.len(),
                    kill.before.lost.len(),
                    kill.before.not_complete.len(),
                );
                for f in &kill.failures {
                    println!("    FAILED: {f}");
                }
            }
            passed &= kill.failures.is_empty();
            report["kill"] = kill.to_json();
        }
        report["passed"] = json!(passed);
        if o.json {
            println!("{}", serde_json::to_string_pretty(&report).unwrap());
        } else {
            println!("{}", if passed { "passed" } else { "FAILED" });
        }
        if !passed {
            for d in &lab.daemons {
                eprintln!("--- log of booth {} ---\n{}", d.booth, d.log_tail());
            }
        }
        passed
    });
    if !passed {
        std::process::exit(1);
    }
}
