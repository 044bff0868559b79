//! Flags shared by the verbs that take a run's parameters, and their value parsers. Ranges are
//! checked by [`Params::validate`], so flags and sweep files share one set of rules.

use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow};
use clap::{Args, ValueEnum};

use crate::env::{self, Spec};
use crate::params::{
    ConfigError, Controller, CostModel, HumanParams, Interaction, Params, Profile, Selection,
    cli_flag,
};

/// Where a `json:` task's keyStates.txt and spaces.txt are, when not beside the model file.
#[derive(Debug, Clone, Args, Default)]
pub struct TaskFiles {
    /// keyStates.txt of a json: task, if not beside the model file.
    #[arg(long)]
    pub key_states: Option<PathBuf>,
    /// spaces.txt of a json: task, if not beside the model file.
    #[arg(long)]
    pub spaces: Option<PathBuf>,
}

/// On/off switch for flags that take a value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Switch {
    /// Enabled.
    On,
    /// Disabled.
    Off,
}

/// Every parameter of SPEC 3–4 as a flag; unset flags keep the SPEC default.
#[derive(Debug, Clone, Args, Default)]
pub struct ModelArgs {
    /// MF learning rate (Eq. 4), in (0, 1]. Default 0.6.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub alpha_mf: Option<f64>,
    /// MF discount, in [0, 1). Default 0.9.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub gamma_mf: Option<f64>,
    /// MB discount, in [0, 1). Default 0.95.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub gamma_mb: Option<f64>,
    /// Softmax temperature of MF, MB and the MC, > 0 (at least 1e-300). Default 0.02.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub tau: Option<f64>,
    /// Initial action values, from -1e12 to 1e12. Default 0 (paper).
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub q_init: Option<f64>,
    /// MB transition window N, 1 to 65535. Default 10.
    #[arg(long, value_parser = count, allow_negative_numbers = true)]
    pub window_n: Option<u32>,
    /// Value iteration stops when a sweep's summed |dQ| is below this, > 0. Default 0.01.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub vi_epsilon: Option<f64>,
    /// Cap on value-iteration sweeps per inference, >= 1. A call that reaches it stops unconverged
    /// and is counted in the vi_capped column. Default 10000.
    #[arg(long, value_parser = count, allow_negative_numbers = true)]
    pub vi_max_sweeps: Option<u32>,
    /// Weight of the new value in the moving averages, in (0, 1]. Default 0.6.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub filter_alpha: Option<f64>,
    /// kappa = exp(-kappa_coeff * H_MF in bits) (Eq. 7), >= 0. Default 9.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub kappa_coeff: Option<f64>,
    /// Normalise entropies by log2(|A|). Default on.
    #[arg(long, value_enum)]
    pub normalise_entropy: Option<Switch>,
    /// How the MC selects an expert. Default softmax (paper).
    #[arg(long, value_enum)]
    pub selection: Option<Selection>,
    /// How inference cost is measured. Default ops (deterministic).
    #[arg(long, value_enum)]
    pub cost_model: Option<CostModel>,
}

/// The simulated human's flags (SPEC 5).
#[derive(Debug, Clone, Args, Default)]
pub struct HumanArgs {
    /// A named human; the flags below override its fields.
    #[arg(long, value_enum)]
    pub profile: Option<Profile>,
    /// Interaction type. Default none.
    #[arg(long, value_enum)]
    pub interaction: Option<Interaction>,
    /// Interactions the human gives per run before stopping.
    #[arg(long, value_parser = count, allow_negative_numbers = true)]
    pub budget: Option<u32>,
    /// Bonus weight of a congratulation (or penalty of a punishment), 0 to 1e12. Default 0.1.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub zeta: Option<f64>,
    /// Probability that the human is inattentive at an opportunity, in [0, 1]. Default 0.1.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub forget: Option<f64>,
}

/// Most runs per controller of one `mbmf run` (every configuration is held in memory).
pub const MAX_RUNS: u64 = 1_000_000;

/// Most worker threads `--threads` accepts.
pub const MAX_THREADS: u64 = 4096;

/// Parses a number flag. Ranges are checked by [`Params::validate`], so flags and sweep files
/// share one set of rules; NaN and infinities parse here and are refused there.
pub fn number(text: &str) -> Result<f64, String> {
    text.trim()
        .parse::<f64>()
        .map_err(|_| "expected a number, such as 0.5 or 1e-3".to_string())
}

/// Parses a whole number in `min..=max`, saying which rule a bad value breaks.
pub fn whole(text: &str, min: u64, max: u64) -> Result<u64, String> {
    let range = if max == u64::MAX {
        format!("a whole number >= {min}")
    } else {
        format!("a whole number from {min} to {max}")
    };
    match text.trim().parse::<i128>() {
        Ok(n) if n < i128::from(min) => Err(format!("{n} is too small: expected {range}")),
        Ok(n) if n > i128::from(max) => Err(format!("{n} is too large: expected {range}")),
        Ok(n) => Ok(n as u64),
        Err(_) if text.trim().parse::<f64>().is_ok() => {
            Err(format!("not a whole number: expected {range}"))
        }
        Err(_) => Err(format!("expected {range}")),
    }
}

/// A count of steps, sweeps or interactions: 0 to 2^32 - 1.
pub fn count(text: &str) -> Result<u32, String> {
    whole(text, 0, u64::from(u32::MAX)).map(|n| n as u32)
}

/// `--runs`: 1 to [`MAX_RUNS`].
pub fn runs_count(text: &str) -> Result<u32, String> {
    whole(text, 1, MAX_RUNS).map(|n| n as u32)
}

/// `--seed`: any 64-bit unsigned integer.
pub fn seed(text: &str) -> Result<u64, String> {
    whole(text, 0, u64::MAX)
}

/// `--batch-size`: at least 1.
pub fn batch_size(text: &str) -> Result<usize, String> {
    whole(text, 1, usize::MAX as u64).map(|n| n as usize)
}

/// `--threads`: 1 to [`MAX_THREADS`].
pub fn threads_count(text: &str) -> Result<usize, String> {
    whole(text, 1, MAX_THREADS).map(|n| n as usize)
}

/// Checks, before any work, that `path` can be an output folder: its nearest existing ancestor
/// (the folder itself included) is a folder that can be written into. A file, a device such as
/// `/dev/null` or a read-only folder is a usage error naming `flag`, so no verb computes for
/// minutes and then fails on its first write.
pub fn check_out_dir(path: &Path, flag: &str) -> Result<(), super::Failure> {
    let refuse = |why: String| super::usage(anyhow!("{flag} {}: {why}", path.display()));
    let Some(existing) = path
        .ancestors()
        .map(|a| {
            if a.as_os_str().is_empty() {
                Path::new(".")
            } else {
                a
            }
        })
        .find(|a| std::fs::metadata(a).is_ok())
    else {
        return Err(refuse("no part of this path exists".into()));
    };
    let metadata = std::fs::metadata(existing).map_err(|e| refuse(e.to_string()))?;
    if !metadata.is_dir() {
        let what = if metadata.is_file() {
            "a file"
        } else {
            "a device, pipe or socket"
        };
        let whose = if existing == path {
            "it is".to_string()
        } else {
            format!("{} is", existing.display())
        };
        return Err(refuse(format!(
            "{whose} {what}, not a folder; give a folder to write into"
        )));
    }
    // Creating (and at once removing) a file is the only reliable test of write access.
    tempfile::Builder::new()
        .prefix(".mbmf-write-check")
        .tempfile_in(existing)
        .map_err(|e| refuse(format!("cannot write into {}: {e}", existing.display())))?;
    Ok(())
}

impl ModelArgs {
    /// Applies the flags that were given to `p`.
    pub fn apply(&self, p: &mut Params) {
        macro_rules! set {
            ($($field:ident),*) => { $( if let Some(v) = self.$field { p.$field = v; } )* };
        }
        set!(
            alpha_mf,
            gamma_mf,
            gamma_mb,
            tau,
            q_init,
            window_n,
            vi_epsilon,
            vi_max_sweeps
        );
        set!(filter_alpha, kappa_coeff);
        if let Some(s) = self.normalise_entropy {
            p.normalise_entropy = s == Switch::On;
        }
        if let Some(s) = self.selection {
            p.selection = s;
        }
        if let Some(c) = self.cost_model {
            p.cost_model = c;
        }
    }
}

impl HumanArgs {
    /// The human for `controller`: the profile's preset (or no interaction), then the flags.
    pub fn resolve(&self, controller: Controller) -> (HumanParams, Profile) {
        let (mut human, profile) = match self.profile {
            Some(p) => (p.human(controller).unwrap_or_default(), p),
            None => (HumanParams::default(), Profile::None),
        };
        let mut custom = false;
        if let Some(i) = self.interaction {
            human.interaction = i;
            custom = true;
        }
        if let Some(b) = self.budget {
            human.budget = b;
            custom = true;
        }
        if let Some(z) = self.zeta {
            human.zeta = z;
            custom = true;
        }
        if let Some(f) = self.forget {
            human.forget_prob = f;
            custom = true;
        }
        let profile = if custom && self.profile.is_none() {
            Profile::Custom
        } else {
            profile
        };
        (human, profile)
    }
}

/// Loads the environment named by `task`, with explicit keyStates / spaces paths if given.
pub fn load_task(task: &str, key_states: Option<&Path>, spaces: Option<&Path>) -> Result<Spec> {
    if let Some(path) = task.strip_prefix("json:") {
        if path.is_empty() {
            return Err(anyhow!(
                "task 'json:' names no file: expected json:PATH, the transition-model file \
                 (e.g. json:data/navworld/realisticNavWorld.json)"
            ));
        }
        let mut paths = env::JsonPaths::beside(path);
        if let Some(k) = key_states {
            paths.key_states = k.to_path_buf();
        }
        if let Some(s) = spaces {
            paths.spaces = s.to_path_buf();
        }
        return Ok(env::json::load(&paths, task)?);
    }
    if key_states.is_some() || spaces.is_some() {
        let flag = if key_states.is_some() {
            "--key-states"
        } else {
            "--spaces"
        };
        return Err(anyhow!(
            "{flag} only applies to json:PATH tasks, not '{task}': the built-in tasks have no files"
        ));
    }
    Ok(env::load(task)?)
}

/// A library configuration error in command-line terms: parameters are named by their flags.
pub fn explain(error: ConfigError) -> anyhow::Error {
    match error {
        ConfigError::InvalidParam {
            name,
            value,
            accepted,
        } => anyhow!(
            "invalid value '{value}' for '{}': expected {accepted}",
            cli_flag(name)
        ),
        other => other.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_number_flags_say_which_rule_a_bad_value_breaks() {
        assert_eq!(count("12"), Ok(12));
        assert!(count("-1").unwrap_err().contains("-1 is too small"));
        assert!(count("4294967296").unwrap_err().contains("too large"));
        assert!(count("2.5").unwrap_err().contains("not a whole number"));
        assert!(runs_count("0").unwrap_err().contains("from 1 to 1000000"));
        assert_eq!(seed("18446744073709551615"), Ok(u64::MAX));
        assert!(number("x").is_err());
        assert!(number("nan").is_ok_and(f64::is_nan));
    }
}
