//! The detection strategies. Each consumes synchronised [`Sample`](crate::sample::Sample)s,
//! one per GNSS epoch, and reports whether it ran, whether it fired, and why.
//!
//! - [`location_shift`]: strategy 1, GNSS location shift vs a predicted shift (kinematic, or the
//!   paper's LSTM with its f32 reference and integer kernels).
//! - [`turn`]: strategy 2, steering turns (segmenter, k-NN with exact banded DTW) vs GNSS turns.
//! - [`motion`]: strategy 3, standstill vs motion from the wheels and from GNSS.
//! - [`track`]: beyond the paper, for stealthy spoofing: the GNSS track against the car's dead
//!   reckoning over 10 s and 30 s, calibrated on the car itself.
//!
//! No strategy depends on another; [`crate::fusion`] combines them.

pub mod location_shift;
pub mod motion;
pub mod track;
pub mod turn;

/// Identifies a strategy in verdicts and reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum StrategyId {
    /// Strategy 1: the GNSS shift against a predicted shift.
    LocationShift = 0,
    /// Strategy 2: turns from steering against turns in the GNSS course.
    Turn = 1,
    /// Strategy 3: standing or moving, wheels against GNSS.
    Motion = 2,
    /// Beyond the paper: the GNSS track against the car's dead reckoning.
    Track = 3,
}

impl StrategyId {
    /// Every strategy, in bit order.
    pub const ALL: [StrategyId; 4] = [StrategyId::LocationShift, StrategyId::Turn, StrategyId::Motion, StrategyId::Track];
    /// The paper's three strategies.
    pub const PAPER: [StrategyId; 3] = [StrategyId::LocationShift, StrategyId::Turn, StrategyId::Motion];
    /// The name used on the command line, in JSON and in reports.
    pub const fn name(self) -> &'static str {
        match self {
            StrategyId::LocationShift => "location_shift",
            StrategyId::Turn => "turn",
            StrategyId::Motion => "motion",
            StrategyId::Track => "track",
        }
    }
}

/// A small set of strategies (a bit mask).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct StrategySet(pub u8);

impl StrategySet {
    /// No strategy.
    pub const EMPTY: StrategySet = StrategySet(0);
    /// Adds `s`.
    pub fn insert(&mut self, s: StrategyId) {
        self.0 |= 1 << s as u8;
    }
    /// Whether `s` is in the set.
    pub fn contains(self, s: StrategyId) -> bool {
        self.0 & (1 << s as u8) != 0
    }
    /// Whether the set is empty.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }
    /// Both sets' strategies.
    pub fn union(self, o: StrategySet) -> StrategySet {
        StrategySet(self.0 | o.0)
    }
    /// The strategies in the set, in bit order.
    pub fn iter(self) -> impl Iterator<Item = StrategyId> {
        StrategyId::ALL.into_iter().filter(move |s| self.contains(*s))
    }
}
