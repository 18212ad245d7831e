//! Benchmark (not a test): the cost of the store's durability promise. Each
//! raw sample is one committed INSERT (a 101-value spectrum as JSON); with
//! `synchronous = FULL` the commit waits for the WAL to reach the disk, with
//! NORMAL it does not (and can be lost on power loss). Times every insert of
//! `SAMPLES` samples into a fresh database on the target folder's disk, in
//! each mode, and prints the median and quartiles per sample write.
//!
//! Run: `cargo bench --bench sample_durability` (add `-- --json` for one JSON line).

use std::time::Instant;

use lightbooth::store::{now, NewMeasurement, NewSample, Store};
use sqlx::sqlite::SqliteSynchronous;

const SAMPLES: usize = 400;

fn quartiles(mut ms: Vec<f64>) -> [f64; 3] {
    ms.sort_by(f64::total_cmp);
    let at = |q: f64| ms[((ms.len() - 1) as f64 * q).round() as usize];
    [at(0.25), at(0.5), at(0.75)]
}

async fn per_sample_ms(mode: SqliteSynchronous) -> Vec<f64> {
    let dir = tempfile::tempdir_in(env!("CARGO_TARGET_TMPDIR")).unwrap();
    let url = format!("sqlite://{}", dir.path().join("bench.sqlite").display());
    let store = Store::open_with_synchronous(&url, mode).await.unwrap();
    let mut times = Vec::with_capacity(SAMPLES);
    // Measurements of at most 99 samples, as the API allows.
    let mut id = 0;
    for i in 0..SAMPLES {
        if i % 99 == 0 {
            id = store
                .create_measurement(&NewMeasurement {
                    booth: Default::default(),
                    session_id: None,
                    scene: None,
                    target: None,
                    samples: 99,
                    settings_json: serde_json::json!({}),
                    note: String::new(),
                })
                .await
                .unwrap();
        }
        let sample = NewSample {
            index: i % 99,
            taken_at: now(),
            code: 0,
            message: "OK".into(),
            usable: true,
            radiance: Some((0..101).map(|k| 0.01 + 1e-5 * k as f64).collect()),
            luminance_cd_m2: Some(73.1),
            instrument_xyz: None,
        };
        let t = Instant::now();
        store.insert_sample(id, &sample).await.unwrap();
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    store.close().await;
    times
}

#[tokio::main(flavor = "current_thread")]
async fn main() {
    let json = std::env::args().any(|a| a == "--json");
    let normal = quartiles(per_sample_ms(SqliteSynchronous::Normal).await);
    let full = quartiles(per_sample_ms(SqliteSynchronous::Full).await);
    if json {
        println!(
            "{{\"samples\":{SAMPLES},\"normal_ms\":{{\"q1\":{:.4},\"median\":{:.4},\"q3\":{:.4}}},\
             \"full_ms\":{{\"q1\":{:.4},\"median\":{:.4},\"q3\":{:.4}}}}}",
            normal[0], normal[1], normal[2], full[0], full[1], full[2]
        );
    } else {
        println!("per-sample write, {SAMPLES} samples each (ms: 25 % / median / 75 %)");
        println!(
            "  synchronous=NORMAL  {:.3} / {:.3} / {:.3}",
            normal[0], normal[1], normal[2]
        );
        println!("  synchronous=FULL    {:.3} / {:.3} / {:.3}", full[0], full[1], full[2]);
    }
}
