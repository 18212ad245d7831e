//! The retry-and-average loop, above every driver: take samples one at a
//! time through [`Spectroradiometer::take_sample`] until the requested number
//! of good ones is in, within the retries the instrument's settings allow.
//!
//! - Every sample is handed to the caller as it is taken (the daemon stores
//!   it before the next one), bad codes included; bad samples never enter
//!   the mean ([`average_samples`]).
//! - After a bad code the driver may react ([`Spectroradiometer::after_bad_sample`]:
//!   the PR-650 turns sync off on codes 07/08).
//! - An attempt lost to a link fault (no reply, a cut-off or garbled report)
//!   yields no sample, since no quality code arrived; it counts against the
//!   retries, and the driver resynchronises before its next command.
//! - Anything else (a closed port, a cancel, bad settings) ends the series at once.
//!
//! A driver only knows how to take one sample; what "enough good samples"
//! means is decided here, the same for every model.

use tokio_util::sync::CancellationToken;

use super::{average_samples, AveragedMeasurement, InstrumentError, QualityCode, Sample, Spectroradiometer};

/// Why one sample could not be taken (the last reason is reported if the series fails).
enum Failure {
    Link(InstrumentError),
    Code(QualityCode),
}

/// Takes `n` good samples (at least one) with at most the instrument's
/// `retries` extra attempts, and averages them. See the module doc.
pub fn measure_averaged(
    instrument: &mut dyn Spectroradiometer,
    n: usize,
    cancel: &CancellationToken,
    on_sample: &mut dyn FnMut(&Sample),
) -> Result<AveragedMeasurement, InstrumentError> {
    let n = n.max(1);
    let capabilities = instrument.capabilities();
    if n > capabilities.max_samples {
        return Err(InstrumentError::Settings(format!(
            "{n} samples asked for; the {} averages at most {} per measurement",
            capabilities.model, capabilities.max_samples
        )));
    }
    let model = capabilities.model;
    let max_attempts = n + capabilities.retries;
    tracing::info!(model, samples = n, max_attempts, "averaged measurement");
    let mut samples: Vec<Sample> = Vec::with_capacity(n);
    let mut good = 0;
    let mut last_failure: Option<Failure> = None;
    for attempt in 1..=max_attempts {
        if good == n {
            break;
        }
        if cancel.is_cancelled() {
            return Err(InstrumentError::Cancelled);
        }
        match instrument.take_sample(samples.len(), cancel) {
            Ok(sample) => {
                on_sample(&sample);
                if sample.code.is_ok() {
                    good += 1;
                } else {
                    tracing::warn!(model, attempt, code = %sample.code, "bad sample, not averaged");
                    instrument.after_bad_sample(&sample.code, cancel)?;
                    last_failure = Some(Failure::Code(sample.code.clone()));
                }
                samples.push(sample);
            }
            Err(e) if e.is_retryable_link_fault() => {
                tracing::warn!(model, attempt, error = %e, "sample lost to a link fault");
                last_failure = Some(Failure::Link(e));
            }
            Err(e) => return Err(e),
        }
    }
    if good < n {
        return Err(match last_failure {
            Some(Failure::Link(e)) => e,
            Some(Failure::Code(code)) => InstrumentError::Quality {
                hint: instrument.quality_hint(code.kind),
                code: code.code,
                message: code.message,
                good,
                needed: n,
            },
            None => InstrumentError::Cancelled,
        });
    }
    average_samples(instrument.info().clone(), instrument.capabilities().reading, samples).map_err(|detail| {
        InstrumentError::Protocol {
            command: "the readings of this series".into(),
            detail,
        }
    })
}

#[cfg(test)]
mod tests {
    //! The loop against a scripted instrument: it must work for any driver,
    //! not only the PR-650 (signed codes, its own hint, its own limits).
    use std::collections::VecDeque;
    use std::time::SystemTime;

    use super::*;
    use crate::{Capabilities, Identity, QualityKind};
    use lightbooth_science::spectrum::{Grid, SpectralUnit, Spectrum};

    /// What the scripted instrument answers to each `take_sample`.
    enum Step {
        Good(f64),
        Bad(i32),
        LinkFault,
    }

    struct Scripted {
        identity: Identity,
        steps: VecDeque<Step>,
        reactions: Vec<i32>,
    }

    impl Scripted {
        fn new(retries: usize, steps: Vec<Step>) -> Scripted {
            let grid = Grid::uniform(380.0, 2.0, 201);
            let capabilities = Capabilities {
                model: "scripted",
                reading: crate::Reading::Spectrum,
                native_grid: grid,
                max_samples: 3,
                default_samples: 2,
                retries,
                stated_accuracy: crate::StatedAccuracy::unstated("a test double"),
            };
            Scripted {
                identity: Identity::new(capabilities, |_| "the scripted hint"),
                steps: steps.into(),
                reactions: Vec::new(),
            }
        }
    }

    impl Spectroradiometer for Scripted {
        fn identity(&self) -> &Identity {
            &self.identity
        }
        fn take_sample(&mut self, index: usize, _cancel: &CancellationToken) -> Result<Sample, InstrumentError> {
            let (code, radiance) = match self.steps.pop_front().expect("the loop asked for one sample too many") {
                Step::Good(v) => (
                    QualityCode {
                        code: 0,
                        kind: QualityKind::Ok,
                        message: "ok".into(),
                    },
                    Some(
                        Spectrum::constant(self.identity.info.grid.clone(), SpectralUnit::SpectralRadiance, v).unwrap(),
                    ),
                ),
                Step::Bad(code) => (
                    QualityCode {
                        code,
                        kind: QualityKind::Overload,
                        message: "overload".into(),
                    },
                    None,
                ),
                Step::LinkFault => {
                    return Err(InstrumentError::NoReply {
                        command: "M5".into(),
                        waited_ms: 10,
                    })
                }
            };
            Ok(Sample {
                index,
                time: SystemTime::now(),
                code,
                radiance,
                luminance: None,
                instrument_xyz: None,
            })
        }
        fn after_bad_sample(&mut self, code: &QualityCode, _cancel: &CancellationToken) -> Result<(), InstrumentError> {
            self.reactions.push(code.code);
            Ok(())
        }
    }

    #[test]
    fn bad_codes_and_link_faults_use_up_retries_but_never_enter_the_mean() {
        let mut instrument = Scripted::new(
            2,
            vec![Step::Good(1.0), Step::Bad(-1003), Step::LinkFault, Step::Good(3.0)],
        );
        let mut seen = Vec::new();
        let m = measure_averaged(&mut instrument, 2, &CancellationToken::new(), &mut |s| {
            seen.push(s.code.code)
        })
        .unwrap();
        assert_eq!(
            seen,
            vec![0, -1003, 0],
            "every sample reaches the caller, bad codes too"
        );
        assert_eq!(m.samples.len(), 3);
        assert!(m
            .mean
            .as_ref()
            .unwrap()
            .values()
            .iter()
            .all(|v| (v - 2.0).abs() < 1e-12));
        assert_eq!(
            m.mean.as_ref().unwrap().grid().wavelengths().len(),
            201,
            "the driver's own grid is kept"
        );
        assert_eq!(instrument.reactions, vec![-1003]);
    }

    #[test]
    fn too_few_good_samples_fail_with_the_drivers_hint() {
        let mut instrument = Scripted::new(1, vec![Step::Good(1.0), Step::Bad(-1003), Step::Bad(-1003)]);
        let e = measure_averaged(&mut instrument, 2, &CancellationToken::new(), &mut |_| {}).unwrap_err();
        match e {
            InstrumentError::Quality {
                code,
                good,
                needed,
                hint,
                ..
            } => assert_eq!((code, good, needed, hint), (-1003, 1, 2, "the scripted hint")),
            other => panic!("expected a quality error, got {other}"),
        }
        assert!(instrument.steps.is_empty(), "n + retries attempts, no more");
    }

    #[test]
    fn more_samples_than_the_model_allows_is_refused_before_any_is_taken() {
        let mut instrument = Scripted::new(0, vec![]);
        let e = measure_averaged(&mut instrument, 4, &CancellationToken::new(), &mut |_| {}).unwrap_err();
        assert!(e.to_string().contains("at most 3"), "{e}");
    }
}
