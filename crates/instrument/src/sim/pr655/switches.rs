//! The behaviours of the PR-655/PR-670 that the protocol sheet
//! (`docs/src/instruments/pr655-670-protocol.md` section 13) leaves open or
//! the sources disagree on, each a switch of the simulator, with the
//! defaults a real unit is known to accept.

use crate::pr655::protocol::{LineStyle, StatusStyle};
use crate::pr655::Model;

/// What a stray CR or LF right after `PHOTO` produces (13.2, 12.3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StrayTerminator {
    #[default]
    Ignore,
    /// An empty CR LF line.
    EmptyLine,
    /// `-1000` (illegal command).
    IllegalCommand,
}

/// What `D⟨code⟩` answers after a failed measurement (12.9, 13.9).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AfterFailure {
    /// The failed measurement's status alone.
    #[default]
    Error,
    /// The last good measurement's data, as the PR-650 does.
    Stale,
    /// `-2000`: no such data.
    NoData,
}

/// The status of an `SS1` (auto sync) measurement of a source the unit
/// cannot sync to (13.9 lists −1 / −10: PTB's `PR670measspd` handles both as
/// a sync failure; the status table reads −10 "cannot auto-sync to the light
/// source" and −1 "light source not constant").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SyncFailure {
    /// −10: cannot auto-sync to the light source.
    #[default]
    CannotAutoSync,
    /// −1: light source not constant.
    NotConstant,
}

impl SyncFailure {
    /// The status the measurement ends with.
    pub fn status(self) -> i32 {
        match self {
            SyncFailure::CannotAutoSync => -10,
            SyncFailure::NotConstant => -1,
        }
    }
}

/// The behaviours of section 13 the sources disagree on, each selectable.
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Pr655Switches {
    /// 13.1: which model (grid, exposure range, PR-670-only setup commands).
    pub model: Model,
    /// 13.2: `PHOTO` letters count only when each arrives in its own read
    /// (off by default: a real unit answers PsychoPy, whose letters arrive
    /// with no pause between them, §1).
    pub strict_photo: bool,
    /// 13.2: time from the last `O` to the banner, ms of wall time (not
    /// scaled by speed, so a late banner, 13.10, is late at any speed).
    pub banner_latency_ms: u64,
    /// 13.10: no banner at all (the unit does not answer `PHOTO`).
    pub no_banner: bool,
    /// 13.2: a stray CR/LF after `PHOTO`.
    pub stray_terminator: StrayTerminator,
    /// 13.2: a second `PHOTO` while in remote mode gets no banner (the PR-670's way).
    pub photo_only_once: bool,
    /// 13.4: LF ends a command as well as CR (on by default: a real unit
    /// answers PsychoPy's LF-terminated commands, §1).
    pub accept_lf: bool,
    /// 13.4: lower-case commands are accepted.
    pub case_insensitive: bool,
    /// 13.5: `00000`/`-0008` or `0000`/`-8`.
    pub status_style: StatusStyle,
    /// 13.8: the 16th byte of a spectral line.
    pub line_style: LineStyle,
    /// 13.9: `D` after a failed measurement.
    pub after_failure: AfterFailure,
    /// The status of an [`crate::sim::FaultKind::ErrorCode`] measurement (13.9: −8, −2, −1, −10, −12).
    pub error_status: i32,
    /// 13.9: what an `SS1` measurement of an unsyncable source ends with.
    pub sync_failure: SyncFailure,
    /// 13.7: the time auto sync (`SS1`) spends finding the source's
    /// frequency before each measurement, ms at speed 1. No source gives it
    /// (9: durations are undocumented); the default, 1000 ms, is a simulator
    /// choice: twenty periods at the slowest syncable frequency (20 Hz, 7).
    pub sync_detection_ms: u64,
    /// What `D114` answers.
    pub firmware: String,
}

impl Default for Pr655Switches {
    fn default() -> Pr655Switches {
        Pr655Switches::for_model(Model::Pr655)
    }
}

impl Pr655Switches {
    /// The defaults for `model` (a PR-670 answers `PHOTO` once): section
    /// 13's first choices, but `PHOTO` in any pacing and LF-terminated
    /// commands accepted, as real units accept them (section 1).
    pub fn for_model(model: Model) -> Pr655Switches {
        Pr655Switches {
            model,
            strict_photo: false,
            banner_latency_ms: 300,
            no_banner: false,
            stray_terminator: StrayTerminator::Ignore,
            photo_only_once: model == Model::Pr670,
            accept_lf: true,
            case_insensitive: false,
            status_style: StatusStyle::FiveDigits,
            line_style: LineStyle::TrailingSpace,
            after_failure: AfterFailure::Error,
            error_status: -8,
            sync_failure: SyncFailure::CannotAutoSync,
            sync_detection_ms: 1000,
            firmware: "2.22D".into(),
        }
    }
}
