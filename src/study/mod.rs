//! The study: how accurate each colour coding is, what it costs, where it
//! fails, and the cheapest settings that meet a tolerance — for the booth
//! scenes of Ruppertsberg & Bloj (2006) and for any scene a lab brings.
pub mod auto;
