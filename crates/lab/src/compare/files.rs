//! A scene's comparisons as files: the CSV and the MAT-file the API
//! serves (`/api/scenes/{scene}/comparisons.csv|.mat`), made once per kept
//! summary ([`crate::computed`]). Both name the same columns: each stored
//! row's, then its propagated uncertainty's (see [`uncertainty_columns`]).

use std::collections::HashMap;

use lightbooth_report::export::csv_table::csv_table;
use lightbooth_report::export::mat::MatFile;
use lightbooth_science::uncertainty::{PointUncertainty, PropagatedDifference};
use lightbooth_store::ComparisonRow;

use super::summary::SceneComparisons;

/// A stored column of the CSV: its name and the row's value as text.
type StoredColumn = (&'static str, fn(&ComparisonRow) -> String);

/// The stored row's columns, in the order of [`ComparisonRow`]'s fields.
/// Numbers in Rust's shortest round-trip form; an unset value is empty.
const STORED_COLUMNS: [StoredColumn; 25] = [
    ("id", |r| r.id.to_string()),
    ("measurement_id", |r| r.measurement_id.to_string()),
    ("render_id", |r| r.render_id.to_string()),
    ("scene", |r| r.scene.clone()),
    ("target", |r| r.target.clone()),
    ("coding", |r| r.coding.clone()),
    ("observer", |r| r.observer.name().to_string()),
    ("white_source", |r| r.white_source.clone()),
    ("white_X", |r| r.white_X.to_string()),
    ("white_Y", |r| r.white_Y.to_string()),
    ("white_Z", |r| r.white_Z.to_string()),
    ("measured_X", |r| r.measured_X.to_string()),
    ("measured_Y", |r| r.measured_Y.to_string()),
    ("measured_Z", |r| r.measured_Z.to_string()),
    ("rendered_X", |r| r.rendered_X.to_string()),
    ("rendered_Y", |r| r.rendered_Y.to_string()),
    ("rendered_Z", |r| r.rendered_Z.to_string()),
    ("rendered_Y_se", |r| r.rendered_Y_se.to_string()),
    ("measured_Y_se", |r| {
        r.measured_Y_se.map(|v| v.to_string()).unwrap_or_default()
    }),
    ("Y_beyond_noise", |r| {
        r.Y_beyond_noise.map(|v| v.to_string()).unwrap_or_default()
    }),
    ("Y_ratio", |r| r.Y_ratio.to_string()),
    ("xy_distance", |r| r.xy_distance.to_string()),
    ("dE76", |r| r.dE76.to_string()),
    ("dE00", |r| r.dE00.to_string()),
    ("created_at", |r| r.created_at.to_string()),
];

/// The CSV of a scene's comparisons: every row names its observer (the
/// `observer` column); the stored columns first, then each row's
/// uncertainty columns. No rows, no header (an empty file).
pub fn comparisons_csv(c: &SceneComparisons) -> Result<Vec<u8>, String> {
    if c.rows.is_empty() {
        return Ok(Vec::new());
    }
    let stored = &STORED_COLUMNS;
    let extra = uncertainty_columns(None);
    let mut header: Vec<&str> = stored.iter().map(|(name, _)| *name).collect();
    header.extend(extra.iter().map(|(name, _)| name.as_str()));
    let by_row = uncertainty_by_row(c);
    let rows = c.rows.iter().map(|row| {
        let mut fields: Vec<String> = stored.iter().map(|(_, value)| value(row)).collect();
        fields.extend(
            uncertainty_columns(by_row.get(&row.id).copied())
                .into_iter()
                .map(|(_, v)| v),
        );
        fields
    });
    Ok(csv_table(&header, rows)?.into_bytes())
}

/// Each comparison row's propagated figures, by the row's id.
fn uncertainty_by_row(c: &SceneComparisons) -> HashMap<i64, (&PointUncertainty, &str)> {
    c.codings
        .iter()
        .filter_map(|s| s.uncertainty.as_ref().ok())
        .flat_map(|u| {
            u.row_ids
                .iter()
                .copied()
                .zip(u.propagated.points.iter().map(|p| (p, u.instrument_model.as_str())))
        })
        .collect()
}

/// A row's uncertainty columns, named as in the CSV and the MAT file
/// (empty, or NaN in the MAT file, where nothing was propagated): the
/// simulated truth's standard error of Y in the budget (`truth_se_Y`,
/// cd/m²; empty for a real instrument); for ΔE00 the 95th percentile of what the measurement's error alone gives
/// (repeatability; with the stated accuracy), for Δx, Δy and relative ΔY
/// the 95 % interval with the stated accuracy; and each figure's three
/// claims (`true`/`false`; empty where not made).
pub fn uncertainty_columns(p: Option<(&PointUncertainty, &str)>) -> Vec<(String, String)> {
    let num = |v: Option<f64>| v.map(|v| v.to_string()).unwrap_or_default();
    let flag = |v: Option<bool>| v.map(|v| v.to_string()).unwrap_or_default();
    let mut out = vec![(
        "accuracy_of".to_string(),
        p.map(|p| p.1.to_string()).unwrap_or_default(),
    )];
    out.push((
        "truth_se_Y".to_string(),
        num(p.and_then(|p| p.0.measured_luminance.truth_standard_error_cd_m2)),
    ));
    /// A figure's column prefix, where it is in a point, and whether it is signed.
    type Figure = (&'static str, fn(&PointUncertainty) -> &PropagatedDifference, bool);
    let figures: [Figure; 4] = [
        ("dE00", |p| &p.de00, false),
        ("relative_dY", |p| &p.relative_dy, true),
        ("dx", |p| &p.dx, true),
        ("dy", |p| &p.dy, true),
    ];
    for (name, figure, signed) in figures {
        let d = p.map(|p| figure(p.0));
        if signed {
            out.push((
                format!("{name}_low95"),
                num(d.map(|d| d.stated_accuracy.interval_95.low)),
            ));
            out.push((
                format!("{name}_high95"),
                num(d.map(|d| d.stated_accuracy.interval_95.high)),
            ));
        } else {
            out.push((
                format!("{name}_null95_repeatability"),
                num(d.and_then(|d| d.null_95th_repeatability)),
            ));
            out.push((
                format!("{name}_null95_stated_accuracy"),
                num(d.and_then(|d| d.null_95th_stated_accuracy)),
            ));
        }
        out.push((format!("{name}_beyond_noise"), flag(d.map(|d| d.claims.beyond_noise))));
        out.push((
            format!("{name}_beyond_repeatability"),
            flag(d.map(|d| d.claims.beyond_repeatability)),
        ));
        out.push((
            format!("{name}_beyond_stated_accuracy"),
            flag(d.and_then(|d| d.claims.beyond_stated_accuracy)),
        ));
    }
    out
}

/// The MAT file of a scene's comparisons: one column vector per numeric
/// field and char matrices `target`, `coding` and `observer` (one row each),
/// so `table(cellstr(target), cellstr(coding), dE00, ...)` rebuilds the
/// table; then each row's uncertainty columns, named as in the CSV.
pub fn comparisons_mat(c: &SceneComparisons) -> Result<Vec<u8>, String> {
    let mut mat = MatFile::new();
    let internal = |e: String| e;
    let col = |f: fn(&ComparisonRow) -> f64| c.rows.iter().map(f).collect::<Vec<f64>>();
    mat.text_rows("target", &c.rows.iter().map(|r| r.target.clone()).collect::<Vec<_>>())
        .map_err(internal)?;
    mat.text_rows("coding", &c.rows.iter().map(|r| r.coding.clone()).collect::<Vec<_>>())
        .map_err(internal)?;
    // The observer of every XYZ and ΔE in the file.
    mat.text_rows("observer", &[c.observer.to_string()]).map_err(internal)?;
    type Field = (&'static str, fn(&ComparisonRow) -> f64);
    let fields: [Field; 14] = [
        ("measurement_id", |r| r.measurement_id as f64),
        ("render_id", |r| r.render_id as f64),
        ("measured_X", |r| r.measured_X),
        ("measured_Y", |r| r.measured_Y),
        ("measured_Z", |r| r.measured_Z),
        ("rendered_X", |r| r.rendered_X),
        ("rendered_Y", |r| r.rendered_Y),
        ("rendered_Z", |r| r.rendered_Z),
        ("rendered_Y_se", |r| r.rendered_Y_se),
        ("Y_ratio", |r| r.Y_ratio),
        ("xy_distance", |r| r.xy_distance),
        ("dE76", |r| r.dE76),
        ("dE00", |r| r.dE00),
        ("white_Y", |r| r.white_Y),
    ];
    for (name, f) in fields {
        mat.column(name, &col(f)).map_err(internal)?;
    }
    // Each row's uncertainty columns (NaN where not propagated or not
    // made; claims 1 or 0), named as in the CSV.
    let by_row = uncertainty_by_row(c);
    let per_row: Vec<Vec<(String, String)>> = c
        .rows
        .iter()
        .map(|r| uncertainty_columns(by_row.get(&r.id).copied()))
        .collect();
    for (k, (name, _)) in uncertainty_columns(None).iter().enumerate() {
        if name == "accuracy_of" {
            mat.text_rows(name, &per_row.iter().map(|cols| cols[k].1.clone()).collect::<Vec<_>>())
                .map_err(internal)?;
            continue;
        }
        let values: Vec<f64> = per_row
            .iter()
            .map(|cols| match cols[k].1.as_str() {
                "true" => 1.0,
                "false" => 0.0,
                v => v.parse().unwrap_or(f64::NAN),
            })
            .collect();
        mat.column(name, &values).map_err(internal)?;
    }
    Ok(mat.into_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use lightbooth_science::colorimetry::Observer;

    fn row() -> ComparisonRow {
        ComparisonRow {
            id: 7,
            measurement_id: 3,
            render_id: 2,
            scene: "white".into(),
            target: "centre, left".into(),
            coding: "nstep3".into(),
            observer: Observer::Cie1931,
            white_source: "scene file".into(),
            white_X: 95.0,
            white_Y: 100.0,
            white_Z: 108.0,
            measured_X: 30.0,
            measured_Y: 31.0,
            measured_Z: 32.0,
            rendered_X: 30.5,
            rendered_Y: 31.5,
            rendered_Z: 32.5,
            rendered_Y_se: 0.01,
            measured_Y_se: Some(0.02),
            Y_beyond_noise: None,
            Y_ratio: 31.5 / 31.0,
            xy_distance: 1e-3,
            dE76: 1.0,
            dE00: 0.8,
            created_at: 1.5e9,
        }
    }

    /// The CSV's stored columns are the row's fields as the JSON names
    /// them, each with the JSON's value: a field added to
    /// [`ComparisonRow`] and not to the CSV fails here.
    #[test]
    fn the_csv_has_every_field_of_the_json_row_with_its_value() {
        let c = SceneComparisons {
            scene: "white".into(),
            observer: Observer::Cie1931,
            codings: Vec::new(),
            rows: vec![row()],
        };
        let csv = comparisons_csv(&c).unwrap();
        let mut reader = csv::Reader::from_reader(csv.as_slice());
        let header: Vec<String> = reader.headers().unwrap().iter().map(str::to_string).collect();
        let record = reader.records().next().unwrap().unwrap();
        let json = serde_json::to_value(row()).unwrap();
        let json = json.as_object().unwrap();
        let mut stored: Vec<&str> = header[..json.len()].iter().map(String::as_str).collect();
        stored.sort_unstable();
        assert_eq!(stored, json.keys().map(String::as_str).collect::<Vec<_>>());
        for (name, value) in json {
            let k = header.iter().position(|h| h == name).unwrap();
            let expected = match value {
                serde_json::Value::String(s) => s.clone(),
                serde_json::Value::Null => String::new(),
                other => other.to_string(),
            };
            let got = &record[k];
            match (got.parse::<f64>(), expected.parse::<f64>()) {
                (Ok(a), Ok(b)) => assert_eq!(a, b, "{name}"),
                _ => assert_eq!(got, expected, "{name}"),
            }
        }
        // The uncertainty columns follow, empty where nothing was propagated.
        assert_eq!(header[json.len()], "accuracy_of");
        assert_eq!(&record[json.len()], "");
    }

    #[test]
    fn no_rows_no_header() {
        let c = SceneComparisons {
            scene: "white".into(),
            observer: Observer::Cie1931,
            codings: Vec::new(),
            rows: Vec::new(),
        };
        assert!(comparisons_csv(&c).unwrap().is_empty());
    }
}
