//! One session with an instrument over its serial port, the same for every
//! model: flush, send a command and read its whole reply within the right
//! timeouts; remember when a fault left the line out of step; and
//! resynchronise (drain, ping, drain) before the next command, so a session
//! survives a garbled, cut-off or cancelled reply. What the commands are,
//! how long their replies are and what they mean stays with each model's
//! driver ([`crate::pr650::driver`], [`crate::pr655::driver`]),
//! which describes its commands to the session through [`Request`].
//!
//! The practice both protocol sheets share (`docs/src/instruments/pr650-protocol.md`
//! §6, `pr655-670-protocol.md` section 11):
//! - the input buffer is flushed before every command;
//! - silence to an ordinary command means nobody is listening (off, local
//!   mode, wrong port): [`InstrumentError::NoReply`]; silence after a
//!   measuring command may just be a long measurement: a
//!   [`WaitPhase::FirstByte`] timeout;
//! - after a link fault or a cancel the next command first resynchronises:
//!   drain whatever the unit still sends, ping it until its answer comes back
//!   (skipping late lines), drain again. A ping met by silence for the
//!   command timeout means the unit stopped answering:
//!   [`InstrumentError::Unresponsive`], naming the fault before it. The ping
//!   waits a whole measurement only when the unit may still be measuring.

use std::fmt::Display;
use std::time::Duration;

use super::serial::{LinkSettings, SerialLink};
use crate::{Identity, InstrumentError, InstrumentInfo, WaitPhase};
use tokio_util::sync::CancellationToken;

/// A command as the session sends it; each model's command type says this
/// of itself.
pub trait Request {
    /// The command as typed, without terminator (what the log and errors show).
    fn text(&self) -> String;
    /// True when the unit measures before it answers (`M0`, `M5`): its
    /// silence is then a long measurement, not a dead unit, and a cancel
    /// leaves the unit measuring.
    fn measures(&self) -> bool;
    /// How many non-empty lines the whole reply has, given its first line
    /// and the length of the unit's spectral grid.
    fn reply_lines(&self, first_line: &[u8], grid_len: usize) -> usize;
}

/// A session's timeouts and waits, from the model's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SessionTiming {
    /// First byte of the reply to an ordinary command, and of the
    /// resynchronisation ping: how long a dead unit goes unnoticed.
    pub command: Duration,
    /// A whole measurement: the first byte after a measuring command, and
    /// the ping's wait while the unit may still be measuring.
    pub measure: Duration,
    /// Longest silence inside a reply before it counts as cut off.
    pub gap: Duration,
    /// How long the line must be quiet to end a drain.
    pub resync_quiet: Duration,
    /// Whether a measuring command whose reply timed out (not only one that
    /// was cancelled) may leave the unit measuring, so the next ping waits a
    /// whole measurement. The PR-655/670's driver says yes; the PR-650's has
    /// always counted only a cancel.
    pub measuring_after_timeout: bool,
}

/// Whether a line of the unit's is the answer to the ping.
pub type IsAnswer = Box<dyn Fn(&[u8]) -> bool + Send>;

/// How the session asks whether the unit is still there and in step: a
/// harmless command, and the line that answers it.
pub struct Ping {
    /// The command as typed, without terminator (`B1`, `D111`).
    pub command: String,
    /// True for the ping's answer; other lines (a late report) are skipped.
    pub is_answer: IsAnswer,
}

/// An open session with one instrument: its serial port, what the unit
/// said it is, and whether the line is in step.
pub struct Session {
    link: SerialLink,
    identity: Identity,
    timing: SessionTiming,
    ping: Ping,
    /// Set after a link fault or a cancel: the unit may still be measuring or
    /// sending, so the next command must resynchronise first.
    needs_resync: bool,
    /// Set when a measuring command was cancelled (or, per
    /// [`SessionTiming::measuring_after_timeout`], timed out): the unit may go
    /// on measuring, so the resynchronisation ping may wait that long.
    may_be_measuring: bool,
    /// The command and error of the exchange that last failed, for the report
    /// if the unit then stops answering.
    last_fault: Option<(String, String)>,
}

impl Session {
    /// Opens `port` with `link`'s settings for a unit taken to be
    /// `identity.info` until it says more about itself ([`Session::info_mut`]).
    pub fn open(
        port: &str,
        link: &LinkSettings,
        timing: SessionTiming,
        identity: Identity,
        ping: Ping,
    ) -> Result<Session, InstrumentError> {
        Ok(Session {
            link: SerialLink::open(port, link)?,
            identity,
            timing,
            ping,
            needs_resync: false,
            may_be_measuring: false,
            last_fault: None,
        })
    }

    /// What the unit is, as far as the session knows.
    pub fn info(&self) -> &InstrumentInfo {
        &self.identity.info
    }

    /// What the unit is and can do, as [`crate::Spectroradiometer::identity`] reports it.
    pub fn identity(&self) -> &Identity {
        &self.identity
    }

    /// For the driver to fill in what the unit reports (serial, firmware, grid).
    pub fn info_mut(&mut self) -> &mut InstrumentInfo {
        &mut self.identity.info
    }

    pub fn timing(&self) -> &SessionTiming {
        &self.timing
    }

    /// The port itself, for what is not a command and its reply (the
    /// PR-655's `PHOTO` and banner, its closing `Q`).
    pub fn link(&mut self) -> &mut SerialLink {
        &mut self.link
    }

    /// Reads and discards until the line has been quiet for the resync quiet
    /// time, or the command timeout has passed.
    pub fn drain(&mut self) -> Result<usize, InstrumentError> {
        self.link
            .drain_until_quiet(self.timing.resync_quiet, self.timing.command)
    }

    /// Flush, send, read: one command and its whole reply, its first byte
    /// awaited for `first_byte_timeout`. A link fault or a cancel marks the
    /// session for resynchronisation.
    pub fn exchange(
        &mut self,
        command: &dyn Request,
        first_byte_timeout: Duration,
        cancel: &CancellationToken,
    ) -> Result<Vec<u8>, InstrumentError> {
        let text = command.text();
        let grid_len = self.identity.info.grid.len();
        let gap = self.timing.gap;
        let model = self.identity.info.model.clone();
        let result = (|| {
            self.link.flush_input()?;
            tracing::debug!(command = %text, "→ {model}");
            self.link.send(&text)?;
            self.link.read_reply(
                &text,
                &|first| command.reply_lines(first, grid_len),
                first_byte_timeout,
                gap,
                cancel,
            )
        })();
        let measures = command.measures();
        let result = match result {
            Err(InstrumentError::Timeout {
                command,
                phase: WaitPhase::FirstByte,
                waited_ms,
            }) if !measures => Err(InstrumentError::NoReply { command, waited_ms }),
            other => other,
        };
        match &result {
            Ok(reply) => tracing::debug!(command = %text, bytes = reply.len(), "← {model}"),
            Err(e) => {
                tracing::debug!(command = %text, error = %e, "{model} exchange failed");
                if e.is_retryable_link_fault() || matches!(e, InstrumentError::Cancelled) {
                    self.needs_resync = true;
                    self.last_fault = Some((text.clone(), e.to_string()));
                }
                let cut_short = match e {
                    InstrumentError::Cancelled => true,
                    InstrumentError::Timeout { .. } => self.timing.measuring_after_timeout,
                    _ => false,
                };
                if measures && cut_short {
                    self.may_be_measuring = true;
                }
            }
        }
        result
    }

    /// The start of every sample: resynchronise if a fault left the line out
    /// of step, then send the measuring `command` (`M0`, `M5`) and wait up
    /// to a whole measurement for its reply.
    pub fn measure(&mut self, command: &dyn Request, cancel: &CancellationToken) -> Result<Vec<u8>, InstrumentError> {
        self.resync_if_needed(cancel)?;
        self.exchange(command, self.timing.measure, cancel)
    }

    /// An ordinary command (first byte within the command timeout) and its
    /// reply as `parse` reads it. A reply that does not parse is a
    /// [`Session::protocol_error`]: the error names the command, and the
    /// line is out of step.
    pub fn query<T, E: Display>(
        &mut self,
        command: &dyn Request,
        cancel: &CancellationToken,
        parse: impl FnOnce(&[u8]) -> Result<T, E>,
    ) -> Result<T, InstrumentError> {
        let reply = self.exchange(command, self.timing.command, cancel)?;
        parse(&reply).map_err(|e| self.protocol_error(&command.text(), &e))
    }

    /// A reply to `command` that arrived whole but does not parse: a
    /// [`InstrumentError::Protocol`] error, and the line is out of step.
    pub fn protocol_error(&mut self, command: &str, detail: &dyn Display) -> InstrumentError {
        self.needs_resync = true;
        let e = InstrumentError::Protocol {
            command: command.to_string(),
            detail: detail.to_string(),
        };
        self.last_fault = Some((command.to_string(), e.to_string()));
        e
    }

    /// A fault outside [`Session::exchange`] (a driver's own read of a
    /// reply's later line): the line is out of step, and with
    /// `may_be_measuring` the next ping waits a whole measurement.
    pub fn mark_out_of_step(&mut self, command: &str, error: &InstrumentError, may_be_measuring: bool) {
        self.needs_resync = true;
        self.may_be_measuring |= may_be_measuring;
        self.last_fault = Some((command.to_string(), error.to_string()));
    }

    /// True when a fault left the line out of step.
    pub fn needs_resync(&self) -> bool {
        self.needs_resync
    }

    /// The unit has just answered as it should (a handshake): the line is in step.
    pub fn in_step(&mut self) {
        self.needs_resync = false;
        self.may_be_measuring = false;
        self.last_fault = None;
    }

    /// [`Session::resync`] when a fault left the line out of step.
    pub fn resync_if_needed(&mut self, cancel: &CancellationToken) -> Result<(), InstrumentError> {
        if self.needs_resync {
            self.resync(cancel)?;
        }
        Ok(())
    }

    /// After a fault or cancel: wait out whatever the unit is still sending
    /// (a late report, a cancelled measurement that finishes and answers),
    /// ping it until its answer comes back, then drain again. A ping met by
    /// silence for the command timeout (a whole measurement while the unit
    /// may still be measuring) is [`InstrumentError::Unresponsive`].
    pub fn resync(&mut self, cancel: &CancellationToken) -> Result<(), InstrumentError> {
        let model = self.identity.info.model.clone();
        tracing::info!("{model}: resynchronising");
        self.drain()?;
        self.link.flush_input()?;
        let ping = self.ping.command.clone();
        tracing::debug!(command = %ping, "→ {model} (resync)");
        self.link.send(&ping)?;
        // Skip lines (a late report, a late measurement's answer) until the
        // ping's, for up to a whole measurement while bytes keep coming;
        // silence ends the wait sooner unless the unit may still be measuring.
        let silence = if self.may_be_measuring {
            self.timing.measure
        } else {
            self.timing.command
        };
        match self
            .link
            .read_until_line(&ping, &*self.ping.is_answer, silence, self.timing.measure, cancel)
        {
            Ok(()) => {}
            Err(InstrumentError::Timeout {
                command,
                phase: WaitPhase::FirstByte,
                waited_ms,
            }) => {
                let (after, reason) = self
                    .last_fault
                    .clone()
                    .unwrap_or_else(|| ("?".into(), "an earlier fault".into()));
                tracing::warn!(
                    after,
                    reason,
                    waited_ms,
                    "{model}: no reply to the resynchronisation ping"
                );
                return Err(InstrumentError::Unresponsive {
                    after,
                    reason,
                    command,
                    waited_ms,
                });
            }
            Err(e) => return Err(e),
        }
        // The ping's own answer may follow a late one.
        self.drain()?;
        self.in_step();
        tracing::info!("{model}: back in step");
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    //! The session against a scripted far end on a real pseudo-terminal.

    use std::io::{Read, Write};
    use std::thread::JoinHandle;
    use std::time::Instant;

    use serialport::{SerialPort, TTYPort};

    use super::*;
    use crate::link::lines::Terminator;
    use crate::Capabilities;
    use lightbooth_science::spectrum::Grid;

    /// A command of a test's making.
    struct Cmd {
        text: &'static str,
        measures: bool,
        lines: usize,
    }

    impl Request for Cmd {
        fn text(&self) -> String {
            self.text.into()
        }
        fn measures(&self) -> bool {
            self.measures
        }
        fn reply_lines(&self, _first_line: &[u8], _grid_len: usize) -> usize {
            self.lines
        }
    }

    const B1: Cmd = Cmd {
        text: "B1",
        measures: false,
        lines: 1,
    };
    const D5: Cmd = Cmd {
        text: "D5",
        measures: false,
        lines: 3,
    };
    const M0: Cmd = Cmd {
        text: "M0",
        measures: true,
        lines: 1,
    };

    /// The instrument's end of the pty, driven by a test's script.
    struct FarEnd {
        port: TTYPort,
        /// Every byte the host sent, in order.
        heard: Vec<u8>,
    }

    impl FarEnd {
        /// The next command line the host sends (up to its LF), within `within`.
        fn command(&mut self, within: Duration) -> Option<String> {
            let start = Instant::now();
            let mut line = Vec::new();
            let mut byte = [0u8; 1];
            while start.elapsed() < within {
                match self.port.read(&mut byte) {
                    Ok(1) => {
                        self.heard.push(byte[0]);
                        if byte[0] == b'\n' {
                            return Some(String::from_utf8_lossy(&line).into_owned());
                        }
                        line.push(byte[0]);
                    }
                    _ => continue,
                }
            }
            None
        }

        fn say(&mut self, bytes: &[u8]) {
            self.port.write_all(bytes).unwrap();
            self.port.flush().unwrap();
        }
    }

    fn timing(command_ms: u64, measure_ms: u64) -> SessionTiming {
        SessionTiming {
            command: Duration::from_millis(command_ms),
            measure: Duration::from_millis(measure_ms),
            gap: Duration::from_millis(400),
            resync_quiet: Duration::from_millis(100),
            measuring_after_timeout: false,
        }
    }

    /// A session on a fresh pty whose far end runs `script`, which returns what it heard.
    fn session_with(
        timing: SessionTiming,
        script: impl FnOnce(&mut FarEnd) + Send + 'static,
    ) -> (Session, JoinHandle<FarEnd>, TTYPort) {
        let (mut master, slave) = TTYPort::pair().expect("a pty pair");
        master.set_timeout(Duration::from_millis(10)).unwrap();
        let path = slave.name().expect("the pty's device name");
        let link = LinkSettings {
            terminator: Terminator::Lf,
            ..LinkSettings::default()
        };
        let capabilities = Capabilities {
            model: "PR-650",
            reading: crate::Reading::Spectrum,
            native_grid: Grid::pr650(),
            max_samples: 99,
            default_samples: 1,
            retries: 0,
            stated_accuracy: crate::StatedAccuracy::unstated("a test double"),
        };
        let identity = Identity::new(capabilities, |_| "");
        let ping = Ping {
            command: "B1".into(),
            is_answer: Box::new(|line| line.trim_ascii() == b"000"),
        };
        let session = Session::open(&path, &link, timing, identity, ping).expect("the session opens the pty");
        let far = std::thread::spawn(move || {
            let mut far = FarEnd {
                port: master,
                heard: Vec::new(),
            };
            script(&mut far);
            // Handed back, not dropped: the master end stays open (a closed
            // master hangs the line up) until the test has read all.
            far
        });
        // The slave end stays open with the test, so the pty never hangs up under the session.
        (session, far, slave)
    }

    #[test]
    fn an_exchange_flushes_stale_input_sends_the_command_and_reads_its_whole_reply() {
        let (mut session, far, _keep) = session_with(timing(1000, 5000), |far| {
            far.say(b"00,0\r\n2.8"); // a stale partial report, before the command
            let command = far.command(Duration::from_secs(5));
            assert_eq!(command.as_deref(), Some("D5"));
            // The reply, paused mid-way for less than the gap, then bytes past it.
            far.say(b"00,0\r\n1.000E-03\r\n");
            std::thread::sleep(Duration::from_millis(250));
            far.say(b"0380.,1.203E-05\r\nextra");
        });
        std::thread::sleep(Duration::from_millis(200)); // the stale bytes arrive first
        let reply = session
            .exchange(&D5, Duration::from_secs(1), &CancellationToken::new())
            .unwrap();
        assert_eq!(reply, b"00,0\r\n1.000E-03\r\n0380.,1.203E-05\r\n");
        assert!(!session.needs_resync());
        assert_eq!(
            far.join().unwrap().heard,
            b"D5\n",
            "the command and its terminator, nothing else"
        );
    }

    #[test]
    fn silence_is_no_reply_to_a_command_but_a_timeout_after_a_measuring_one() {
        let (mut session, far, _keep) = session_with(timing(300, 5000), |far| {
            let _ = far.command(Duration::from_secs(3));
            let _ = far.command(Duration::from_secs(3));
        });
        let start = Instant::now();
        let e = session
            .exchange(&B1, Duration::from_millis(300), &CancellationToken::new())
            .unwrap_err();
        assert!(
            matches!(&e, InstrumentError::NoReply { command, waited_ms } if command == "B1" && *waited_ms >= 300),
            "{e:?}"
        );
        assert!(start.elapsed() < Duration::from_secs(2));
        assert!(session.needs_resync(), "a fault puts the line out of step");
        let e = session
            .exchange(&M0, Duration::from_millis(300), &CancellationToken::new())
            .unwrap_err();
        assert!(
            matches!(&e, InstrumentError::Timeout { command, phase: WaitPhase::FirstByte, .. } if command == "M0"),
            "{e:?}"
        );
        assert_eq!(far.join().unwrap().heard, b"B1\nM0\n");
    }

    #[test]
    fn a_cut_off_reply_is_truncated_and_resync_skips_garbage_until_the_ping_is_answered() {
        let (mut session, far, _keep) = session_with(timing(1000, 5000), |far| {
            assert_eq!(far.command(Duration::from_secs(5)).as_deref(), Some("D5"));
            far.say(b"00,0\r\n1.0"); // then silence: cut off
            assert_eq!(far.command(Duration::from_secs(5)).as_deref(), Some("B1"));
            far.say(b"0380.,1.2#3E-05\r\n\x7fgarbage\r\n000\r\n");
            assert_eq!(far.command(Duration::from_secs(5)).as_deref(), Some("B1"));
            far.say(b"000\r\n");
        });
        let e = session
            .exchange(&D5, Duration::from_secs(1), &CancellationToken::new())
            .unwrap_err();
        assert!(
            matches!(
                e,
                InstrumentError::Truncated {
                    lines: 1,
                    expected: 3,
                    gap_ms: 400,
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(session.needs_resync());
        session.resync_if_needed(&CancellationToken::new()).unwrap();
        assert!(!session.needs_resync(), "back in step");
        let reply = session
            .exchange(&B1, Duration::from_secs(1), &CancellationToken::new())
            .unwrap();
        assert_eq!(reply, b"000\r\n");
        assert_eq!(far.join().unwrap().heard, b"D5\nB1\nB1\n");
    }

    #[test]
    fn a_garbled_reply_is_a_protocol_error_that_names_the_command_and_needs_a_resync() {
        let (mut session, far, _keep) = session_with(timing(500, 5000), |_| {});
        let e = session.protocol_error("D2", &"line 1: `0#,0` is not a report");
        assert_eq!(
            e.to_string(),
            "garbled reply to `D2`: line 1: `0#,0` is not a report. The line may be noisy; check the cable and the \
             baud rate (9600 for the Photo Research units, 115200 for the CS-2000 and CR-250/300, 4800 for the \
             Minolta meters)"
        );
        assert!(session.needs_resync());
        far.join().unwrap();
    }

    #[test]
    fn a_ping_met_by_silence_is_unresponsive_and_names_the_fault_before_it() {
        let (mut session, far, _keep) = session_with(timing(300, 5000), |far| {
            let _ = far.command(Duration::from_secs(3));
            let _ = far.command(Duration::from_secs(3));
        });
        let _ = session
            .exchange(&D5, Duration::from_millis(300), &CancellationToken::new())
            .unwrap_err();
        let start = Instant::now();
        let e = session.resync_if_needed(&CancellationToken::new()).unwrap_err();
        match &e {
            InstrumentError::Unresponsive {
                after,
                reason,
                command,
                waited_ms,
            } => {
                assert_eq!((after.as_str(), command.as_str()), ("D5", "B1"));
                assert!(reason.contains("no reply to `D5`"), "{reason}");
                assert!((300..2000).contains(waited_ms), "{waited_ms}");
            }
            other => panic!("{other:?}"),
        }
        assert!(
            start.elapsed() < Duration::from_secs(3),
            "the ping waits the command timeout, not a measurement"
        );
        assert!(session.needs_resync(), "still out of step");
        assert_eq!(far.join().unwrap().heard, b"D5\nB1\n");
    }

    /// The far end of a unit that goes on measuring: it ignores `M0`, and
    /// answers the ping only after `late`.
    fn still_measuring(late: Duration) -> impl FnOnce(&mut FarEnd) + Send + 'static {
        move |far| {
            let _ = far.command(Duration::from_secs(5));
            if far.command(Duration::from_secs(5)).as_deref() == Some("B1") {
                std::thread::sleep(late);
                far.say(b"000\r\n");
            }
        }
    }

    #[test]
    fn after_a_cancelled_measurement_the_ping_waits_a_whole_measurement() {
        let late = Duration::from_millis(900);
        let (mut session, far, _keep) = session_with(timing(300, 4000), still_measuring(late));
        let cancel = CancellationToken::new();
        cancel.cancel();
        let e = session.exchange(&M0, Duration::from_secs(4), &cancel).unwrap_err();
        assert!(matches!(e, InstrumentError::Cancelled), "{e:?}");
        let start = Instant::now();
        session.resync_if_needed(&CancellationToken::new()).unwrap();
        assert!(start.elapsed() >= late, "the ping's late answer was awaited");
        assert_eq!(far.join().unwrap().heard, b"M0\nB1\n");
    }

    #[test]
    fn a_timed_out_measurement_lengthens_the_pings_wait_only_where_the_model_says_so() {
        for measuring_after_timeout in [false, true] {
            let timing = SessionTiming {
                measuring_after_timeout,
                ..timing(300, 4000)
            };
            let (mut session, far, _keep) = session_with(timing, still_measuring(Duration::from_millis(900)));
            let e = session
                .exchange(&M0, Duration::from_millis(300), &CancellationToken::new())
                .unwrap_err();
            assert!(matches!(e, InstrumentError::Timeout { .. }), "{e:?}");
            let resynced = session.resync_if_needed(&CancellationToken::new());
            if measuring_after_timeout {
                resynced.unwrap();
            } else {
                let e = resynced.unwrap_err();
                assert!(
                    matches!(&e, InstrumentError::Unresponsive { after, .. } if after == "M0"),
                    "{e:?}"
                );
            }
            far.join().unwrap();
        }
    }
}
