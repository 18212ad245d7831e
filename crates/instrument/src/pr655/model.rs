//! The two models that speak the PR-655/PR-670 protocol, and what sets
//! them apart: the name `D111` answers, the native spectral grid and the
//! fixed exposures each takes (`docs/src/instruments/pr655-670-protocol.md`
//! sections 5 and 8).

use lightbooth_science::spectrum::Grid;

/// The two models that speak this protocol.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Model {
    Pr655,
    Pr670,
}

impl Model {
    /// The name `D111` answers ("PR-655", "PR-670").
    pub fn name(self) -> &'static str {
        match self {
            Model::Pr655 => "PR-655",
            Model::Pr670 => "PR-670",
        }
    }

    /// The native spectral grid (section 8, \[C\]): 380–780 nm at 4 nm (101
    /// points) on the PR-655, at 2 nm (201 points) on the PR-670.
    pub fn grid(self) -> Grid {
        match self {
            Model::Pr655 => Grid::uniform(380.0, 4.0, 101),
            Model::Pr670 => Grid::uniform(380.0, 2.0, 201),
        }
    }

    /// The model whose `D111` reply this is, if either.
    pub fn from_name(name: &str) -> Option<Model> {
        match name.trim().to_ascii_uppercase().replace(' ', "").as_str() {
            "PR-655" | "PR655" => Some(Model::Pr655),
            "PR-670" | "PR670" => Some(Model::Pr670),
            _ => None,
        }
    }

    /// Fixed exposure times the model takes, in ms (section 5, \[M\]): the
    /// PR-655 3–6000, the PR-670 6–6000 (6–30000 in extended sensitivity,
    /// which lightbooth does not set).
    pub fn exposure_range_ms(self) -> std::ops::RangeInclusive<u32> {
        match self {
            Model::Pr655 => 3..=6000,
            Model::Pr670 => 6..=6000,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_model_knows_its_name_grid_and_exposures() {
        for model in [Model::Pr655, Model::Pr670] {
            assert_eq!(Model::from_name(model.name()), Some(model));
        }
        assert_eq!(Model::from_name(" pr 670 "), Some(Model::Pr670));
        assert_eq!(Model::from_name("PR-650"), None);
        assert_eq!((Model::Pr655.grid().len(), Model::Pr670.grid().len()), (101, 201));
        assert_eq!(Model::Pr670.exposure_range_ms(), 6..=6000);
    }
}
