//! Revocation of young pairs that the pairing contradicts (module doc of [`super`],
//! "Pairing", step 6).

use super::{TrackPairLs, HISTORY};
use crate::types::Id;

impl TrackPairLs {
    /// Revocation (module doc, "Pairing", step 6): the stored groups of every pair that
    /// was learnt from, accepted for fewer than [`HISTORY`] consecutive scans, ended within
    /// the last [`HISTORY`] scans, and is now contradicted (one of its tracks accepted with
    /// another track of the other one's sensor) are taken out of the estimate.
    /// `new_memory` holds this scan's pairs, sorted; `memory` the last scan's.
    pub(super) fn revoke_contradicted(&mut self) {
        let confirm = self.params.confirm_scans;
        let now = self.scans;
        // pairs that ended at the last scan, once learnt from and never fully validated
        for &(pk, streak) in &self.memory {
            if streak >= confirm
                && streak < HISTORY as u32
                && self.new_memory.binary_search_by(|x| x.0.cmp(&pk)).is_err()
            {
                self.ended.push((pk, streak, now - 1));
            }
        }
        if self.ended.is_empty() {
            return;
        }
        self.by_second.clear();
        self.by_second
            .extend(self.new_memory.iter().map(|&((a, b), _)| (b, a)));
        self.by_second.sort_unstable();
        let mut k = 0;
        while k < self.ended.len() {
            let ((ka, kb), streak, last) = self.ended[k];
            let resumed = self
                .new_memory
                .binary_search_by(|x| x.0.cmp(&(ka, kb)))
                .is_ok();
            if resumed || last + (HISTORY as u64) < now {
                self.ended.swap_remove(k);
                continue;
            }
            // ka's pairs this scan (sorted by ka first), and kb's
            let from = self.new_memory.partition_point(|x| x.0 .0 < ka);
            let a_elsewhere = self.new_memory[from..]
                .iter()
                .take_while(|x| x.0 .0 == ka)
                .any(|x| x.0 .1 .0 == kb.0 && x.0 .1 != kb);
            let from = self.by_second.partition_point(|x| x.0 < kb);
            let b_elsewhere = self.by_second[from..]
                .iter()
                .take_while(|x| x.0 == kb)
                .any(|x| x.1 .0 == ka.0 && x.1 != ka);
            if !(a_elsewhere || b_elsewhere) {
                k += 1;
                continue;
            }
            // its groups were stored at the last `streak - confirm + 1` scans it was
            // accepted in, up to `last`
            let oldest = last.saturating_sub(u64::from(streak - confirm));
            for g in self.groups.iter_mut().rev() {
                if g.stamp < oldest {
                    break;
                }
                if g.stamp > last || g.len == 0 {
                    continue;
                }
                let obs = &self.observations[g.start..g.start + g.len];
                let has = |k: (Id, Id)| obs.iter().any(|o| (o.sensor_id, o.track_id) == k);
                if has(ka) && has(kb) {
                    g.len = 0;
                }
            }
            self.ended.swap_remove(k);
        }
    }
}
