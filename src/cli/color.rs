//! `lightbooth color`: colorimetry of every spectrum column of a CSV file.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, ValueEnum};
use serde::Serialize;

use lightbooth::colorimetry::{ciede2000, delta_e76, xyz_from_radiance, xyz_relative, Lab, Observer, Xyz};
use lightbooth::spectrum::{table::SpectraTable, SpectralUnit};

#[derive(Args, Debug)]
pub struct ColorArgs {
    /// CSV file: first column `nm`, then one column per spectrum; or
    /// `builtin:NAME`, a table compiled into lightbooth (colorchecker_classic,
    /// munsell_matt, natural_reflectances, illuminants, …), from any folder.
    file: PathBuf,
    /// Column used as the CIELAB reference white (adds L* a* b*).
    #[arg(long)]
    white: Option<String>,
    /// Column every other column is compared with (adds ΔE*ab and ΔE00; needs --white).
    #[arg(long)]
    reference: Option<String>,
    /// Colour-matching functions (the observer): judd-vos-1978, cie-1931, cie-1964-10, cie-2015-2 or cie-2015-10.
    #[arg(long, visible_alias = "observer", default_value = "judd-vos-1978", value_parser = parse_observer)]
    cmf: Observer,
    /// What the columns hold: absolute spectral radiance W/(sr·m²·nm) (Y in cd/m²),
    /// spectral irradiance W/(m²·nm) (Y in lux), or reflectance (relative XYZ, white Y = 100).
    #[arg(long, value_enum, default_value_t = ColumnUnit::Radiance)]
    unit: ColumnUnit,
    /// With --unit reflectance: the illuminant (A, D65, F2, F11, E or FILE.csv[:COLUMN]).
    #[arg(long, default_value = "D65")]
    illuminant: String,
    /// One JSON array of objects instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum ColumnUnit {
    Radiance,
    Irradiance,
    Reflectance,
}

/// The table `file` names: `builtin:NAME`, or a CSV file; a file that is
/// not there says where it was looked for and which tables are built in.
fn read_table(file: &std::path::Path) -> anyhow::Result<SpectraTable> {
    use lightbooth::reference_data::{builtin_table, BUILTIN_TABLES};
    let builtins = || BUILTIN_TABLES.map(|(n, _)| format!("builtin:{n}")).join(", ");
    if let Some(name) = file.to_str().and_then(|f| f.strip_prefix("builtin:")) {
        return builtin_table(name)
            .ok_or_else(|| anyhow::anyhow!("no built-in table `{name}`: the built-in tables are {}", builtins()));
    }
    if !file.exists() {
        let here = std::env::current_dir()
            .map(|d| d.display().to_string())
            .unwrap_or_default();
        anyhow::bail!(
            "{}: no such file (looked in {here}); the tables of the manual's examples are built in: {}",
            file.display(),
            builtins()
        );
    }
    Ok(SpectraTable::read(file)?)
}

fn parse_observer(s: &str) -> Result<Observer, String> {
    s.parse()
}

/// One output row; fields not computed are left out of the JSON.
#[derive(Serialize)]
struct Row {
    name: String,
    /// The observer of X, Y, Z, x, y, u′, v′, L*a*b* and ΔE.
    observer: Observer,
    #[serde(rename = "X")]
    x_cap: f64,
    #[serde(rename = "Y")]
    y_cap: f64,
    #[serde(rename = "Z")]
    z_cap: f64,
    x: f64,
    y: f64,
    u: f64,
    v: f64,
    #[serde(rename = "L", skip_serializing_if = "Option::is_none")]
    l: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    a: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    b: Option<f64>,
    #[serde(rename = "dE76", skip_serializing_if = "Option::is_none")]
    de76: Option<f64>,
    #[serde(rename = "dE00", skip_serializing_if = "Option::is_none")]
    de00: Option<f64>,
}

pub fn run(args: ColorArgs) -> anyhow::Result<()> {
    let table = read_table(&args.file)?;
    if args.reference.is_some() && args.white.is_none() {
        anyhow::bail!("--reference needs --white: ΔE is computed in CIELAB, which needs a reference white column");
    }
    let source = table.source_name().to_string();
    let mut xyzs: Vec<(String, Xyz)> = Vec::with_capacity(table.len());
    match args.unit {
        ColumnUnit::Radiance | ColumnUnit::Irradiance => {
            let unit = match args.unit {
                ColumnUnit::Irradiance => SpectralUnit::SpectralIrradiance,
                _ => SpectralUnit::SpectralRadiance,
            };
            for (name, s) in table.spectra(unit)? {
                let xyz = xyz_from_radiance(&s, args.cmf).with_context(|| format!("{source}: column {name}"))?;
                xyzs.push((name, xyz));
            }
        }
        ColumnUnit::Reflectance => {
            let illuminant = super::load_illuminant(&args.illuminant)?
                .resample(table.grid())
                .with_context(|| format!("illuminant {} on the grid of {source}", args.illuminant))?;
            for (name, s) in table.spectra(SpectralUnit::Reflectance)? {
                let xyz =
                    xyz_relative(&s, &illuminant, args.cmf).with_context(|| format!("{source}: column {name}"))?;
                xyzs.push((name, xyz));
            }
        }
    }
    let find = |name: &str, flag: &str| {
        xyzs.iter().find(|(n, _)| n == name).map(|(_, x)| *x).with_context(|| {
            let names: Vec<&str> = xyzs.iter().map(|(n, _)| n.as_str()).collect();
            format!(
                "{flag} {name}: no such column in {source}; it has: {}",
                names.join(", ")
            )
        })
    };
    let white = args.white.as_deref().map(|w| find(w, "--white")).transpose()?;
    if let Some(w) = white {
        if w.x <= 0.0 || w.y <= 0.0 || w.z <= 0.0 {
            anyhow::bail!(
                "--white {}: the reference white must have positive X, Y and Z, got {w:?}",
                args.white.unwrap_or_default()
            );
        }
    }
    let reference = args.reference.as_deref().map(|r| find(r, "--reference")).transpose()?;

    let rows: Vec<Row> = xyzs
        .iter()
        .map(|(name, xyz)| {
            let xy = xyz.chromaticity();
            let uv = xyz.uv_prime();
            let lab = white.map(|w| Lab::from_xyz(*xyz, w));
            let ref_lab = reference.zip(white).map(|(r, w)| Lab::from_xyz(r, w));
            Row {
                name: name.clone(),
                observer: args.cmf,
                x_cap: xyz.x,
                y_cap: xyz.y,
                z_cap: xyz.z,
                x: xy.x,
                y: xy.y,
                u: uv.u,
                v: uv.v,
                l: lab.map(|l| l.l),
                a: lab.map(|l| l.a),
                b: lab.map(|l| l.b),
                de76: lab.zip(ref_lab).map(|(p, q)| delta_e76(p, q)),
                de00: lab.zip(ref_lab).map(|(p, q)| ciede2000(p, q)),
            }
        })
        .collect();

    if args.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    let mut header = format!(
        "{:<24} {:>12} {:>12} {:>12} {:>7} {:>7} {:>7} {:>7}",
        "name", "X", "Y", "Z", "x", "y", "u'", "v'"
    );
    if white.is_some() {
        header.push_str(&format!(" {:>8} {:>8} {:>8}", "L*", "a*", "b*"));
    }
    if reference.is_some() {
        header.push_str(&format!(" {:>8} {:>8}", "dE*ab", "dE00"));
    }
    println!("observer: {}", args.cmf);
    println!("{header}");
    for r in rows {
        let mut line = format!(
            "{:<24} {:>12.5} {:>12.5} {:>12.5} {:>7.4} {:>7.4} {:>7.4} {:>7.4}",
            r.name, r.x_cap, r.y_cap, r.z_cap, r.x, r.y, r.u, r.v
        );
        if let (Some(l), Some(a), Some(b)) = (r.l, r.a, r.b) {
            line.push_str(&format!(" {l:>8.3} {a:>8.3} {b:>8.3}"));
        }
        if let (Some(d76), Some(d00)) = (r.de76, r.de00) {
            line.push_str(&format!(" {d76:>8.3} {d00:>8.3}"));
        }
        println!("{line}");
    }
    Ok(())
}
