//! Splitting a sweep between independent processes: shard `I/N` owns the configurations whose
//! index is `I` modulo `N` (round robin, so slow and fast parts of the grid spread evenly), with
//! all their seeds. Shards write disjoint parts of one dataset; their union is the whole sweep.

use std::fmt;
use std::str::FromStr;

/// One of `count` disjoint slices of a sweep's configurations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard, from 0 to `count - 1`.
    pub index: u32,
    /// Number of shards.
    pub count: u32,
}

/// A shard that cannot be worked out.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ShardError {
    /// `--shard` is not `I/N`.
    #[error("invalid shard '{0}': expected I/N with 0 <= I < N, e.g. --shard 0/4")]
    Syntax(String),
    /// The index is not below the count.
    #[error("shard index {index} is not below the shard count {count}: {hint}")]
    OutOfRange {
        /// The index.
        index: u64,
        /// The count.
        count: u64,
        /// Where the numbers came from and how to fix them.
        hint: String,
    },
    /// An environment variable is missing or not a number.
    #[error("{0}")]
    Env(String),
}

impl Shard {
    /// The whole sweep in one process.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Whether this shard runs configuration `config`.
    pub fn owns(&self, config: u64) -> bool {
        config % u64::from(self.count) == u64::from(self.index)
    }

    /// The configurations of this shard among `total`, in increasing order.
    pub fn configs(&self, total: u64) -> impl Iterator<Item = u64> + use<> {
        (u64::from(self.index)..total).step_by(self.count as usize)
    }

    /// Number of configurations of this shard among `total`, counted without enumerating them.
    pub fn count_of(&self, total: u64) -> u64 {
        let (index, count) = (u64::from(self.index), u64::from(self.count));
        if index >= total {
            0
        } else {
            (total - index - 1) / count + 1
        }
    }

    /// A shard after checking `index < count`.
    pub fn new(index: u64, count: u64, hint: &str) -> Result<Shard, ShardError> {
        if count == 0 || index >= count {
            return Err(ShardError::OutOfRange {
                index,
                count,
                hint: hint.to_string(),
            });
        }
        let count = u32::try_from(count)
            .map_err(|_| ShardError::Env(format!("shard count {count} is too large")))?;
        Ok(Shard {
            index: index as u32,
            count,
        })
    }

    /// The shard given by the environment: Slurm job arrays (`SLURM_ARRAY_TASK_ID`,
    /// `SLURM_ARRAY_TASK_COUNT`, minus `SLURM_ARRAY_TASK_MIN` so `--array=1-4` works too) or a
    /// Kubernetes indexed Job (`JOB_COMPLETION_INDEX`, with the count from `count` or
    /// `MBMF_SHARD_COUNT`). `var` reads a variable (`std::env::var` in the program).
    pub fn from_env(
        var: impl Fn(&str) -> Option<String>,
        count: Option<u32>,
    ) -> Result<Shard, ShardError> {
        let number = |name: &str| -> Result<Option<u64>, ShardError> {
            match var(name) {
                None => Ok(None),
                Some(s) => s.trim().parse::<u64>().map(Some).map_err(|_| {
                    ShardError::Env(format!("{name}='{s}' is not a whole number >= 0"))
                }),
            }
        };
        if let Some(id) = number("SLURM_ARRAY_TASK_ID")? {
            let n = number("SLURM_ARRAY_TASK_COUNT")?.ok_or_else(|| {
                ShardError::Env(
                    "SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not: submit the \
                     sweep as a job array (sbatch --array=0-(N-1))"
                        .into(),
                )
            })?;
            if let Some(c) = count
                && u64::from(c) != n
            {
                return Err(ShardError::Env(format!(
                    "--shard-count {c} disagrees with SLURM_ARRAY_TASK_COUNT={n}"
                )));
            }
            let min = number("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
            let step = number("SLURM_ARRAY_TASK_STEP")?.unwrap_or(1).max(1);
            let hint = format!(
                "SLURM_ARRAY_TASK_ID={id}, SLURM_ARRAY_TASK_MIN={min}, SLURM_ARRAY_TASK_STEP={step}, \
                 SLURM_ARRAY_TASK_COUNT={n}; submit a contiguous array such as --array=0-{}",
                n.saturating_sub(1)
            );
            if id < min || (id - min) % step != 0 {
                return Err(ShardError::OutOfRange {
                    index: id,
                    count: n,
                    hint,
                });
            }
            return Shard::new((id - min) / step, n, &hint);
        }
        if let Some(index) = number("JOB_COMPLETION_INDEX")? {
            let n = match count {
                Some(c) => u64::from(c),
                None => number("MBMF_SHARD_COUNT")?.ok_or_else(|| {
                    ShardError::Env(
                        "JOB_COMPLETION_INDEX is set (Kubernetes indexed Job) but the shard count \
                         is not: pass --shard-count N (the Job's completions) or set \
                         MBMF_SHARD_COUNT"
                            .into(),
                    )
                })?,
            };
            let hint = format!(
                "JOB_COMPLETION_INDEX={index} with {n} shards; set completions to the shard count"
            );
            return Shard::new(index, n, &hint);
        }
        Err(ShardError::Env(
            "--shard-from-env: neither SLURM_ARRAY_TASK_ID (Slurm job array) nor \
             JOB_COMPLETION_INDEX (Kubernetes indexed Job) is set; use --shard I/N to choose \
             the shard by hand"
                .into(),
        ))
    }
}

impl FromStr for Shard {
    type Err = ShardError;

    fn from_str(s: &str) -> Result<Shard, ShardError> {
        let syntax = || ShardError::Syntax(s.to_string());
        let (i, n) = s.split_once('/').ok_or_else(syntax)?;
        let i: u64 = i.trim().parse().map_err(|_| syntax())?;
        let n: u64 = n.trim().parse().map_err(|_| syntax())?;
        Shard::new(
            i,
            n,
            "shards are numbered from 0, so --shard I/N needs I < N",
        )
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_sizes_are_counted_as_enumerated() {
        for count in 1..6u32 {
            for index in 0..count {
                let shard = Shard { index, count };
                for total in 0..20u64 {
                    assert_eq!(shard.count_of(total), shard.configs(total).count() as u64);
                }
            }
        }
        let shard = Shard { index: 3, count: 7 };
        assert_eq!(shard.count_of(u64::MAX), (u64::MAX - 4) / 7 + 1);
    }

    fn env<'a>(pairs: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |name| {
            pairs
                .iter()
                .find(|(k, _)| *k == name)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    fn shard_text_parses_and_rejects_an_index_not_below_the_count() {
        assert_eq!("1/4".parse(), Ok(Shard { index: 1, count: 4 }));
        assert!(matches!(
            "4/4".parse::<Shard>(),
            Err(ShardError::OutOfRange { .. })
        ));
        assert!(matches!(
            "0/0".parse::<Shard>(),
            Err(ShardError::OutOfRange { .. })
        ));
        assert!(matches!("x".parse::<Shard>(), Err(ShardError::Syntax(_))));
    }

    #[test]
    fn shards_partition_the_configurations_round_robin() {
        let shards: Vec<Shard> = (0..3).map(|i| Shard { index: i, count: 3 }).collect();
        let mut all: Vec<u64> = shards.iter().flat_map(|s| s.configs(10)).collect();
        all.sort();
        assert_eq!(all, (0..10).collect::<Vec<_>>());
        assert_eq!(shards[1].configs(10).collect::<Vec<_>>(), vec![1, 4, 7]);
        assert!(shards[1].owns(7) && !shards[1].owns(8));
    }

    #[test]
    fn slurm_arrays_starting_at_one_are_shifted_by_their_minimum() {
        let vars = [
            ("SLURM_ARRAY_TASK_ID", "4"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
        ];
        assert_eq!(
            Shard::from_env(env(&vars), None),
            Ok(Shard { index: 3, count: 4 })
        );
    }

    #[test]
    fn a_slurm_id_beyond_the_count_is_refused_with_the_variables_named() {
        let vars = [
            ("SLURM_ARRAY_TASK_ID", "4"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ];
        let err = Shard::from_env(env(&vars), None).unwrap_err().to_string();
        assert!(err.contains("not below the shard count 4"), "{err}");
        assert!(err.contains("SLURM_ARRAY_TASK_ID=4"), "{err}");
    }

    #[test]
    fn kubernetes_indexed_jobs_need_a_shard_count() {
        let vars = [("JOB_COMPLETION_INDEX", "2")];
        let err = Shard::from_env(env(&vars), None).unwrap_err().to_string();
        assert!(err.contains("--shard-count"), "{err}");
        assert_eq!(
            Shard::from_env(env(&vars), Some(3)),
            Ok(Shard { index: 2, count: 3 })
        );
        let with_var = [("JOB_COMPLETION_INDEX", "2"), ("MBMF_SHARD_COUNT", "2")];
        assert!(Shard::from_env(env(&with_var), None).is_err());
    }

    #[test]
    fn no_scheduler_variables_is_an_error_that_suggests_shard() {
        let err = Shard::from_env(env(&[]), None).unwrap_err().to_string();
        assert!(err.contains("--shard I/N"), "{err}");
    }
}
