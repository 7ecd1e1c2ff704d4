//! Strategy 2: turns. Steering says the car turned left or right; GNSS must agree.
//!
//! Steering wheel angle is resampled to 5 Hz (as in the paper) from the per-epoch samples. When
//! no steering is measured, a proxy is derived from yaw rate and wheel speed with a kinematic
//! bicycle model, `steer = ratio * atan(wheelbase * yaw_rate / speed)`
//! ([`crate::vehicle::Bicycle`]); the outcome says which was used.
//!
//! A *steering segment* starts when |steer| rises above `start_deg` (taken from the last 5 Hz
//! tick below `settle_deg`, but at most [`MAX_LEAD`] ticks before the rise) and ends when it
//! settles below `settle_deg` again (or after [`MAX_SEGMENT`] ticks): [`segmenter`]. The segment,
//! resampled to [`QUERY_LEN`] points, is classified
//! left / right / none by k-NN ([`knn`]) with exact banded DTW ([`dtw`]) against templates learned
//! from real drives ([`TemplateSet`], read in place from a CRC-checked blob in flash). Over the same ticks, the
//! GNSS course change says left (< -`gnss_turn_deg`), right (> +`gnss_turn_deg`) or straight
//! (|change| < `gnss_straight_deg`). The strategy fires when
//! - steering says a turn and GNSS says straight or the other way, or
//! - over a window of `heading_window_s` with no steering segment, GNSS turned by more than
//!   `straight_turn_deg` beyond the course change the steering implies through the bicycle
//!   model (GNSS turns where the wheel does not). Two windows: the last one, while the wheel
//!   stays below `settle_deg` all along (and the GNSS lag allowance before); and one ending 1.5 s
//!   ago, while the wheel stays below `start_deg`, compared with the steering's window shifted
//!   either way by the lags allowed (vehicle signals up to 1.5 s late, GNSS up to
//!   `gnss_lag_s` + 1 s), the closest shift counting.
//!
//! A segment's turn must also be implied by the steering itself (integrated through the bicycle
//! model, more than `gnss_turn_deg` the same way): a roundabout's steering can look like a turn
//! while the net heading change is small.
//!
//! The GNSS heading is the receiver's course where it reports one with its speed, else the
//! bearing over 3 m of track covered within 2.5 s: a bearing that took longer is a creeping
//! car's, and a receiver's error wandering by metres over those seconds is in it. A segment
//! after which the car stopped within 3 m by its wheels (a parking space, a queue) is judged
//! only if a heading was measured after its steering settled: else the heading held from before
//! the turn says nothing of the turn's end. A car that drove on while the GNSS showed no
//! heading (a position frozen or creeping) is judged as before: that is an attack's.

//!
//! [`strategy`] ties them together: the 5 Hz ticks, the judgement, and (its child module
//! `strategy/heading.rs`) the GNSS-only heading check.

pub mod dtw;
pub mod knn;
pub mod segmenter;
pub mod strategy;

pub use crate::wire::templates::{BlobError, Provenance, TemplateSet, TurnClass, MAGIC, QUERY_LEN, VERSION};
pub use knn::{classify, classify_reference, Neighbour, MAX_K};
pub use segmenter::{MAX_LEAD, MAX_SEGMENT};
pub use strategy::{TurnConfig, TurnMismatch, TurnOutcome, TurnStep, TurnStrategy, DEFAULT_TEMPLATES};
