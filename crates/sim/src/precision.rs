//! The precision of a Newton solve's factorizations: when a step is factored in single
//! precision, what a failed single-precision factorization is taken for, and when the solve
//! goes on in double precision ([`crate::newton::FactorPrecision`] and the `SINGLE_*` constants
//! there).
//!
//! The rules, as a state machine apart from the solver's loop so that each can be tested on
//! its own sequence of factorization outcomes (the sequences that matter are hard to meet on a
//! mesh small enough for the test suite: a mold whose matrix is confirmed indefinite twice
//! before its creep loses a pivot, as kitten filled to a fifth does):
//!
//! - A step starts in single precision while the solve does ([`Precision::step`]).
//! - A single-precision failure is factored again in double precision at the same damping; if
//!   that succeeds, the pivot was lost to round-off (after [`SINGLE_MAX_LOST_PIVOTS`] the solve
//!   goes on in double precision), and if it fails, the matrix is indefinite at that damping
//!   (a confirmation): the damping is raised, and the step's retries are single-precision
//!   again, their failures taken as that indefiniteness.
//! - After [`SINGLE_TRUST_AFTER`] confirmations, and no lost pivot, a single-precision failure
//!   is taken as indefiniteness at once (the trust), but for one in [`SINGLE_RECHECK_EVERY`],
//!   confirmed again; a lost pivot found so ends the trust.
//! - A value out of single precision's range: that step in double precision.
//! - A single-precision factor that preconditions the step too poorly: the step factored
//!   again in double precision; after [`SINGLE_MAX_POOR`] the solve goes on in double precision.

use crate::newton::{SINGLE_MAX_LOST_PIVOTS, SINGLE_MAX_POOR, SINGLE_RECHECK_EVERY, SINGLE_TRUST_AFTER, SolveStats};

/// How a factorization ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Factored {
    /// A factor.
    Ok,
    /// A pivot not positive.
    NotPositiveDefinite,
    /// A value out of the precision's range.
    OutOfRange,
    /// Any other failure.
    Other,
}

/// What the solve does next, after a factorization.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Next {
    /// Solve the step with the factor.
    Solve,
    /// Raise the damping and factor again (in [`StepPrecision::single`]).
    RaiseDamping,
    /// Factor the same matrix again, in double precision.
    Refactor,
    /// Give up: the factorization's error is the solve's.
    Fail,
}

/// The solve's state.
#[derive(Clone, Debug)]
pub(crate) struct Precision {
    /// Steps start in single precision.
    use_single: bool,
    /// Steps whose single-precision factor preconditioned too poorly.
    poor: usize,
    /// Single-precision failures taken as indefiniteness since the last double-precision
    /// confirmation.
    unconfirmed_since_check: usize,
}

/// A step's state.
#[derive(Clone, Debug)]
pub(crate) struct StepPrecision {
    /// The next factorization is single-precision.
    pub single: bool,
    /// A single-precision failure is taken as indefiniteness.
    indefinite: bool,
    /// The next factorization is the double-precision one of a matrix whose single-precision
    /// factorization lost a pivot: it tells a lost pivot from indefiniteness.
    confirming: bool,
    /// Set by a confirmation: the next damping raise returns to single precision (once; a later
    /// fallback for range or a poor factor keeps double precision for the step).
    back_to_single: bool,
}

impl Precision {
    /// A solve that factors in single precision or not.
    pub fn new(single: bool) -> Self {
        Self { use_single: single, poor: 0, unconfirmed_since_check: 0 }
    }

    /// Whether steps start in single precision.
    #[cfg(test)]
    pub fn single(&self) -> bool {
        self.use_single
    }

    /// Whether the solve has earned the trust: [`SINGLE_TRUST_AFTER`] confirmations, and no
    /// failure a lost pivot.
    fn trust_earned(stats: &SolveStats) -> bool {
        stats.single_fallbacks_indefinite >= SINGLE_TRUST_AFTER && stats.single_fallbacks_pivot == 0
    }

    /// Whether single-precision failures are taken as indefiniteness without a
    /// double-precision factorization, at the start of the next step: under the trust, but for
    /// the recheck of one in [`SINGLE_RECHECK_EVERY`].
    pub fn trusted(&self, stats: &SolveStats) -> bool {
        Self::trust_earned(stats) && self.unconfirmed_since_check + 1 < SINGLE_RECHECK_EVERY
    }

    /// A step's start.
    pub fn step(&self, stats: &SolveStats) -> StepPrecision {
        StepPrecision {
            single: self.use_single,
            indefinite: self.trusted(stats),
            confirming: false,
            back_to_single: false,
        }
    }

    /// After a factorization in `step.single` precision that ended `res`: the counts in
    /// `stats` (but for the factorizations themselves, counted by the caller) and what the
    /// solve does next.
    pub fn factored(&mut self, step: &mut StepPrecision, res: Factored, stats: &mut SolveStats) -> Next {
        if std::mem::take(&mut step.confirming) {
            self.unconfirmed_since_check = 0;
            match res {
                Factored::Ok => {
                    if Self::trust_earned(stats) {
                        tracing::debug!(
                            iteration = stats.iterations,
                            "a recheck found a lost single-precision pivot: the trust ends"
                        );
                        stats.single_trust_ended = true;
                    }
                    stats.single_fallbacks_pivot += 1;
                    if stats.single_fallbacks_pivot >= SINGLE_MAX_LOST_PIVOTS {
                        tracing::debug!("pivots lost in single precision again and again; double precision");
                        self.use_single = false;
                    }
                }
                Factored::NotPositiveDefinite => {
                    stats.single_fallbacks_indefinite += 1;
                    step.indefinite = true;
                    step.back_to_single = true;
                }
                Factored::OutOfRange | Factored::Other => {}
            }
        }
        match res {
            Factored::Ok => Next::Solve,
            Factored::NotPositiveDefinite if !step.single || step.indefinite => {
                stats.single_indefinite_unconfirmed += usize::from(step.single);
                self.unconfirmed_since_check += usize::from(step.single);
                if std::mem::take(&mut step.back_to_single) {
                    step.single = self.use_single;
                }
                Next::RaiseDamping
            }
            // A pivot lost in single precision, or a value out of its range: this step in
            // double precision, at the same damping (the damping path stays that of the direct
            // solve until a double factorization has confirmed the step's matrix indefinite;
            // after that a single-precision failure is taken as the same indefiniteness).
            Factored::NotPositiveDefinite | Factored::OutOfRange if step.single => {
                stats.single_fallbacks += 1;
                if res == Factored::OutOfRange {
                    stats.single_fallbacks_range += 1;
                } else {
                    step.confirming = true;
                }
                step.single = false;
                Next::Refactor
            }
            _ => Next::Fail,
        }
    }

    /// The step's single-precision factor preconditioned it too poorly: the step is factored
    /// again in double precision.
    pub fn poorly_preconditioned(&mut self, step: &mut StepPrecision, stats: &mut SolveStats) {
        stats.single_fallbacks += 1;
        stats.single_fallbacks_poor += 1;
        self.poor += 1;
        tracing::debug!("single-precision factor not accurate enough; double precision");
        step.single = false;
        // Ill-conditioned beyond single precision: stop paying for the wasted iterations.
        if self.poor >= SINGLE_MAX_POOR {
            self.use_single = false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Factored::{NotPositiveDefinite as Npd, Ok as Fine, OutOfRange};

    /// Runs one step's factorizations, the outcomes in order, checking the precision each was
    /// asked in (`true`: single) and what followed; returns the step's last state.
    fn run_step(p: &mut Precision, stats: &mut SolveStats, seq: &[(bool, Factored, Next)]) -> StepPrecision {
        let mut st = p.step(stats);
        for (k, &(single, res, next)) in seq.iter().enumerate() {
            assert_eq!(st.single, single, "factorization {k} of {seq:?}");
            assert_eq!(p.factored(&mut st, res, stats), next, "factorization {k} of {seq:?}");
        }
        st
    }

    /// A confirmed indefinite step: single fails, double fails, the damping is raised and the
    /// retry is single again.
    const CONFIRMED: [(bool, Factored, Next); 3] =
        [(true, Npd, Next::Refactor), (false, Npd, Next::RaiseDamping), (true, Fine, Next::Solve)];
    /// A trusted failure: single fails and the damping is raised at once.
    const TRUSTED: [(bool, Factored, Next); 2] = [(true, Npd, Next::RaiseDamping), (true, Fine, Next::Solve)];
    /// A lost pivot: single fails, double succeeds.
    const LOST: [(bool, Factored, Next); 2] = [(true, Npd, Next::Refactor), (false, Fine, Next::Solve)];

    #[test]
    fn failures_are_confirmed_until_the_trust_then_one_in_eight() {
        let (mut p, mut stats) = (Precision::new(true), SolveStats::default());
        for _ in 0..SINGLE_TRUST_AFTER {
            assert!(!p.trusted(&stats));
            run_step(&mut p, &mut stats, &CONFIRMED);
        }
        assert_eq!(stats.single_fallbacks_indefinite, SINGLE_TRUST_AFTER);
        // Trusted: SINGLE_RECHECK_EVERY − 1 failures at once, then one confirmed again.
        for round in 0..3 {
            for _ in 0..SINGLE_RECHECK_EVERY - 1 {
                assert!(p.trusted(&stats), "round {round}");
                run_step(&mut p, &mut stats, &TRUSTED);
            }
            assert!(!p.trusted(&stats));
            run_step(&mut p, &mut stats, &CONFIRMED);
        }
        assert_eq!(stats.single_fallbacks_indefinite, SINGLE_TRUST_AFTER + 3);
        assert_eq!(stats.single_indefinite_unconfirmed, 3 * (SINGLE_RECHECK_EVERY - 1));
        assert_eq!(stats.single_fallbacks_pivot, 0);
        assert!(!stats.single_trust_ended && p.single());
    }

    #[test]
    fn a_recheck_that_finds_a_lost_pivot_ends_the_trust() {
        let (mut p, mut stats) = (Precision::new(true), SolveStats::default());
        for _ in 0..SINGLE_TRUST_AFTER {
            run_step(&mut p, &mut stats, &CONFIRMED);
        }
        for _ in 0..SINGLE_RECHECK_EVERY - 1 {
            run_step(&mut p, &mut stats, &TRUSTED);
        }
        // The recheck: a lost pivot.
        assert!(!p.trusted(&stats));
        run_step(&mut p, &mut stats, &LOST);
        assert!(stats.single_trust_ended);
        assert_eq!(stats.single_fallbacks_pivot, 1);
        // From then on every failure is confirmed, however many follow.
        for _ in 0..2 * SINGLE_RECHECK_EVERY {
            assert!(!p.trusted(&stats));
            run_step(&mut p, &mut stats, &CONFIRMED);
        }
        assert_eq!(stats.single_indefinite_unconfirmed, SINGLE_RECHECK_EVERY - 1);
    }

    #[test]
    fn lost_pivots_before_the_confirmations_keep_failures_confirmed() {
        let (mut p, mut stats) = (Precision::new(true), SolveStats::default());
        run_step(&mut p, &mut stats, &LOST);
        for _ in 0..4 {
            run_step(&mut p, &mut stats, &CONFIRMED);
        }
        assert!(!p.trusted(&stats));
        // A later lost pivot is not the end of a trust that never began.
        run_step(&mut p, &mut stats, &LOST);
        assert!(!stats.single_trust_ended);
        assert_eq!(stats.single_fallbacks_pivot, 2);
    }

    #[test]
    fn the_solve_goes_on_in_double_after_the_lost_pivots_limit() {
        let (mut p, mut stats) = (Precision::new(true), SolveStats::default());
        for k in 0..SINGLE_MAX_LOST_PIVOTS {
            assert!(p.single(), "after {k} lost pivots");
            run_step(&mut p, &mut stats, &LOST);
        }
        assert!(!p.single());
        assert_eq!(stats.single_fallbacks_pivot, SINGLE_MAX_LOST_PIVOTS);
        // A double-precision step: a failure raises the damping, not counted as a fallback.
        run_step(&mut p, &mut stats, &[(false, Npd, Next::RaiseDamping), (false, Fine, Next::Solve)]);
        assert_eq!(stats.single_fallbacks, SINGLE_MAX_LOST_PIVOTS);
        assert_eq!(stats.single_indefinite_unconfirmed, 0);
    }

    #[test]
    fn a_confirmation_returns_to_single_precision_once() {
        let (mut p, mut stats) = (Precision::new(true), SolveStats::default());
        // Confirmed, the retry in single fails as the same indefiniteness, then out of range:
        // the rest of the step in double precision.
        run_step(
            &mut p,
            &mut stats,
            &[
                (true, Npd, Next::Refactor),
                (false, Npd, Next::RaiseDamping),
                (true, Npd, Next::RaiseDamping),
                (true, OutOfRange, Next::Refactor),
                (false, Npd, Next::RaiseDamping),
                (false, Fine, Next::Solve),
            ],
        );
        assert_eq!(
            (stats.single_fallbacks, stats.single_fallbacks_indefinite, stats.single_fallbacks_range),
            (2, 1, 1)
        );
        assert_eq!(stats.single_indefinite_unconfirmed, 1);
        // Another failure: an error the precision does not explain.
        run_step(&mut p, &mut stats, &[(true, Factored::Other, Next::Fail)]);
    }

    #[test]
    fn poor_preconditioners_turn_the_solve_to_double() {
        let (mut p, mut stats) = (Precision::new(true), SolveStats::default());
        for k in 0..SINGLE_MAX_POOR {
            assert!(p.single(), "after {k}");
            let mut st = run_step(&mut p, &mut stats, &[(true, Fine, Next::Solve)]);
            p.poorly_preconditioned(&mut st, &mut stats);
            assert!(!st.single);
            assert_eq!(p.factored(&mut st, Fine, &mut stats), Next::Solve);
        }
        assert!(!p.single());
        assert_eq!((stats.single_fallbacks, stats.single_fallbacks_poor), (SINGLE_MAX_POOR, SINGLE_MAX_POOR));
    }
}
