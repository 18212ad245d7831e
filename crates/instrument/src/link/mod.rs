//! The link to an instrument, the same for every model: the serial port
//! ([`serial`]: settings, flushing, timed writes, the two-phase read), its
//! line framing ([`lines`]), and one [`session`] over it that every driver
//! shares (a command and its reply within the right timeouts, and the
//! resynchronisation after a fault).
//!
//! Below the models: nothing here knows a PR-650 from a PR-670 but what a
//! driver tells it (its commands through [`session::Request`], its ping
//! through [`session::Ping`]).

pub mod lines;
pub mod serial;
pub mod session;

pub use lines::Terminator;
pub use serial::{Framing, LinkSettings, SerialLink};
pub use session::{Ping, Request, Session, SessionTiming};
