//! "Did you mean ...?": the one rule every message uses to guess the name a typo meant. A leaf
//! module, so that parameters, environments, sweep files and datasets share it without
//! depending on each other.

/// Edit distance (insertions, deletions, substitutions, and swaps of two neighbouring letters,
/// the commonest typo: `rnu` is one edit from `run`) between two short words.
pub fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    // Three rows of the optimal-string-alignment table: two back, previous, current.
    let mut before: Vec<usize> = vec![0; b.len() + 1];
    let mut previous: Vec<usize> = (0..=b.len()).collect();
    for i in 1..=a.len() {
        let mut row = vec![i; b.len() + 1];
        for j in 1..=b.len() {
            let substitute = previous[j - 1] + usize::from(a[i - 1] != b[j - 1]);
            let mut d = substitute.min(previous[j] + 1).min(row[j - 1] + 1);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                d = d.min(before[j - 2] + 1);
            }
            row[j] = d;
        }
        before = std::mem::replace(&mut previous, row);
    }
    previous[b.len()]
}

/// Case and `-`/`_` do not count as typos: `Alpha-MF` is `alpha_mf`.
fn normalise(word: &str) -> String {
    word.to_lowercase().replace('-', "_")
}

/// The candidate closest to `word`, if it is a plausible typo: at most one letter in three
/// wrong, plus one, and at least one letter right. Whole names come first; only when none is
/// close does one `_`-separated word of a name count (`cost` for `cost_total`). Ties go to the
/// shorter name.
pub fn closest<'a>(word: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let word = normalise(word.trim());
    // Nothing typed is no typo of anything.
    if word.is_empty() {
        return None;
    }
    let close = |part: &str| {
        let (d, len) = (edit_distance(&word, part), part.chars().count());
        (d < len && d <= 1 + len / 3).then_some(d)
    };
    let candidates: Vec<&str> = candidates.into_iter().collect();
    let best = |by_word: bool| {
        candidates
            .iter()
            .filter_map(|&c| {
                let name = normalise(c);
                let d = if by_word {
                    name.split('_').filter_map(close).min()
                } else {
                    close(&name)
                };
                d.map(|d| (d, c.len(), c))
            })
            .min()
            .map(|(_, _, c)| c)
    };
    best(false).or_else(|| best(true))
}

/// `did you mean 'x'? ` for the closest candidate, or nothing when none is close.
pub fn hint<'a>(word: &str, candidates: impl IntoIterator<Item = &'a str>) -> String {
    closest(word, candidates).map_or_else(String::new, |c| format!("did you mean '{c}'? "))
}

/// The values of `values` listed more than once, each once, in the order of their first
/// listing: (index of that first listing, `twice` or `N times`). The one rule of the warnings
/// for a value repeated in a sweep file's `[grid]` and on the command line (`--controller
/// ec,ec`).
pub fn repeats<T: PartialEq>(values: &[T]) -> Vec<(usize, String)> {
    (0..values.len())
        .filter(|&i| !values[..i].contains(&values[i]))
        .filter_map(|i| {
            let times = values.iter().filter(|v| **v == values[i]).count();
            match times {
                1 => None,
                2 => Some((i, "twice".to_string())),
                n => Some((i, format!("{n} times"))),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_typo_in_a_short_name_is_caught_and_unrelated_words_are_not() {
        assert_eq!(closest("taw", ["tau", "task"]), Some("tau"));
        assert_eq!(closest("xyz", ["tau", "task"]), None);
        assert_eq!(closest("tidy3", ["tidy1", "tidy2"]), Some("tidy1"));
        assert_eq!(closest("gridworld", ["tidy1", "tidy2"]), None);
        assert_eq!(closest("gaol", ["init", "goal", "new_goal"]), Some("goal"));
        assert_eq!(
            closest("newgoal", ["init", "goal", "new_goal"]),
            Some("new_goal")
        );
    }

    #[test]
    fn case_dashes_and_single_words_of_a_name_count() {
        let names = ["total_reward", "cost_total", "mean_entropy_chosen"];
        assert_eq!(closest("total_rewrd", names), Some("total_reward"));
        assert_eq!(closest("COST_TOTAL", names), Some("cost_total"));
        assert_eq!(closest("cost", names), Some("cost_total"));
        assert_eq!(closest("banana", names), None);
        assert_eq!(closest("", ["q_init", "tau", "q"]), None);
        assert_eq!(closest("kapa", ["kappa_coeff", "tau"]), Some("kappa_coeff"));
        assert_eq!(closest("kappa-coef", ["kappa_coeff"]), Some("kappa_coeff"));
        assert_eq!(
            closest("contoller", ["controller", "task"]),
            Some("controller")
        );
    }

    #[test]
    fn repeats_are_named_once_at_their_first_listing() {
        let listed = ["ec", "mf", "ec", "rnd", "mf", "ec"];
        assert_eq!(
            repeats(&listed),
            vec![(0, "3 times".to_string()), (1, "twice".to_string())]
        );
        assert!(repeats(&["a", "b"]).is_empty());
    }

    #[test]
    fn edit_distance_counts_insertions_deletions_and_substitutions() {
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("abc", "abc"), 0);
        assert_eq!(edit_distance("rnu", "run"), 1);
        assert_eq!(closest("rnu", ["env", "run", "stats"]), Some("run"));
    }
}
