//! k-nearest-neighbour classification of a steering segment against the templates, with exact
//! banded DTW: pruned by LB_Keogh and early abandoning ([`classify`]), and plainly
//! ([`classify_reference`], the reference the pruned one is tested against).

use super::dtw::{dtw_pruned, dtw_reference, envelope, lb_keogh};
use crate::wire::templates::{TemplateSet, TurnClass, QUERY_LEN};

/// Largest `k` for k-NN.
pub const MAX_K: usize = 7;

/// Result of a k-NN query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbour {
    /// The winning class.
    pub class: TurnClass,
    /// Distance to the nearest template of the winning class.
    pub distance: f32,
    /// That template's index in the set.
    pub index: usize,
}

fn vote(top: &[(f32, usize, TurnClass)]) -> Option<Neighbour> {
    let mut counts = [0usize; 3];
    for t in top {
        counts[t.2 as usize] += 1;
    }
    let best = (0..3).max_by_key(|&c| (counts[c], core::cmp::Reverse(top.iter().position(|t| t.2 as usize == c).unwrap_or(usize::MAX))))?;
    let t = top.iter().find(|t| t.2 as usize == best)?;
    Some(Neighbour { class: t.2, distance: t.0, index: t.1 })
}

/// Inserts a neighbour into `top` (sorted by distance, at most `k`), after the equal ones.
fn insert(top: &mut heapless::Vec<(f32, usize, TurnClass), MAX_K>, k: usize, d: f32, i: usize, c: TurnClass) {
    if top.len() >= k && top.last().is_some_and(|l| d >= l.0) {
        return;
    }
    if top.len() >= k {
        top.pop();
    }
    // Walk to the first strictly greater entry, then shift the rest by one.
    let mut item = (d, i, c);
    let mut placed = false;
    for slot in top.iter_mut() {
        if placed || item.0 < slot.0 {
            core::mem::swap(slot, &mut item);
            placed = true;
        }
    }
    let _ = top.push(item);
}

/// k-NN with pruning (LB_Keogh on the query's envelope, early-abandoning DTW).
pub fn classify(set: &TemplateSet, q: &[f32; QUERY_LEN], k: usize) -> Option<Neighbour> {
    let k = k.clamp(1, MAX_K);
    let band = set.band();
    let (mut u, mut l) = ([0.0f32; QUERY_LEN], [0.0f32; QUERY_LEN]);
    envelope(q, band, &mut u, &mut l);
    let mut top: heapless::Vec<(f32, usize, TurnClass), MAX_K> = heapless::Vec::new();
    for i in 0..set.len() {
        let (c, _, t) = set.get(i);
        let bound = match top.last() {
            Some(l) if top.len() == k => l.0,
            _ => f32::INFINITY,
        };
        if lb_keogh(&t, &u, &l, bound) > bound {
            continue;
        }
        let d = dtw_pruned(q, &t, band, bound);
        if d.is_finite() {
            insert(&mut top, k, d, i, c);
        }
    }
    vote(&top)
}

/// The same k-NN by plain full banded DTW against every template: the reference.
pub fn classify_reference(set: &TemplateSet, q: &[f32; QUERY_LEN], k: usize) -> Option<Neighbour> {
    let k = k.clamp(1, MAX_K);
    let mut top: heapless::Vec<(f32, usize, TurnClass), MAX_K> = heapless::Vec::new();
    for i in 0..set.len() {
        let (c, _, t) = set.get(i);
        insert(&mut top, k, dtw_reference(q, &t, set.band()), i, c);
    }
    vote(&top)
}
