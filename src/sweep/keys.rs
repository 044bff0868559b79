//! The parameters a sweep file may set: the task, every parameter of the registry
//! ([`crate::params::PARAMS`]) by its key (snake or kebab case), and the schedule of changes.

pub use crate::params::{Kind, Value};
use crate::params::{PARAMS, Params};

/// A key a sweep file may set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Key {
    /// The task: any task of the task registry ([`crate::env::registry`]), a `json:` PATH
    /// relative to the sweep file.
    Task,
    /// The parameter `PARAMS[i]`.
    Param(usize),
    /// Changes during the run, e.g. "1601:goal=34;1601:world=json:PATH".
    Change,
}

/// Number of keys.
pub const N_KEYS: usize = PARAMS.len() + 2;

impl Key {
    /// The `profile` key.
    pub const PROFILE: Key = Key::named("profile");
    /// The `interaction` key.
    pub const INTERACTION: Key = Key::named("interaction");

    /// The key of the parameter named `name` (a field of the registry; checked at compile time).
    pub const fn named(name: &str) -> Key {
        let mut i = 0;
        while i < PARAMS.len() {
            if PARAMS[i]
                .name
                .as_bytes()
                .eq_ignore_ascii_case(name.as_bytes())
            {
                return Key::Param(i);
            }
            i += 1;
        }
        panic!("no such parameter")
    }

    /// Every key, in the order listings show them (task, the registry's order, change).
    pub fn all() -> impl Iterator<Item = Key> {
        std::iter::once(Key::Task)
            .chain((0..PARAMS.len()).map(Key::Param))
            .chain(std::iter::once(Key::Change))
    }

    /// Its position in [`Key::all`], below [`N_KEYS`].
    pub fn index(self) -> usize {
        match self {
            Key::Task => 0,
            Key::Param(i) => i + 1,
            Key::Change => N_KEYS - 1,
        }
    }

    /// The key's name (snake case).
    pub fn name(self) -> &'static str {
        match self {
            Key::Task => "task",
            Key::Param(i) => PARAMS[i].key,
            Key::Change => "change",
        }
    }

    /// Its kind of value.
    pub fn kind(self) -> Kind {
        match self {
            Key::Task => Kind::Task,
            Key::Param(i) => PARAMS[i].kind,
            Key::Change => Kind::Schedule,
        }
    }

    /// Looks a key up by name: snake or kebab case, an alias or the output column's name.
    pub fn lookup(name: &str) -> Option<Key> {
        let norm = normalise(name);
        let is = |names: &[&str]| names.contains(&norm.as_str());
        Key::all().find(|k| match *k {
            Key::Task => is(&["task"]),
            Key::Param(i) => is(&[PARAMS[i].key, PARAMS[i].name]) || is(PARAMS[i].aliases),
            Key::Change => is(&["change", "changes", "schedule"]),
        })
    }

    /// Whether a profile sets the key (so it is applied after the profile).
    pub fn is_human(self) -> bool {
        matches!(self, Key::Param(i) if PARAMS[i].set_by_profile)
    }
}

/// Lower case, `-` turned into `_`.
pub fn normalise(name: &str) -> String {
    name.trim().to_ascii_lowercase().replace('-', "_")
}

/// Sets `key` to `value` in `params`. `task`, `profile` and `change` are resolved by the caller
/// and ignored here; so are values of the wrong variant, which parsing never produces.
pub fn apply(key: Key, value: &Value, params: &mut Params) {
    if let Key::Param(i) = key {
        (PARAMS[i].set)(params, value);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_indexed_by_their_position() {
        for (i, k) in Key::all().enumerate() {
            assert_eq!(k.index(), i, "{}", k.name());
        }
        assert_eq!(Key::all().count(), N_KEYS);
        assert_eq!(Key::PROFILE.name(), "profile");
    }

    #[test]
    fn lookup_accepts_kebab_case_and_aliases() {
        let name = |k: Option<Key>| k.map(Key::name);
        assert_eq!(name(Key::lookup("kappa-coeff")), Some("kappa_coeff"));
        assert_eq!(name(Key::lookup("kappa")), Some("kappa_coeff"));
        assert_eq!(name(Key::lookup("forget_prob")), Some("forget"));
        assert_eq!(name(Key::lookup("Alpha_MF")), Some("alpha_mf"));
        assert_eq!(Key::lookup("schedule"), Some(Key::Change));
        assert_eq!(Key::lookup("nope"), None);
    }
}
