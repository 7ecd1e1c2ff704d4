//! Attacked and transformed drives, as the `attack` and `nuisance` commands and the Python
//! package make them (one path, so both give the same drives).

use crate::detect;
use detector_core::sync::SyncConfig;
use gnss_data::attack::{self, AttackKind, AttackParams, Attacked};
use gnss_data::input::Replay;
use gnss_data::nuisance::{self, Nuisance, NuisanceKind};
use gnss_data::replay;

/// `kind` applied to `r` from `onset` (seconds on the drive's clock), or from an onset drawn
/// with `seed` among the times where the kind makes sense; `Err` when the drive can host none.
pub fn attack(r: &Replay, kind: AttackKind, seed: u64, onset: Option<f64>, params: &AttackParams, sync: SyncConfig) -> Result<Attacked, String> {
    let onset = match onset {
        Some(t) => t,
        None => {
            use rand::{seq::IndexedRandom, SeedableRng};
            let (samples, _) = replay::synchronize(r, sync);
            let c = attack::candidate_onsets(kind, &samples);
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            *c.choose(&mut rng).ok_or_else(|| format!("this drive cannot host a {} attack (see `host-sim attack --help`)", kind.name()))?
        }
    };
    Ok(attack::apply_with(r, kind, seed, onset, params))
}

/// `r` transformed by `given` or, where `given` says nothing (its default), by a nuisance of
/// `kind` drawn from `seed` for this drive's duration and fix rate; and what was applied.
pub fn nuisance(r: &Replay, kind: NuisanceKind, seed: u64, given: Nuisance, sync: SyncConfig) -> (Replay, Nuisance) {
    let n = if given == Nuisance::default() {
        let (samples, _) = replay::synchronize(r, sync);
        let dur = samples.last().zip(samples.first()).map_or(0.0, |(a, b)| a.t - b.t);
        Nuisance::draw(kind, seed, dur, 1.0 / detect::profile_of(&samples).nominal_dt_s as f64)
    } else {
        given
    };
    (nuisance::apply(r, &n, seed), n)
}
