//! The parameters a sweep file may set: one key per `mbmf run` flag (snake or kebab case), each
//! with its kind of value, and how a value is applied to a run's [`Params`].

use std::fmt;

use crate::env::tidy::Boxes;
use crate::params::Params;

/// What values a key takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A finite number; lists and ranges accepted.
    Real,
    /// A whole number from 0 to 4,294,967,295; lists and ranges accepted.
    Count,
    /// `true`/`false` (or "on"/"off").
    Switch,
    /// One of a fixed set of names.
    Choice(&'static [&'static str]),
    /// tidy1, tidy2 or json:PATH.
    Task,
    /// A built-in profile name or one defined in the file.
    Profile,
    /// A schedule of changes, `STEP:KEY=VALUE` events joined by `;`.
    Schedule,
}

/// A key's name, aliases, kind and help line.
#[derive(Debug, Clone, Copy)]
pub struct KeyInfo {
    /// The key.
    pub key: Key,
    /// Its name in snake case (kebab case is accepted too).
    pub name: &'static str,
    /// Other accepted names.
    pub aliases: &'static [&'static str],
    /// Its kind of value.
    pub kind: Kind,
    /// One line for `--help`-style listings.
    pub doc: &'static str,
}

/// Names of the controllers, as on the command line.
pub const CONTROLLERS: &[&str] = &["mf", "mb", "rnd", "ec", "entropy"];
/// Names of the selection rules.
pub const SELECTIONS: &[&str] = &["softmax", "argmax"];
/// Names of the cost models.
pub const COST_MODELS: &[&str] = &["ops", "wallclock"];
/// Names of the interaction types.
pub const INTERACTIONS: &[&str] = &[
    "none",
    "congratulation",
    "takeover",
    "punishment",
    "nuisance",
];
/// tidy1's box assignments (permutations of `rgb`).
pub const BOX_ASSIGNMENTS: &[&str] = &["rgb", "rbg", "grb", "gbr", "brg", "bgr"];
/// Names of the reward sources.
pub const REWARD_SOURCES: &[&str] = &["environment", "human"];
/// Names of the congratulation effects.
pub const CONGRATULATION_EFFECTS: &[&str] = &["bias", "reward"];

/// Declares [`Key`], [`KEYS`] and [`N_KEYS`] from one row per key: variant, name, aliases, kind
/// of value and help line.
macro_rules! keys {
    ($($key:ident $name:literal [$($alias:literal),*] $kind:expr, $doc:literal;)*) => {
        /// A parameter a sweep file may set.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum Key {
            $(#[doc = $doc] $key,)*
        }

        /// Number of keys (the length of [`KEYS`]).
        pub const N_KEYS: usize = [$($name),*].len();

        /// Every key, in the order listings show them (a [`Key`] indexes this array).
        pub const KEYS: [KeyInfo; N_KEYS] = [$(KeyInfo {
            key: Key::$key,
            name: $name,
            aliases: &[$($alias),*],
            kind: $kind,
            doc: $doc,
        },)*];
    };
}

#[rustfmt::skip]
keys! {
    Task "task" [] Kind::Task, "tidy1, tidy2, json:PATH (PATH relative to the sweep file), or any task of mbmf run";
    Controller "controller" [] Kind::Choice(CONTROLLERS), "meta-controller";
    Selection "selection" [] Kind::Choice(SELECTIONS), "MC selection rule (default softmax)";
    CostModel "cost_model" [] Kind::Choice(COST_MODELS), "inference cost measure (default ops)";
    AlphaMf "alpha_mf" [] Kind::Real, "MF learning rate (default 0.6)";
    GammaMf "gamma_mf" [] Kind::Real, "MF discount (default 0.9)";
    GammaMb "gamma_mb" [] Kind::Real, "MB discount (default 0.95)";
    Tau "tau" [] Kind::Real, "softmax temperature (default 0.02)";
    QInit "q_init" [] Kind::Real, "initial action values (default 0)";
    WindowN "window_n" [] Kind::Count, "MB transition window (default 10)";
    ViEpsilon "vi_epsilon" [] Kind::Real, "value-iteration tolerance (default 0.01)";
    ViMaxSweeps "vi_max_sweeps" [] Kind::Count, "value-iteration sweep cap (default 10000)";
    FilterAlpha "filter_alpha" [] Kind::Real, "moving-average weight (default 0.6)";
    KappaCoeff "kappa_coeff" ["kappa"] Kind::Real, "EC cost weight coefficient (default 9)";
    NormaliseEntropy "normalise_entropy" ["normalize_entropy"] Kind::Switch, "normalise entropies (default true)";
    Profile "profile" [] Kind::Profile, "named human: built-in or [profiles.NAME]";
    Interaction "interaction" [] Kind::Choice(INTERACTIONS), "interaction type (default none)";
    Budget "budget" [] Kind::Count, "interactions per run (default 0)";
    Zeta "zeta" [] Kind::Real, "congratulation/punishment weight (default 0.1)";
    Forget "forget" ["forget_prob"] Kind::Real, "probability the human is inattentive (default 0.1)";
    Steps "steps" [] Kind::Count, "experiment steps (default 10000; 20000 for tidy2)";
    Babbling "babbling" [] Kind::Count, "babbling steps (default 1000)";
    Checkpoint "checkpoint" [] Kind::Count, "series row every this many steps (default 100)";
    Boxes "boxes" [] Kind::Choice(BOX_ASSIGNMENTS), "tidy1 box assignment, position i the box of cube i (default rgb)";
    RewardSource "reward_source" [] Kind::Choice(REWARD_SOURCES), "who brings the goal's reward (default environment)";
    CongratulationEffect "congratulation_effect" [] Kind::Choice(CONGRATULATION_EFFECTS), "congratulation as a softmax bias or as reward shaping (default bias)";
    Change "change" ["changes", "schedule"] Kind::Schedule, "changes during the run, e.g. \"1601:goal=34;1601:world=json:PATH\" (default none)";
}

impl Key {
    /// The key's description.
    pub fn info(self) -> &'static KeyInfo {
        &KEYS[self as usize]
    }

    /// The key's name (snake case).
    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// Looks a key up by name: snake or kebab case, or an alias.
    pub fn lookup(name: &str) -> Option<Key> {
        let norm = normalise(name);
        KEYS.iter()
            .find(|k| k.name == norm || k.aliases.contains(&norm.as_str()))
            .map(|k| k.key)
    }

    /// Whether the key describes the simulated human (applied after a profile).
    pub fn is_human(self) -> bool {
        matches!(
            self,
            Key::Interaction | Key::Budget | Key::Zeta | Key::Forget | Key::RewardSource
        )
    }

    /// The key whose command-line flag is `flag` (as in [`crate::params::ConfigError`]).
    pub fn from_flag(flag: &str) -> Option<Key> {
        Key::lookup(flag)
    }
}

/// Lower case, `-` turned into `_`.
pub fn normalise(name: &str) -> String {
    name.trim().to_ascii_lowercase().replace('-', "_")
}

/// One value of a parameter.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// A number.
    Real(f64),
    /// A whole number.
    Count(u32),
    /// On or off.
    Switch(bool),
    /// One of a fixed set of names.
    Choice(&'static str),
    /// A task or a profile name.
    Text(String),
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Real(x) => write!(f, "{x}"),
            Value::Count(n) => write!(f, "{n}"),
            Value::Switch(b) => write!(f, "{b}"),
            Value::Choice(s) => f.write_str(s),
            Value::Text(s) => f.write_str(s),
        }
    }
}

impl Value {
    /// The number, for numeric values.
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Value::Real(x) => Some(*x),
            Value::Count(n) => Some(f64::from(*n)),
            _ => None,
        }
    }
}

/// Sets `key` to `value` in `params`. `task` and `profile` are resolved by the caller and ignored
/// here; so are values of the wrong variant, which parsing never produces.
pub fn apply(key: Key, value: &Value, params: &mut Params) {
    let real = value.as_f64().unwrap_or(f64::NAN);
    let count = match value {
        Value::Count(n) => *n,
        _ => 0,
    };
    match key {
        Key::Task | Key::Profile | Key::Change => {}
        Key::Controller => params.controller = choice(value, params.controller),
        Key::Selection => params.selection = choice(value, params.selection),
        Key::CostModel => params.cost_model = choice(value, params.cost_model),
        Key::AlphaMf => params.alpha_mf = real,
        Key::GammaMf => params.gamma_mf = real,
        Key::GammaMb => params.gamma_mb = real,
        Key::Tau => params.tau = real,
        Key::QInit => params.q_init = real,
        Key::WindowN => params.window_n = count,
        Key::ViEpsilon => params.vi_epsilon = real,
        Key::ViMaxSweeps => params.vi_max_sweeps = count,
        Key::FilterAlpha => params.filter_alpha = real,
        Key::KappaCoeff => params.kappa_coeff = real,
        Key::NormaliseEntropy => params.normalise_entropy = *value == Value::Switch(true),
        Key::Interaction => params.human.interaction = choice(value, params.human.interaction),
        Key::RewardSource => params.reward_source = choice(value, params.reward_source),
        Key::CongratulationEffect => {
            params.congratulation_effect = choice(value, params.congratulation_effect)
        }
        Key::Boxes => {
            if let Value::Choice(name) = value
                && let Ok(b) = Boxes::parse(name)
            {
                params.boxes = b;
            }
        }
        Key::Budget => params.human.budget = count,
        Key::Zeta => params.human.zeta = real,
        Key::Forget => params.human.forget_prob = real,
        Key::Steps => params.steps = count,
        Key::Babbling => params.babbling = count,
        Key::Checkpoint => params.checkpoint = count,
    }
}

/// The enum value a [`Value::Choice`] names (parsing only produces known names).
fn choice<T: clap::ValueEnum>(value: &Value, current: T) -> T {
    match value {
        Value::Choice(name) => T::from_str(name, false).unwrap_or(current),
        _ => current,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_indexed_by_their_enum_value() {
        for (i, k) in KEYS.iter().enumerate() {
            assert_eq!(k.key as usize, i, "{}", k.name);
        }
    }

    #[test]
    fn lookup_accepts_kebab_case_and_aliases() {
        assert_eq!(Key::lookup("kappa-coeff"), Some(Key::KappaCoeff));
        assert_eq!(Key::lookup("forget_prob"), Some(Key::Forget));
        assert_eq!(Key::lookup("Alpha_MF"), Some(Key::AlphaMf));
        assert_eq!(Key::lookup("nope"), None);
    }
}
