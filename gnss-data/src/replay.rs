//! Replays a decoded drive through `detector_core::sync::Synchronizer`, exactly as the firmware
//! feeds it, and collects the synchronised samples.

use crate::input::{Event, Replay};
use detector_core::sample::Sample;
use detector_core::sync::{SyncConfig, SyncCounters, Synchronizer};

/// All samples of a replay, in epoch order, and what the synchroniser dropped.
pub fn synchronize(r: &Replay, cfg: SyncConfig) -> (Vec<Sample>, SyncCounters) {
    let mut sync = Synchronizer::new(cfg);
    let mut out = Vec::new();
    let mut emit = |s: &Sample| out.push(*s);
    for e in &r.events {
        match *e {
            Event::Fix(f) => sync.push_fix(f, &mut emit),
            Event::Obs { sig, t, v } => sync.push_obs(sig, t, v, &mut emit),
        }
    }
    sync.flush(&mut emit);
    (out, sync.counters())
}
