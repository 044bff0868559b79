//! Pareto analysis of sweep results over several objectives (e.g. maximise total reward,
//! minimise cost and interactions): objective parsing, dominance, non-dominated sorting into
//! fronts (Deb et al. 2002) and a scale-free knee point on a front.
//!
//! Points are rows of objective values in the order of the `Direction` slice; every function
//! takes any slice of rows (`Vec<f64>`, arrays, ...). A point containing NaN neither dominates
//! nor is dominated, so it always lands on the first front: missing values are never hidden
//! behind other points, and the caller decides whether to drop them first.

use std::fmt;
use std::str::FromStr;

/// Whether larger or smaller values of an objective are better.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Larger is better.
    Maximize,
    /// Smaller is better.
    Minimize,
}

/// Spellings accepted for a direction, for error messages.
const DIRECTION_SPELLINGS: &str = "max, min, maximize or minimize";

impl Direction {
    /// `true` when `a` is strictly better than `b` in this direction.
    fn better(self, a: f64, b: f64) -> bool {
        match self {
            Direction::Maximize => a > b,
            Direction::Minimize => a < b,
        }
    }

    /// The short spelling, `max` or `min`.
    pub fn as_str(self) -> &'static str {
        match self {
            Direction::Maximize => "max",
            Direction::Minimize => "min",
        }
    }
}

impl fmt::Display for Direction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for Direction {
    type Err = ObjectiveParseError;

    /// Parses `max`, `min`, `maximize` or `minimize` (ASCII case-insensitive, surrounding
    /// whitespace ignored).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim();
        if t.eq_ignore_ascii_case("max") || t.eq_ignore_ascii_case("maximize") {
            Ok(Direction::Maximize)
        } else if t.eq_ignore_ascii_case("min") || t.eq_ignore_ascii_case("minimize") {
            Ok(Direction::Minimize)
        } else {
            Err(ObjectiveParseError::UnknownDirection {
                text: s.to_owned(),
                direction: t.to_owned(),
            })
        }
    }
}

/// A named objective and its direction, written `NAME:DIR` on the command line (e.g.
/// `total_reward:max`, `total_cost:min`).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Objective {
    /// Column name of the objective in the results.
    pub name: String,
    /// Whether larger or smaller values are better.
    pub direction: Direction,
}

impl Objective {
    /// Parses `NAME:DIR`, where `DIR` is `max`, `min`, `maximize` or `minimize` (ASCII
    /// case-insensitive). The split is at the last `:`, and whitespace around either part is
    /// ignored. Errors name the bad text and what is accepted.
    pub fn parse(text: &str) -> Result<Objective, ObjectiveParseError> {
        let Some((name, dir)) = text.rsplit_once(':') else {
            return Err(ObjectiveParseError::MissingDirection {
                text: text.to_owned(),
            });
        };
        let name = name.trim();
        if name.is_empty() {
            return Err(ObjectiveParseError::EmptyName {
                text: text.to_owned(),
            });
        }
        let direction = dir.parse::<Direction>().map_err(|_| {
            // Re-issue with the whole text, so the message shows the full argument.
            ObjectiveParseError::UnknownDirection {
                text: text.to_owned(),
                direction: dir.trim().to_owned(),
            }
        })?;
        Ok(Objective {
            name: name.to_owned(),
            direction,
        })
    }
}

impl FromStr for Objective {
    type Err = ObjectiveParseError;

    /// Same as [`Objective::parse`].
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Objective::parse(s)
    }
}

impl fmt::Display for Objective {
    /// Writes `NAME:max` or `NAME:min`, which parses back to the same objective.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.name, self.direction)
    }
}

/// A malformed objective specification.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ObjectiveParseError {
    /// No `:DIR` part.
    MissingDirection {
        /// The whole text given.
        text: String,
    },
    /// Nothing before the `:`.
    EmptyName {
        /// The whole text given.
        text: String,
    },
    /// The part after the last `:` is not a known direction.
    UnknownDirection {
        /// The whole text given.
        text: String,
        /// The unrecognised direction.
        direction: String,
    },
}

impl fmt::Display for ObjectiveParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ObjectiveParseError::MissingDirection { text } => write!(
                f,
                "objective '{text}' has no direction: write NAME:DIR with DIR one of \
                 {DIRECTION_SPELLINGS} (e.g. total_reward:max)"
            ),
            ObjectiveParseError::EmptyName { text } => write!(
                f,
                "objective '{text}' has no name before ':': write NAME:DIR (e.g. total_cost:min)"
            ),
            ObjectiveParseError::UnknownDirection { text, direction } => write!(
                f,
                "objective '{text}' has unknown direction '{direction}': expected \
                 {DIRECTION_SPELLINGS}"
            ),
        }
    }
}

impl std::error::Error for ObjectiveParseError {}

/// `true` when `a` Pareto-dominates `b`: at least as good in every objective and strictly
/// better in at least one. Equal points do not dominate each other. If either point contains
/// NaN the answer is `false`: NaN never dominates and is never dominated.
///
/// # Panics
/// If `a`, `b` and `dirs` do not all have the same length.
pub fn dominates(a: &[f64], b: &[f64], dirs: &[Direction]) -> bool {
    assert!(
        a.len() == dirs.len() && b.len() == dirs.len(),
        "dominates: points have {} and {} values but there are {} objectives",
        a.len(),
        b.len(),
        dirs.len()
    );
    if a.iter().chain(b).any(|v| v.is_nan()) {
        return false;
    }
    let mut strictly_better_somewhere = false;
    for ((&ai, &bi), &d) in a.iter().zip(b).zip(dirs) {
        if d.better(bi, ai) {
            return false;
        }
        strictly_better_somewhere |= d.better(ai, bi);
    }
    strictly_better_somewhere
}

/// Non-domination rank of every point (fast non-dominated sort, Deb et al. 2002, O(n² m)):
/// rank 0 is the Pareto front, rank 1 the front once rank 0 is removed, and so on. Identical
/// points get the same rank; a point with NaN gets rank 0 (see [`dominates`]).
///
/// # Panics
/// If a point does not have one value per objective.
pub fn non_dominated_ranks<P: AsRef<[f64]>>(points: &[P], dirs: &[Direction]) -> Vec<usize> {
    let n = points.len();
    for (i, p) in points.iter().enumerate() {
        assert_eq!(
            p.as_ref().len(),
            dirs.len(),
            "non_dominated_ranks: point {i} has {} values but there are {} objectives",
            p.as_ref().len(),
            dirs.len()
        );
    }
    // dominated[i]: the points i dominates; dominator_count[i]: how many points dominate i.
    let mut dominated: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut dominator_count = vec![0usize; n];
    for i in 0..n {
        for j in (i + 1)..n {
            let (pi, pj) = (points[i].as_ref(), points[j].as_ref());
            if dominates(pi, pj, dirs) {
                dominated[i].push(j);
                dominator_count[j] += 1;
            } else if dominates(pj, pi, dirs) {
                dominated[j].push(i);
                dominator_count[i] += 1;
            }
        }
    }
    let mut ranks = vec![0usize; n];
    let mut current: Vec<usize> = (0..n).filter(|&i| dominator_count[i] == 0).collect();
    let mut rank = 0;
    while !current.is_empty() {
        let mut next = Vec::new();
        for &i in &current {
            ranks[i] = rank;
            for &j in &dominated[i] {
                dominator_count[j] -= 1;
                if dominator_count[j] == 0 {
                    next.push(j);
                }
            }
        }
        current = next;
        rank += 1;
    }
    ranks
}

/// Indices of the Pareto front (rank 0 of [`non_dominated_ranks`]), ascending.
pub fn pareto_front<P: AsRef<[f64]>>(points: &[P], dirs: &[Direction]) -> Vec<usize> {
    non_dominated_ranks(points, dirs)
        .iter()
        .enumerate()
        .filter(|&(_, &r)| r == 0)
        .map(|(i, _)| i)
        .collect()
}

/// Knee point of a front: the index of the point closest (Euclidean) to the ideal point after
/// min–max normalisation, or `None` if no point is eligible.
///
/// Rule: each objective is rescaled over the given points to [0, 1] with 1 the best value
/// (`(v - min) / (max - min)` when maximising, `(max - v) / (max - min)` when minimising), so
/// the result does not depend on units or scales; an objective that is constant over the
/// points (range 0) counts as 1 (best) for all of them. The knee is the point nearest to
/// `(1, ..., 1)`; ties go to the lowest index. Points with a non-finite value (NaN or ±inf)
/// are not eligible and do not enter the min/max.
///
/// Meant for the points of one front (e.g. rank 0), but defined for any set.
///
/// # Panics
/// If a point does not have one value per objective.
pub fn knee_point<P: AsRef<[f64]>>(front_points: &[P], dirs: &[Direction]) -> Option<usize> {
    let eligible: Vec<usize> = front_points
        .iter()
        .enumerate()
        .filter(|(i, p)| {
            let p = p.as_ref();
            assert_eq!(
                p.len(),
                dirs.len(),
                "knee_point: point {i} has {} values but there are {} objectives",
                p.len(),
                dirs.len()
            );
            p.iter().all(|v| v.is_finite())
        })
        .map(|(i, _)| i)
        .collect();
    let ranges: Vec<(f64, f64)> = (0..dirs.len())
        .map(|k| {
            eligible
                .iter()
                .map(|&i| front_points[i].as_ref()[k])
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v), hi.max(v))
                })
        })
        .collect();
    let distance_to_ideal = |i: usize| -> f64 {
        let p = front_points[i].as_ref();
        p.iter()
            .zip(dirs)
            .zip(&ranges)
            .map(|((&v, &d), &(lo, hi))| {
                let range = hi - lo;
                let goodness = if range > 0.0 {
                    match d {
                        Direction::Maximize => (v - lo) / range,
                        Direction::Minimize => (hi - v) / range,
                    }
                } else {
                    1.0
                };
                (1.0 - goodness) * (1.0 - goodness)
            })
            .sum::<f64>()
    };
    let mut best: Option<(usize, f64)> = None;
    for i in eligible {
        let d = distance_to_ideal(i);
        // Strictly smaller only, so ties keep the lowest index.
        if best.is_none_or(|(_, bd)| d < bd) {
            best = Some((i, d));
        }
    }
    best.map(|(i, _)| i)
}

#[cfg(test)]
mod tests {
    use super::*;
    use Direction::{Maximize as Max, Minimize as Min};

    #[test]
    fn objectives_parse_every_accepted_spelling() {
        for (text, dir) in [
            ("total_reward:max", Max),
            ("total_reward:maximize", Max),
            ("total_cost:min", Min),
            ("total_cost:MINIMIZE", Min),
            (" interactions : Min ", Min),
        ] {
            let o = Objective::parse(text).unwrap();
            assert_eq!(o.direction, dir, "{text}");
            assert_eq!(o.name, text.rsplit_once(':').unwrap().0.trim());
        }
        let o: Objective = "a:b:max".parse().unwrap();
        assert_eq!(o.name, "a:b", "the split is at the last colon");
    }

    #[test]
    fn objective_display_round_trips_through_parse() {
        let o = Objective::parse("total_reward:maximize").unwrap();
        assert_eq!(o.to_string(), "total_reward:max");
        assert_eq!(Objective::parse(&o.to_string()).unwrap(), o);
    }

    #[test]
    fn bad_objectives_are_rejected_with_the_text_and_the_accepted_spellings() {
        let e = Objective::parse("total_reward:best").unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("'total_reward:best'") && msg.contains("'best'"),
            "{msg}"
        );
        assert!(msg.contains("max, min, maximize or minimize"), "{msg}");

        let e = Objective::parse("total_reward").unwrap_err();
        assert!(matches!(e, ObjectiveParseError::MissingDirection { .. }));
        assert!(
            e.to_string().contains("'total_reward' has no direction"),
            "{e}"
        );

        let e = Objective::parse(":max").unwrap_err();
        assert!(matches!(e, ObjectiveParseError::EmptyName { .. }));
        assert!(e.to_string().contains("no name"), "{e}");

        assert!(Objective::parse("cost:").is_err());
    }

    #[test]
    fn dominance_needs_no_worse_everywhere_and_better_somewhere() {
        let dirs = [Max, Min];
        assert!(dominates(&[2.0, 1.0], &[1.0, 2.0], &dirs));
        assert!(
            dominates(&[2.0, 1.0], &[1.0, 1.0], &dirs),
            "better in one, equal in other"
        );
        assert!(!dominates(&[2.0, 1.0], &[2.0, 1.0], &dirs), "equal points");
        assert!(!dominates(&[2.0, 2.0], &[1.0, 1.0], &dirs), "a trade-off");
        assert!(!dominates(&[1.0, 2.0], &[2.0, 1.0], &dirs));
    }

    #[test]
    fn nan_never_dominates_and_is_never_dominated() {
        let dirs = [Max, Max];
        assert!(!dominates(&[f64::NAN, 10.0], &[0.0, 0.0], &dirs));
        assert!(!dominates(&[10.0, 10.0], &[f64::NAN, 0.0], &dirs));
        let ranks = non_dominated_ranks(&[vec![10.0, 10.0], vec![f64::NAN, 0.0]], &dirs);
        assert_eq!(ranks, vec![0, 0]);
    }

    #[test]
    #[should_panic(expected = "objectives")]
    fn dominance_panics_on_points_of_the_wrong_length() {
        dominates(&[1.0], &[1.0, 2.0], &[Max, Max]);
    }

    #[test]
    fn two_objective_ranks_peel_fronts_in_order() {
        // Maximise reward, minimise cost.
        let points = [
            [10.0, 5.0], // 0: front
            [8.0, 3.0],  // 1: front
            [5.0, 1.0],  // 2: front
            [7.0, 4.0],  // 3: dominated by 1 only -> rank 1
            [4.0, 2.0],  // 4: dominated by 2 -> rank 1
            [6.0, 6.0],  // 5: dominated by 0, 1, 3 -> rank 2
            [3.0, 7.0],  // 6: dominated by 5 -> rank 3
        ];
        assert_eq!(
            non_dominated_ranks(&points, &[Max, Min]),
            vec![0, 0, 0, 1, 1, 2, 3]
        );
        assert_eq!(pareto_front(&points, &[Max, Min]), vec![0, 1, 2]);
    }

    #[test]
    fn three_objective_ranks_match_a_hand_built_example() {
        // Maximise reward, minimise cost, minimise interactions.
        let points = vec![
            vec![10.0, 100.0, 50.0], // 0: best reward
            vec![6.0, 20.0, 50.0],   // 1: cheapest
            vec![6.0, 60.0, 0.0],    // 2: fewest interactions
            vec![6.0, 60.0, 10.0],   // 3: dominated by 2 -> rank 1
            vec![9.0, 100.0, 60.0],  // 4: dominated by 0 -> rank 1
            vec![5.0, 60.0, 10.0],   // 5: dominated by 3 -> rank 2
        ];
        assert_eq!(
            non_dominated_ranks(&points, &[Max, Min, Min]),
            vec![0, 0, 0, 1, 1, 2]
        );
    }

    #[test]
    fn identical_points_share_their_rank() {
        let points = [[1.0, 1.0], [1.0, 1.0], [0.0, 0.0], [0.0, 0.0]];
        assert_eq!(non_dominated_ranks(&points, &[Max, Max]), vec![0, 0, 1, 1]);
    }

    #[test]
    fn ranks_of_no_points_are_empty() {
        let points: [[f64; 2]; 0] = [];
        assert!(non_dominated_ranks(&points, &[Max, Max]).is_empty());
        assert_eq!(knee_point(&points, &[Max, Max]), None);
    }

    /// Tiny deterministic generator for the property test (no dependencies).
    struct Lcg(u64);

    impl Lcg {
        /// A value in [0, 1), quantised to 1/16 so that ties and duplicates occur.
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((self.0 >> 33) % 16) as f64 / 16.0
        }
    }

    #[test]
    fn ranks_agree_with_a_brute_force_definition_on_random_points() {
        // 200 random clouds of 1 to 40 points in 1 to 4 objectives with mixed directions.
        let mut rng = Lcg(12345);
        for trial in 0..200 {
            let m = 1 + trial % 4;
            let n = 1 + (trial * 7) % 40;
            let dirs: Vec<Direction> = (0..m)
                .map(|k| if (trial + k) % 2 == 0 { Max } else { Min })
                .collect();
            let points: Vec<Vec<f64>> = (0..n)
                .map(|_| (0..m).map(|_| rng.next()).collect())
                .collect();
            let ranks = non_dominated_ranks(&points, &dirs);
            let front = pareto_front(&points, &dirs);
            for i in 0..n {
                let dominated_by_front = front
                    .iter()
                    .any(|&f| dominates(&points[f], &points[i], &dirs));
                let dominated_by_any = (0..n).any(|j| dominates(&points[j], &points[i], &dirs));
                if ranks[i] == 0 {
                    assert!(
                        !dominated_by_any,
                        "trial {trial}: front point {i} dominated"
                    );
                } else {
                    assert!(dominated_by_front, "trial {trial}: point {i} not dominated");
                    // Rank r means: dominated by some rank r-1 point, by none of rank >= r.
                    let r = ranks[i];
                    assert!(
                        (0..n)
                            .any(|j| ranks[j] == r - 1 && dominates(&points[j], &points[i], &dirs)),
                        "trial {trial}: point {i} of rank {r} has no dominator of rank {}",
                        r - 1
                    );
                }
                for j in 0..n {
                    if dominates(&points[j], &points[i], &dirs) {
                        assert!(ranks[j] < ranks[i], "trial {trial}: {j} dominates {i}");
                    }
                }
            }
        }
    }

    #[test]
    fn knee_is_the_point_nearest_the_ideal_after_normalisation() {
        // Maximise reward, minimise cost. Normalised: 0 -> (1, 0), 1 -> (0.8, 0.75),
        // 2 -> (0, 1). Point 1 is nearest (1, 1).
        let front = [[100.0, 50.0], [80.0, 20.0], [0.0, 10.0]];
        assert_eq!(knee_point(&front, &[Max, Min]), Some(1));
    }

    #[test]
    fn knee_does_not_depend_on_units() {
        let front = [[100.0, 50.0], [80.0, 20.0], [0.0, 10.0]];
        let rescaled: Vec<Vec<f64>> = front
            .iter()
            .map(|p| vec![p[0] * 1e6 + 3.0, p[1] * 1e-3 - 7.0])
            .collect();
        assert_eq!(
            knee_point(&rescaled, &[Max, Min]),
            knee_point(&front, &[Max, Min])
        );
    }

    #[test]
    fn knee_ties_go_to_the_lowest_index() {
        // Normalised to (1, 0) and (0, 1): both at distance 1 from the ideal.
        let symmetric = [[1.0, 0.0], [0.0, 1.0]];
        assert_eq!(knee_point(&symmetric, &[Max, Max]), Some(0));
        let duplicates = [[0.0, 1.0], [0.5, 0.5], [0.5, 0.5], [1.0, 0.0]];
        assert_eq!(knee_point(&duplicates, &[Max, Max]), Some(1));
    }

    #[test]
    fn knee_treats_a_constant_objective_as_best_for_all() {
        // Objective 1 is constant; the knee is decided by objective 0 alone.
        let front = [[1.0, 5.0], [3.0, 5.0], [2.0, 5.0]];
        assert_eq!(knee_point(&front, &[Max, Min]), Some(1));
        assert_eq!(knee_point(&[[7.0, 7.0]], &[Max, Min]), Some(0));
    }

    #[test]
    fn knee_skips_points_with_non_finite_values() {
        let front = [
            [f64::NAN, 1.0],
            [1.0, 0.0],
            [0.0, f64::INFINITY],
            [0.0, 1.0],
        ];
        // Eligible: 1 -> (1, 0) and 3 -> (0, 1), tie, lowest index wins.
        assert_eq!(knee_point(&front, &[Max, Max]), Some(1));
        assert_eq!(knee_point(&[[f64::NAN, 1.0]], &[Max, Max]), None);
    }
}
