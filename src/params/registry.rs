//! The parameter registry: one row per parameter in [`crate::params`]'s `registry!` table
//! generates the [`Params`] and [`HumanParams`] fields and defaults, their range checks, and the
//! [`PARAMS`] list that the command line (flags), sweep files (keys), the outputs (Parquet
//! columns with descriptions) and the analyses (parameter columns) read.
//!
//! [`Params`]: crate::params::Params
//! [`HumanParams`]: crate::params::HumanParams
//! [`PARAMS`]: crate::params::PARAMS

use std::fmt;

use crate::params::Params;

/// What values a parameter (or a sweep key) takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A finite number; lists and ranges accepted in sweep files.
    Real,
    /// A whole number from 0 to 4,294,967,295; lists and ranges accepted in sweep files.
    Count,
    /// `true`/`false` (or "on"/"off").
    Switch,
    /// One of a fixed set of names.
    Choice(&'static [&'static str]),
    /// A task of the task registry ([`crate::env::registry`]).
    Task,
    /// A built-in profile name or one defined in a sweep file.
    Profile,
    /// A schedule of changes, `STEP:KEY=VALUE` events joined by `;`.
    Schedule,
}

/// One value of a parameter, whatever its type.
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
    /// A task, a profile or a schedule.
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

    /// The whole number, for counts.
    pub fn as_count(&self) -> Option<u32> {
        match self {
            Value::Count(n) => Some(*n),
            _ => None,
        }
    }

    /// The name or text, for choices and texts.
    pub fn as_str(&self) -> Option<&str> {
        match self {
            Value::Choice(s) => Some(s),
            Value::Text(s) => Some(s),
            _ => None,
        }
    }

    /// The value as error messages write it (numbers via [`crate::params::show`]).
    pub fn shown(&self) -> String {
        match self {
            Value::Real(x) => crate::params::show(*x),
            other => other.to_string(),
        }
    }
}

/// A type a parameter may have: how it is written as a [`Value`] and read back.
pub trait ParamValue: Copy {
    /// Its kind of value.
    const KIND: Kind;
    /// As a [`Value`].
    fn to_value(self) -> Value;
    /// From a [`Value`] of its kind (`None` for any other).
    fn from_value(value: &Value) -> Option<Self>;
    /// The accepted names with their help, for `--help` (empty but for named choices).
    #[cfg(feature = "cli")]
    fn possible_values() -> Vec<clap::builder::PossibleValue> {
        Vec::new()
    }
}

impl ParamValue for f64 {
    const KIND: Kind = Kind::Real;
    fn to_value(self) -> Value {
        Value::Real(self)
    }
    fn from_value(value: &Value) -> Option<Self> {
        value.as_f64()
    }
}

impl ParamValue for u32 {
    const KIND: Kind = Kind::Count;
    fn to_value(self) -> Value {
        Value::Count(self)
    }
    fn from_value(value: &Value) -> Option<Self> {
        value.as_count()
    }
}

impl ParamValue for bool {
    const KIND: Kind = Kind::Switch;
    fn to_value(self) -> Value {
        Value::Switch(self)
    }
    fn from_value(value: &Value) -> Option<Self> {
        match value {
            Value::Switch(b) => Some(*b),
            _ => None,
        }
    }
}

/// One parameter of the registry, as the command line, sweep files, outputs and analyses see it.
#[derive(Debug)]
pub struct Param {
    /// The field of [`Params`] (or of its `human`), which is also its output column.
    pub name: &'static str,
    /// Its sweep key (snake case; kebab case is accepted too); `--` and the key in kebab case is
    /// its flag.
    pub key: &'static str,
    /// Other accepted sweep keys (the column name is always accepted).
    pub aliases: &'static [&'static str],
    /// Its kind of value.
    pub kind: Kind,
    /// What it is: the column's description.
    pub doc: &'static str,
    /// The column's unit ("" when none).
    pub unit: &'static str,
    /// The accepted range, when narrower than the type's.
    pub accepted: Option<&'static str>,
    /// More for `--help`, after the default.
    pub help: &'static str,
    /// Whether it is a flag of `mbmf run` (others have hand-written flags, or none).
    pub flag: bool,
    /// Whether a human profile sets it, so it is applied after the profile.
    pub set_by_profile: bool,
    /// Whether it is a field of [`crate::params::HumanParams`].
    pub in_human: bool,
    /// Whether it is a task parameter, declared with the tasks that read it
    /// ([`crate::env::registry`]).
    pub task: bool,
    /// Its value in a run's parameters.
    pub get: fn(&Params) -> Value,
    /// Sets it from a value of its kind (values of another kind are ignored).
    pub set: fn(&mut Params, &Value),
    /// The accepted names with their help, for `--help`.
    #[cfg(feature = "cli")]
    pub possible_values: fn() -> Vec<clap::builder::PossibleValue>,
}

impl Param {
    /// Its command-line flag.
    pub fn flag(&self) -> String {
        format!("--{}", self.key.replace('_', "-"))
    }

    /// Its default value.
    pub fn default_value(&self) -> Value {
        (self.get)(&Params::default())
    }
}

/// The parameter whose field (or output column) is `name`.
pub fn param(name: &str) -> Option<&'static Param> {
    crate::params::PARAMS.iter().find(|p| p.name == name)
}

/// `first!(, b)` is `b`, `first!(a, b)` is `a`: an optional part of a row with its fallback.
macro_rules! first {
    (, $b:expr) => {
        $b
    };
    ($a:expr, $b:expr) => {
        $a
    };
}
pub(crate) use first;

/// Generates, from one row per parameter, the `Params` and `HumanParams` structs with their
/// `Default`, `Params::validate` and the `PARAMS` table. A row is
///
/// `CLASS FIELD [as KEY] [[ALIASES]] [in human]: TYPE = DEFAULT, "DOC" [("UNIT")]
///  [, accepts "RANGE" if |x| CHECK] [, help "MORE"];`
///
/// where CLASS is `flag` (a flag of `mbmf run` and a sweep key), `after_profile` (the same, and
/// a profile sets it), `task` (the same, declared with the tasks that read it) or `special`
/// (its flag and key are hand-written), and `in human` puts the field in `HumanParams` (a
/// profile sets it too).
macro_rules! registry {
    ($(
        $class:ident $field:ident $(as $key:ident)? $([$($alias:literal),*])? $(in $group:ident)?
            : $ty:ty = $default:expr, $doc:literal $(($unit:literal))?
            $(, accepts $accepted:literal if |$x:ident| $ok:expr)?
            $(, help $help:literal)?;
    )*) => {
        /// Every parameter, in the order of the output columns.
        pub const PARAMS: &[$crate::params::registry::Param] = &[$(
            $crate::params::registry::Param {
                name: stringify!($field),
                key: $crate::params::registry::first!($(stringify!($key))?, stringify!($field)),
                aliases: &[$($($alias),*)?],
                kind: <$ty as $crate::params::registry::ParamValue>::KIND,
                doc: $doc,
                unit: $crate::params::registry::first!($($unit)?, ""),
                accepted: $crate::params::registry::first!($(Some($accepted))?, None),
                help: $crate::params::registry::first!($($help)?, ""),
                flag: $crate::params::registry::registry!(@flag $class),
                set_by_profile: $crate::params::registry::registry!(@by_profile $class) || $crate::params::registry::registry!(@human $($group)?),
                in_human: $crate::params::registry::registry!(@human $($group)?),
                task: $crate::params::registry::registry!(@task $class),
                get: |p| $crate::params::registry::ParamValue::to_value(p $(.$group)? .$field),
                set: |p, v| {
                    if let Some(x) = <$ty as $crate::params::registry::ParamValue>::from_value(v) {
                        p $(.$group)? .$field = x;
                    }
                },
                #[cfg(feature = "cli")]
                possible_values: <$ty as $crate::params::registry::ParamValue>::possible_values,
            },
        )*];

        impl Params {
            /// Checks every parameter against its accepted range; NaN and infinities are always
            /// refused. Errors name the parameter as its field (and output column);
            /// [`cli_flag`] gives the flag.
            pub fn validate(&self) -> Result<(), ConfigError> {
                $({
                    #[allow(unused_variables)]
                    let value = self $(.$group)? .$field;
                    $(
                        let $x = value;
                        let shown = $crate::params::registry::ParamValue::to_value(value);
                        if !($ok && shown.as_f64().is_none_or(f64::is_finite)) {
                            let default: $ty = $default;
                            return Err(ConfigError::InvalidParam {
                                name: stringify!($field),
                                value: shown.shown(),
                                accepted: format!(
                                    "{} (default {})",
                                    $accepted,
                                    $crate::params::registry::ParamValue::to_value(default).shown()
                                ),
                            });
                        }
                    )?
                })*
                Ok(())
            }
        }

        // Each field's doc says its default and, where narrower than its type, its range.
        $crate::params::registry::registry!(@split [] []; $([$($group)?] $field: $ty = $default,
            concat!($doc, ". Default: `", stringify!($default), "`"
                $(, "; accepted: ", $accepted)?, ".");)*);
    };
    (@flag special) => { false };
    (@flag $class:ident) => { true };
    (@task task) => { true };
    (@task $class:ident) => { false };
    (@by_profile after_profile) => { true };
    (@by_profile $class:ident) => { false };
    (@human human) => { true };
    (@human) => { false };
    // Sorts the fields into `Params` and `HumanParams`.
    (@split [$($p:tt)*] [$($h:tt)*]; [human] $f:ident: $t:ty = $d:expr, $doc:expr; $($rest:tt)*) => {
        $crate::params::registry::registry!(@split [$($p)*] [$($h)* ($f, $t, $d, $doc)]; $($rest)*);
    };
    (@split [$($p:tt)*] [$($h:tt)*]; [] $f:ident: $t:ty = $d:expr, $doc:expr; $($rest:tt)*) => {
        $crate::params::registry::registry!(@split [$($p)* ($f, $t, $d, $doc)] [$($h)*]; $($rest)*);
    };
    (@split [$(($pf:ident, $pt:ty, $pd:expr, $pdoc:expr))*]
        [$(($hf:ident, $ht:ty, $hd:expr, $hdoc:expr))*];) => {
        /// Every sweepable scalar of one run. `Default` gives the paper's values (SPEC 3, 4, 7).
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct Params {
            $(#[doc = $pdoc] pub $pf: $pt,)*
            /// The simulated human.
            pub human: HumanParams,
        }

        impl Default for Params {
            fn default() -> Self {
                Params { $($pf: $pd,)* human: HumanParams::default() }
            }
        }

        /// Scalars of the simulated human (SPEC 5).
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct HumanParams {
            $(#[doc = $hdoc] pub $hf: $ht,)*
        }

        impl Default for HumanParams {
            fn default() -> Self {
                HumanParams { $($hf: $hd,)* }
            }
        }
    };
}
pub(crate) use registry;
