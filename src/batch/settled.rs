//! What a decision in a state may take from the previous decision there instead of computing it
//! again, bit for bit the same: one small set of flags per state of a run without a human, which
//! owns both their invalidation and the fold they let a decision skip. Without a human the
//! softmax of an expert depends only on its Q row (the bonus term is 0, the temperature fixed).

use crate::expert::{ema_into, softmax_graded_by};

/// One of the two experts, naming its half of the [`Settled`] flags.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Expert {
    /// The model-free expert.
    Mf,
    /// The model-based expert.
    Mb,
}

impl Expert {
    /// The expert's two flags: (its softmax is unchanged, folding it changes nothing).
    #[inline(always)]
    const fn bits(self) -> (u8, u8) {
        match self {
            Expert::Mf => (1, 2),
            Expert::Mb => (4, 8),
        }
    }

    /// The expert's third flag: its settled average equals its softmax, bit for bit.
    #[inline(always)]
    const fn equal_bit(self) -> u8 {
        match self {
            Expert::Mf => 16,
            Expert::Mb => 32,
        }
    }
}

/// Per state, for each expert: whether its Q row has not changed since its softmax was last
/// folded into its averaged distribution (a run that keeps softmaxes may still hold it:
/// `Kept`), whether that fold left the averaged distribution as it was, so that folding
/// again would too, and whether that settled average is the softmax itself, bit for bit, so
/// that a decision drawing from the softmax may copy the average instead of computing it (most
/// settled averages are: a near-deterministic softmax is its own moving average's fixed point);
/// and, for both experts, whether the entropy kept for a mixed distribution still holds.
/// A new state knows nothing ([`Default`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[repr(transparent)]
pub struct Settled(u8);

/// One expert's step 5 in a state ([`Settled::fold`]): what it folds, and how it is used.
pub struct Fold<'a> {
    /// Which expert.
    pub expert: Expert,
    /// The action is drawn from this expert's softmax, so it is needed whatever the flags say.
    pub drawn: bool,
    /// The expert's Q row in the state.
    pub q: &'a [f64],
    /// G(s, .) of Eq. 8.
    pub g: &'a [u8],
    /// G is read as signed (a person's run: [`crate::expert::softmax_graded_by`]).
    pub signed: bool,
    /// The weight of G in the softmax.
    pub bonus: f64,
    /// The softmax temperature.
    pub tau: f64,
    /// The moving averages' weight of the new value.
    pub alpha: f64,
}

/// The softmax row a fold writes is a kept slot, where it stays between decisions until another
/// state's softmax takes the slot: `owner` is the state whose softmax the slot holds, `state` the
/// folding one. While the Q row is unchanged and the slot still the state's, the softmax is there
/// already and is neither computed nor copied.
pub struct Kept<'a> {
    /// The state whose softmax the slot holds (`u32::MAX`: none yet).
    pub owner: &'a mut u32,
    /// The state of this fold.
    pub state: u32,
}

/// The flag of a kept mixed distribution's entropy: neither expert's Q row in the state has
/// changed since it was computed.
const MIX: u8 = 64;

impl Settled {
    /// The expert's Q row in the state changed: its softmax and fold must be computed again, and
    /// so must a mixed distribution's entropy.
    #[inline(always)]
    pub fn q_changed(&mut self, expert: Expert) {
        let (softmax, average) = expert.bits();
        self.0 &= !(softmax | average | expert.equal_bit() | MIX);
    }

    /// Whether neither Q row of the state has changed since its mixed distribution's entropy was
    /// kept: without a human, that entropy still holds if the weight is the same too.
    #[inline(always)]
    pub fn mix_kept(self) -> bool {
        self.0 & MIX != 0
    }

    /// The state's mixed distribution's entropy was just computed and kept.
    #[inline(always)]
    pub fn keep_mix(&mut self) {
        self.0 |= MIX;
    }

    /// Whether the expert's Q row is unchanged since its softmax was last folded.
    #[inline(always)]
    pub fn softmax_kept(self, expert: Expert) -> bool {
        self.0 & expert.bits().0 != 0
    }

    /// Writes the softmax of `fold.q` (with bonus `fold.bonus * fold.g`) into `p` when it is
    /// needed and not there already (`kept`), folds it into `avg` unless that is known to change
    /// nothing, and updates the flags; a changed `avg` makes its kept `entropy` unknown (NaN).
    /// Returns whether `avg` changed.
    #[inline(always)]
    pub fn fold(
        &mut self,
        fold: &Fold<'_>,
        p: &mut [f64],
        kept: Option<Kept<'_>>,
        avg: &mut [f64],
        entropy: &mut f64,
    ) -> bool {
        let (softmax, average) = fold.expert.bits();
        let equal = fold.expert.equal_bit();
        let both = softmax | average;
        let unchanged = self.0 & both == both;
        let fresh = self.0 & softmax != 0 && kept.as_ref().is_some_and(|k| *k.owner == k.state);
        if !fresh && (fold.drawn || !unchanged) {
            if unchanged && self.0 & equal != 0 {
                p.copy_from_slice(avg);
            } else {
                softmax_graded_by(fold.signed, fold.q, fold.g, fold.bonus, fold.tau, p);
            }
            if let Some(k) = kept {
                *k.owner = k.state;
            }
        }
        if unchanged {
            return false;
        }
        let changed = ema_into(avg, p, fold.alpha);
        // Once settled, whether the average is the softmax is checked once, not per decision.
        let same = !changed && avg.iter().zip(&*p).all(|(a, b)| a.to_bits() == b.to_bits());
        self.0 = (self.0 & !(both | equal))
            | if changed {
                softmax
            } else if same {
                both | equal
            } else {
                both
            };
        if changed {
            *entropy = f64::NAN;
        }
        changed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const G: [u8; 3] = [0; 3];

    /// One state's MF softmax buffer (and the state whose softmax it holds, when kept),
    /// averaged distribution, flags and kept entropy.
    struct State {
        p: [f64; 3],
        owner: u32,
        avg: [f64; 3],
        settled: Settled,
        entropy: f64,
    }

    /// The state the tests fold in.
    const STATE: u32 = 5;

    impl State {
        /// [`Settled::fold`] of the MF expert on row `q` (temperature 0.5, alpha 0.6, no bonus),
        /// into a kept slot if `kept`, else into scratch space.
        fn fold(&mut self, q: &[f64; 3], drawn: bool, kept: bool) -> bool {
            let fold = Fold {
                expert: Expert::Mf,
                drawn,
                q,
                g: &G,
                signed: false,
                bonus: 0.0,
                tau: 0.5,
                alpha: 0.6,
            };
            let kept = kept.then_some(Kept {
                owner: &mut self.owner,
                state: STATE,
            });
            self.settled
                .fold(&fold, &mut self.p, kept, &mut self.avg, &mut self.entropy)
        }
    }

    fn softmax(q: &[f64; 3]) -> [f64; 3] {
        let mut p = [0.0; 3];
        crate::expert::softmax_biased(q, &G, 0.0, 0.5, &mut p);
        p
    }

    /// Both of the MF expert's flags.
    const MF_BOTH: Settled = Settled(1 | 2);
    /// Both, and the average is the softmax.
    const MF_EQUAL: Settled = Settled(1 | 2 | 16);

    #[test]
    fn a_drawn_softmax_is_copied_from_the_average_only_when_they_are_equal() {
        // A certain choice: p = (1, 0, 0), and 0.4 * 1 + 0.6 * 1 is 1 exactly, so the average
        // settles on the softmax itself.
        let q = [0.0, -1000.0, -1000.0];
        let p = softmax(&q);
        assert_eq!(p, [1.0, 0.0, 0.0]);
        let mut st = State {
            p: [f64::NAN; 3],
            owner: u32::MAX,
            avg: [1.0 / 3.0; 3],
            settled: Settled::default(),
            entropy: 0.0,
        };
        // The zeros shrink by 0.4 a fold, through the subnormals: about 800 folds.
        let folds = (1..2000).find(|_| !st.fold(&q, false, false));
        assert!(folds.expect("the average settles") > 1);
        assert_eq!((st.avg, st.settled), (p, MF_EQUAL));
        // Drawn: the average is copied; the row is not even read.
        st.p = [f64::NAN; 3];
        assert!(!st.fold(&[f64::NAN; 3], true, false));
        assert_eq!(st.p, p);
        // A changed row forgets all three flags.
        st.settled.q_changed(Expert::Mf);
        assert_eq!(st.settled, Settled::default());
    }

    #[test]
    fn a_settled_fold_is_skipped_and_its_softmax_only_computed_when_drawn() {
        let q = [0.0, 1.0, 0.5];
        // A kept entropy of the average; folding that moves the average makes it unknown.
        let mut st = State {
            p: [0.0; 3],
            owner: u32::MAX,
            avg: [1.0 / 3.0; 3],
            settled: Settled::default(),
            entropy: 1.0,
        };
        // The first fold moves the average: only the softmax is known unchanged, and it says so.
        assert!(st.fold(&q, false, false));
        assert!(st.settled.softmax_kept(Expert::Mf));
        assert_ne!(st.settled, MF_BOTH);
        assert!(st.entropy.is_nan());
        assert_eq!(st.p, softmax(&q));
        // Folding the same softmax converges (the moving average reaches a fixed point).
        let folds = (1..200).find(|_| {
            st.fold(&q, false, false);
            st.settled.0 & MF_BOTH.0 == MF_BOTH.0
        });
        assert!(folds.expect("the average settles") > 1);
        let settled_avg = st.avg;
        st.entropy = 2.0;
        // Settled and not drawn: neither the softmax nor the average (nor its entropy) is touched.
        st.p = [f64::NAN; 3];
        assert!(!st.fold(&q, false, false));
        assert!(st.p.iter().all(|x| x.is_nan()));
        assert_eq!((st.avg, st.entropy), (settled_avg, 2.0));
        // Drawn from: the softmax is there again (bit for bit the same), the fold still not.
        assert!(!st.fold(&q, true, false));
        assert_eq!(st.p, softmax(&q));
        assert_eq!(st.avg, settled_avg);
        // This average settled a rounding away from the softmax (0.4 a + 0.6 p rounds back to
        // a), so the flag says they differ and the drawn softmax above was computed.
        assert_ne!(settled_avg, softmax(&q));
        assert_eq!(st.settled, MF_BOTH);
        // Kept in a slot: the first drawn fold writes the slot's softmax and owns it; the next
        // does not even recompute it, until another state takes the slot.
        st.p = [f64::NAN; 3];
        assert!(!st.fold(&q, true, true));
        assert_eq!((st.p, st.owner), (softmax(&q), STATE));
        st.p = [f64::NAN; 3];
        assert!(!st.fold(&q, true, true));
        assert!(st.p.iter().all(|x| x.is_nan()));
        st.owner = STATE + 1;
        assert!(!st.fold(&q, true, true));
        assert_eq!((st.p, st.owner), (softmax(&q), STATE));
        // Not drawn and settled: the slot is neither written nor taken.
        st.owner = STATE + 1;
        st.p = [f64::NAN; 3];
        assert!(!st.fold(&q, false, true));
        assert!(st.p.iter().all(|x| x.is_nan()) && st.owner == STATE + 1);
        // A changed row is computed and folded again.
        st.settled.q_changed(Expert::Mf);
        assert_eq!(st.settled, Settled::default());
        let q2 = [2.0, 1.0, 0.5];
        assert!(st.fold(&q2, false, false));
        assert_eq!(st.p, softmax(&q2));
        assert!(st.settled.softmax_kept(Expert::Mf));
    }

    #[test]
    fn the_other_expert_s_flags_are_left_alone() {
        let mb_both = Settled(4 | 8);
        let mut st = State {
            p: [0.0; 3],
            owner: u32::MAX,
            avg: [0.5, 0.25, 0.25],
            settled: mb_both,
            entropy: 0.0,
        };
        st.fold(&[0.3, 0.1, 0.0], false, false);
        assert_eq!(st.settled, Settled(4 | 8 | 1));
        // Invalidating MF leaves MB's flags; invalidating MB leaves MF's.
        st.settled.q_changed(Expert::Mf);
        assert_eq!(st.settled, mb_both);
        st.settled.q_changed(Expert::Mb);
        assert_eq!(st.settled, Settled::default());
    }

    #[test]
    fn a_kept_mixed_entropy_survives_folds_and_falls_with_either_expert_s_row() {
        for expert in [Expert::Mf, Expert::Mb] {
            let mut st = State {
                p: [0.0; 3],
                owner: u32::MAX,
                avg: [0.5, 0.25, 0.25],
                settled: Settled::default(),
                entropy: 0.0,
            };
            assert!(!st.settled.mix_kept(), "a new state keeps nothing");
            st.settled.keep_mix();
            assert!(st.settled.mix_kept());
            // Folding the MF softmax (its average changes, then settles) leaves the mix alone:
            // it depends on the Q rows, not on the averages.
            let q = [0.0, -1000.0, -1000.0];
            assert!(st.fold(&q, true, false));
            while st.fold(&q, true, false) {}
            assert!(st.settled.mix_kept());
            st.settled.q_changed(expert);
            assert!(!st.settled.mix_kept(), "{expert:?}'s row changed");
        }
    }
}
