//! `lightbooth analyze …`: analyses of spectra alone.

use clap::{Args, Subcommand};

use lightbooth::nstep::nstep_error;
use lightbooth::reference_data::{reflectances, ReflectanceSet};
use lightbooth::spectrum::{table::SpectraTable, Grid, SpectralUnit, Spectrum};

#[derive(Subcommand, Debug)]
pub enum AnalyzeCommand {
    /// The study's Fig. 7: N-step reconstruction error of colour signals for N = 1…81,
    /// normalised so N = 1 is 1.0.
    NstepError(NstepErrorArgs),
}

#[derive(Args, Debug)]
pub struct NstepErrorArgs {
    /// colorchecker, munsell, natural, or a CSV of reflectances (380–780 nm at least).
    #[arg(long)]
    reflectances: String,
    /// A, D65, F2, F11, E, or FILE.csv[:COLUMN] (relative power, 380–780 nm at least).
    #[arg(long)]
    illuminant: String,
    /// `{"n":[…],"error":[…]}` instead of a table.
    #[arg(long)]
    json: bool,
}

pub fn run(cmd: AnalyzeCommand) -> anyhow::Result<()> {
    match cmd {
        AnalyzeCommand::NstepError(args) => nstep_error_cmd(args),
    }
}

fn nstep_error_cmd(args: NstepErrorArgs) -> anyhow::Result<()> {
    let grid = Grid::analysis();
    let refl: Vec<Spectrum> = match args.reflectances.parse::<ReflectanceSet>() {
        Ok(set) => reflectances(set).iter().map(|(_, s)| s.clone()).collect(),
        Err(_) if args.reflectances.ends_with(".csv") => {
            let table = SpectraTable::read(std::path::Path::new(&args.reflectances))?;
            table.require_range(380.0, 780.0)?;
            table
                .spectra(SpectralUnit::Reflectance)?
                .into_iter()
                .map(|(_, s)| s.resample(&grid))
                .collect::<Result<_, _>>()?
        }
        Err(e) => anyhow::bail!("{e}, or a FILE.csv"),
    };
    let illuminant = super::load_illuminant(&args.illuminant)?;
    if !illuminant.grid().covers(380.0, 780.0) {
        anyhow::bail!(
            "illuminant {}: its grid {} does not cover 380–780 nm",
            args.illuminant,
            illuminant.grid()
        );
    }
    let illuminant = illuminant.resample(&grid)?;
    let curve = nstep_error(&refl, &illuminant).map_err(anyhow::Error::msg)?;
    if args.json {
        println!("{}", serde_json::to_string(&curve)?);
    } else {
        println!("{:>3} {:>10}", "N", "error");
        for (n, e) in curve.n.iter().zip(&curve.error) {
            println!("{n:>3} {e:>10.6}");
        }
    }
    Ok(())
}
