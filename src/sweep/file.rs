//! Sweep files: parsing with `file:line` messages, and expansion into configurations.
//!
//! A configuration is one point of the grid: a value for every axis. Configurations are numbered
//! like nested loops in file order (the first axis varies slowest), and run `r` of the sweep is
//! seed `r % seeds` of configuration `r / seeds`. That global run index, with the master seed,
//! fixes the run's random stream, so batching, sharding and resuming never change a result.

use std::collections::{HashMap, HashSet};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use toml::Spanned;
use toml::de::{DeTable, DeValue};

use super::keys::{self, Key, Kind, N_KEYS, Value};
use crate::env::registry;
use crate::env::{self, Spec};
use crate::params::ConfigError;
use crate::params::{Combine, Controller, Interaction, Params, Profile};
use crate::schedule::{Event, Schedule};
use crate::sizing::{self, Shrink, Size, SizeError};

use super::runner::{PartCount, PartKey};
use super::shard::Shard;

/// Top-level keys and sections of a sweep file.
pub const TOP_LEVEL: &[&str] = &[
    "seeds",
    "master_seed",
    "trace",
    "fixed",
    "grid",
    "zip",
    "profiles",
    "profile_file",
];
/// Keys of a range table.
const RANGE_KEYS: &[&str] = &["from", "to", "steps", "by", "log"];
/// Configurations [`Sweep::ignored_settings`] looks at, at most (the warnings need no more).
const IGNORED_SCAN: u64 = 100_000;
/// More values than this on one axis is surely a mistake (and would not fit in memory).
const MAX_AXIS_VALUES: u64 = 1_000_000;
/// Largest sweep file read: a sweep is a few lines of TOML, so anything larger is a wrong path.
pub const MAX_SWEEP_FILE_BYTES: u64 = 1 << 20;

/// A sweep file that cannot be read or is not valid.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The file could not be read.
    // NOTE: the cause is a plain field, not `source`, so `{:#}` prints it once.
    #[error("cannot read sweep file {file}: {cause}")]
    Read {
        /// The file.
        file: String,
        /// The cause.
        cause: std::io::Error,
    },
    /// The path is not a regular file of at most [`MAX_SWEEP_FILE_BYTES`].
    #[error("sweep file {file} {found}: expected a TOML file of at most {max} bytes", max = MAX_SWEEP_FILE_BYTES)]
    NotASweepFile {
        /// The file.
        file: String,
        /// What it is instead ("is a folder", "is 3000000 bytes", ...).
        found: String,
    },
    /// A problem at a place in the file.
    #[error("{file}:{line}: {message}")]
    Invalid {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// The key concerned ("" for syntax errors).
        key: String,
        /// What is wrong and what would be accepted.
        message: String,
    },
}

/// Where a key is set, for messages.
#[derive(Debug, Clone)]
struct Source {
    key: Key,
    line: usize,
    section: String,
}

/// Keys that vary together: one `[grid]` key, or one `[[zip]]` group.
#[derive(Debug, Clone)]
pub struct Axis {
    /// The keys of the axis.
    pub keys: Vec<Key>,
    /// `values[i][k]` is the i-th value of `keys[k]`.
    pub values: Vec<Vec<Value>>,
    /// `[grid]` or `[[zip]] #n`.
    pub section: String,
}

/// A named human (or any bundle of parameters) defined in `[profiles.NAME]`.
#[derive(Debug, Clone)]
pub struct UserProfile {
    /// The name used in `profile = ...`.
    pub name: String,
    /// The values it sets; keys given explicitly in a configuration override them.
    pub values: Vec<(Key, Value)>,
}

/// One configuration, resolved to the parameters of its runs.
#[derive(Debug, Clone, Copy)]
pub struct Resolved {
    /// Index into [`Sweep::tasks`].
    pub task: usize,
    /// Index into [`Sweep::schedules`] (0: no change).
    pub schedule: usize,
    /// Every parameter of the runs.
    pub params: Params,
    /// Index into [`Sweep::profile_names`]: the name written in the `profile` column.
    pub profile: usize,
}

/// A parsed and validated sweep file.
#[derive(Debug, Clone)]
pub struct Sweep {
    /// The file as named on the command line (for messages).
    pub file: String,
    /// The folder `json:` task paths are relative to.
    pub dir: PathBuf,
    /// The file's text, stored with the dataset.
    pub text: String,
    /// Runs per configuration (default 1).
    pub seeds: u32,
    /// Master seed: with the run index it fixes every run's random stream (default 1).
    pub master_seed: u64,
    /// `trace = true`: write the per-step trace table (SPEC 14; default false).
    pub trace: bool,
    /// `[fixed]`: one value for every configuration.
    pub fixed: Vec<(Key, Value)>,
    /// `[grid]` keys and `[[zip]]` groups, in file order.
    pub axes: Vec<Axis>,
    /// `[profiles.NAME]` tables.
    pub profiles: Vec<UserProfile>,
    /// Distinct task names, in order of appearance (`tidy1` when none is set).
    pub tasks: Vec<String>,
    /// Names that may appear in the `profile` column.
    pub profile_names: Vec<String>,
    /// Distinct schedules of changes (the first is the empty one), `json:` paths of their world
    /// events relative to the sweep file.
    pub schedules: Vec<Schedule>,
    /// The index in [`Sweep::schedules`] of each schedule's canonical text as the file wrote it
    /// (before paths were resolved), to find a configuration's schedule.
    schedule_index: HashMap<String, usize>,
    sources: Vec<Source>,
    configurations: u64,
    /// Legal inputs that are almost surely mistakes (a value listed twice), each with its
    /// `file:line`, for the caller to show.
    pub warnings: Vec<String>,
}

const PROFILE_NONE: usize = 0;
const PROFILE_CUSTOM: usize = 1;

/// Reports places in one text.
struct Src<'a> {
    file: &'a str,
    text: &'a str,
}

impl Src<'_> {
    fn line(&self, span: &Range<usize>) -> usize {
        let end = span.start.min(self.text.len());
        self.text[..end].matches('\n').count() + 1
    }

    fn err(&self, span: &Range<usize>, key: &str, message: String) -> SweepError {
        SweepError::Invalid {
            file: self.file.to_string(),
            line: self.line(span),
            key: key.to_string(),
            message,
        }
    }
}

fn known_keys() -> String {
    Key::all().map(Key::name).collect::<Vec<_>>().join(", ")
}

fn suggestion(word: &str, candidates: &[&str]) -> String {
    crate::suggest::hint(word, candidates.iter().copied())
}

fn type_name(v: &DeValue<'_>) -> &'static str {
    match v {
        DeValue::String(_) => "a string",
        DeValue::Integer(_) => "an integer",
        DeValue::Float(_) => "a float",
        DeValue::Boolean(_) => "a boolean",
        DeValue::Datetime(_) => "a date",
        DeValue::Array(_) => "a list",
        DeValue::Table(_) => "a table",
    }
}

fn kind_name(kind: Kind) -> String {
    match kind {
        Kind::Real => "a number".into(),
        Kind::Count => "a whole number from 0 to 4294967295".into(),
        Kind::Switch => "true or false".into(),
        Kind::Choice(names) => format!("one of {}", names.join(", ")),
        Kind::Task => format!("a task name ({})", registry::names()),
        Kind::Schedule => "a schedule of changes, STEP:KEY=VALUE events joined by ';' (e.g. \
             \"1601:goal=34;1601:world=json:PATH\"), or \"\" for none"
            .into(),
        Kind::Profile => format!(
            "a profile name ({} or one defined in [profiles.NAME])",
            builtin_profile_names().join(", ")
        ),
    }
}

fn builtin_profile_names() -> Vec<&'static str> {
    Profile::PRESETS.iter().map(|p| p.name()).collect()
}

fn as_f64(v: &DeValue<'_>) -> Option<f64> {
    match v {
        DeValue::Integer(i) => i128::from_str_radix(&i.as_str().replace('_', ""), i.radix())
            .ok()
            .map(|n| n as f64),
        DeValue::Float(f) => f.as_str().replace('_', "").parse().ok(),
        _ => None,
    }
}

fn as_int(v: &DeValue<'_>) -> Option<i128> {
    match v {
        DeValue::Integer(i) => i128::from_str_radix(&i.as_str().replace('_', ""), i.radix()).ok(),
        DeValue::Float(_) => {
            let x = as_f64(v)?;
            (x.is_finite() && x.fract() == 0.0 && x.abs() < 1e30).then_some(x as i128)
        }
        _ => None,
    }
}

/// A number as the file wrote it (`1e-320`, `0x10`), for messages.
fn as_written(v: &DeValue<'_>) -> String {
    match v {
        DeValue::Integer(i) => i.as_str().to_string(),
        DeValue::Float(f) => f.as_str().to_string(),
        other => type_name(other).to_string(),
    }
}

/// Entries of a table in file order.
fn entries<'t, 'i>(
    table: &'t DeTable<'i>,
) -> Vec<(
    &'t Spanned<std::borrow::Cow<'i, str>>,
    &'t Spanned<DeValue<'i>>,
)> {
    let mut e: Vec<_> = table.iter().collect();
    e.sort_by_key(|(k, _)| k.span().start);
    e
}

/// One key of an axis section: the key, where it is written and its values.
type List = (Key, Range<usize>, Vec<Value>);

/// Parser state while reading one file.
struct Parser<'a> {
    src: Src<'a>,
    sources: Vec<Source>,
    profile_uses: Vec<(String, Range<usize>, String)>,
    /// `[fixed]` values, in file order.
    fixed: Vec<(Key, Value)>,
    /// Axes with the position of their first key, to sort them into file order.
    axes: Vec<(usize, Axis)>,
    profiles: Vec<UserProfile>,
    /// Task names already built (so known to exist).
    tasks_built: Vec<String>,
    /// Legal inputs that are almost surely mistakes, with `file:line`.
    warnings: Vec<String>,
}

impl Parser<'_> {
    fn key(
        &self,
        name: &Spanned<std::borrow::Cow<'_, str>>,
        section: &str,
    ) -> Result<Key, SweepError> {
        Key::lookup(name.get_ref()).ok_or_else(|| {
            let given = keys::normalise(name.get_ref());
            if ["seeds", "master_seed", "trace", "profile_file"].contains(&given.as_str()) {
                // Values that apply to the whole sweep, not to a configuration.
                return self.src.err(
                    &name.span(),
                    name.get_ref(),
                    format!(
                        "'{given}' is a top-level key, not a parameter: write it at the top of \
                         the file, before any section (`{given} = ...` above {section})"
                    ),
                );
            }
            let names: Vec<&str> = Key::all().map(Key::name).collect();
            self.src.err(
                &name.span(),
                name.get_ref(),
                format!(
                    "unknown key '{}' in {section}; {}known keys: {}",
                    name.get_ref(),
                    suggestion(name.get_ref(), &names),
                    known_keys()
                ),
            )
        })
    }

    /// `v` as a table, or `message` at `span`.
    fn table<'t, 'i>(
        &self,
        v: &'t Spanned<DeValue<'i>>,
        span: &Range<usize>,
        key: &str,
        message: String,
    ) -> Result<&'t DeTable<'i>, SweepError> {
        match v.get_ref() {
            DeValue::Table(t) => Ok(t),
            _ => Err(self.src.err(span, key, message)),
        }
    }

    /// Refuses a list or a table as the value of `key` in a section of single values.
    fn one_value(
        &self,
        key: Key,
        v: &Spanned<DeValue<'_>>,
        section: &str,
        hint: &str,
    ) -> Result<(), SweepError> {
        if !matches!(v.get_ref(), DeValue::Array(_) | DeValue::Table(_)) {
            return Ok(());
        }
        let message = format!("key '{}' in {section} takes one value{hint}", key.name());
        Err(self.src.err(&v.span(), key.name(), message))
    }

    /// `[fixed]`: one value per key.
    fn fixed(&mut self, table: &DeTable<'_>) -> Result<(), SweepError> {
        for (key_name, value) in entries(table) {
            let key = self.key(key_name, "[fixed]")?;
            self.one_value(key, value, "[fixed]", "; put lists and ranges in [grid]")?;
            self.claim(key, &key_name.span(), "[fixed]")?;
            let value = self.scalar(key, value, "[fixed]")?;
            self.fixed.push((key, value));
        }
        Ok(())
    }

    /// `[grid]`: one axis per key, in file order.
    fn grid(&mut self, table: &DeTable<'_>) -> Result<(), SweepError> {
        for (key, span, values) in self.lists(table, "[grid]")? {
            let values = values.into_iter().map(|v| vec![v]).collect();
            let section = "[grid]".into();
            let axis = Axis {
                keys: vec![key],
                values,
                section,
            };
            self.axes.push((span.start, axis));
        }
        Ok(())
    }

    /// The keys of an axis section in file order, each claimed, with its place and values.
    fn lists(&mut self, table: &DeTable<'_>, section: &str) -> Result<Vec<List>, SweepError> {
        let mut lists = Vec::new();
        for (key_name, value) in entries(table) {
            let key = self.key(key_name, section)?;
            self.claim(key, &key_name.span(), section)?;
            lists.push((key, key_name.span(), self.values(key, value, section)?));
        }
        Ok(lists)
    }

    /// `[[zip]]`: one axis per table, whose lists vary together.
    fn zip(
        &mut self,
        k: &Spanned<std::borrow::Cow<'_, str>>,
        v: &Spanned<DeValue<'_>>,
    ) -> Result<(), SweepError> {
        let groups: Vec<&Spanned<DeValue<'_>>> = match v.get_ref() {
            DeValue::Array(items) => items.iter().collect(),
            DeValue::Table(_) => vec![v],
            other => {
                return Err(self.src.err(
                    &k.span(),
                    "zip",
                    format!(
                        "'zip' must be one or more [[zip]] tables, found {}",
                        type_name(other)
                    ),
                ));
            }
        };
        for (g, group) in groups.into_iter().enumerate() {
            let section = format!("[[zip]] #{}", g + 1);
            let t = self.table(
                group,
                &group.span(),
                "zip",
                format!("{section} must be a table of lists"),
            )?;
            let columns = self.lists(t, &section)?;
            let zkeys: Vec<Key> = columns.iter().map(|c| c.0).collect();
            let Some((_, first_span, first)) = columns.first() else {
                return Err(self.src.err(
                    &group.span(),
                    "zip",
                    format!("{section} is empty: give two or more lists of equal length"),
                ));
            };
            let n = first.len();
            if let Some((_, span, _)) = columns.iter().find(|(_, _, c)| c.len() != n) {
                let lengths = columns
                    .iter()
                    .map(|(k, _, c)| format!("{} has {}", k.name(), c.len()))
                    .collect::<Vec<_>>()
                    .join(", ");
                return Err(self.src.err(
                    span,
                    "zip",
                    format!("the lists of {section} vary together and must have the same length: {lengths}"),
                ));
            }
            let values: Vec<Vec<Value>> = (0..n)
                .map(|i| columns.iter().map(|(_, _, c)| c[i].clone()).collect())
                .collect();
            let mut rows: HashMap<String, usize> = HashMap::new();
            let mut warned: Vec<String> = Vec::new();
            for row in &values {
                let text = zkeys
                    .iter()
                    .zip(row)
                    .map(|(k, v)| format!("{} = {v}", k.name()))
                    .collect::<Vec<_>>()
                    .join(", ");
                let times = rows.entry(text.clone()).or_insert(0);
                *times += 1;
                if *times == 2 && !warned.contains(&text) {
                    warned.push(text.clone());
                    self.warnings.push(format!(
                        "{}:{}: {section} lists the row ({text}) more than once: its \
                         configurations run that many times (use 'seeds' for replicates)",
                        self.src.file,
                        self.src.line(first_span)
                    ));
                }
            }
            self.axes.push((
                first_span.start,
                Axis {
                    keys: zkeys,
                    values,
                    section,
                },
            ));
        }
        Ok(())
    }

    /// `[profiles.NAME]`: user-defined humans.
    fn profiles(&mut self, table: &DeTable<'_>) -> Result<(), SweepError> {
        for (pname, body) in entries(table) {
            let name = pname
                .get_ref()
                .trim()
                .to_ascii_lowercase()
                .replace('_', "-");
            let section = format!("[profiles.{name}]");
            let valid =
                !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-');
            if !valid || name == "custom" || builtin_profile_names().contains(&name.as_str()) {
                return Err(self.src.err(
                    &pname.span(),
                    "profiles",
                    format!(
                        "profile name '{}' is not allowed: use letters, digits and '-', and none of the built-in names ({}, custom)",
                        pname.get_ref(),
                        builtin_profile_names().join(", ")
                    ),
                ));
            }
            let t = self.table(
                body,
                &pname.span(),
                "profiles",
                format!("{section} must be a table of parameter values"),
            )?;
            let mut values = Vec::new();
            for (key_name, value) in entries(t) {
                let key = self.key(key_name, &section)?;
                if key == Key::PROFILE {
                    return Err(self.src.err(
                        &key_name.span(),
                        "profile",
                        format!("{section} cannot set 'profile' itself"),
                    ));
                }
                self.one_value(key, value, &section, "")?;
                if values.iter().any(|(k, _)| *k == key) {
                    return Err(self.src.err(
                        &key_name.span(),
                        key.name(),
                        format!("key '{}' appears twice in {section}", key.name()),
                    ));
                }
                values.push((key, self.scalar(key, value, &section)?));
                self.sources.push(Source {
                    key,
                    line: self.src.line(&key_name.span()),
                    section: section.clone(),
                });
            }
            self.profiles.push(UserProfile { name, values });
        }
        Ok(())
    }

    /// `profile_file = "F"` (or a list of files): the `[profiles.NAME]` tables of a profile file
    /// (`mbmf fit-human` writes them), its path relative to this file, join this file's own.
    fn profile_file(
        &mut self,
        key: &Spanned<std::borrow::Cow<'_, str>>,
        value: &Spanned<DeValue<'_>>,
        dir: &Path,
    ) -> Result<(), SweepError> {
        thread_local! {
            /// Whether a profile file is being read, which may not name another.
            static READING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
        }
        if READING.get() {
            return Err(self.src.err(
                &key.span(),
                "profile_file",
                "a profile file cannot name another profile file".to_owned(),
            ));
        }
        let paths: Vec<String> = match value.get_ref() {
            DeValue::String(s) => vec![s.to_string()],
            DeValue::Array(items) => items
                .iter()
                .map(|i| match i.get_ref() {
                    DeValue::String(s) => Some(s.to_string()),
                    _ => None,
                })
                .collect::<Option<_>>()
                .unwrap_or_default(),
            _ => Vec::new(),
        };
        if paths.is_empty() {
            return Err(self.src.err(
                &value.span(),
                "profile_file",
                "key 'profile_file': the path of a profile file (a string, or a list of them), \
                 relative to this sweep file"
                    .to_owned(),
            ));
        }
        for path in paths {
            READING.set(true);
            let loaded = load_profiles(&dir.join(&path));
            READING.set(false);
            let loaded = loaded.map_err(|e| {
                self.src.err(
                    &key.span(),
                    "profile_file",
                    format!("profile_file '{path}': {e}"),
                )
            })?;
            for profile in loaded {
                if self.profiles.iter().any(|u| u.name == profile.name) {
                    return Err(self.src.err(
                        &key.span(),
                        "profile_file",
                        format!(
                            "profile_file '{path}' defines profile '{}', which is already defined",
                            profile.name
                        ),
                    ));
                }
                self.profiles.push(profile);
            }
        }
        Ok(())
    }

    /// Profiles may be defined after they are used, so names are checked at the end.
    fn check_profile_uses(&self) -> Result<(), SweepError> {
        for (name, span, section) in &self.profile_uses {
            let defined = self.profiles.iter().any(|u| &u.name == name);
            if !defined && name != "custom" && !builtin_profile_names().contains(&name.as_str()) {
                let mut names = builtin_profile_names();
                names.extend(self.profiles.iter().map(|u| u.name.as_str()));
                return Err(self.src.err(
                    span,
                    "profile",
                    format!(
                        "key 'profile' in {section}: unknown profile '{name}'; {}known profiles: {} (define others in [profiles.NAME])",
                        suggestion(name, &names),
                        names.join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Configurations of `axes`: an axis without a value is refused (it would give an empty
    /// dataset), and so are more runs (configurations x `seeds`) than the `i64` run index holds,
    /// naming the sizes and the largest axis.
    fn configurations(&self, axes: &[Axis], seeds: u32) -> Result<u64, SweepError> {
        let line_of = |axis: &Axis| {
            self.sources
                .iter()
                .find(|s| Some(&s.key) == axis.keys.first() && s.section == axis.section)
                .map_or(1, |s| s.line)
        };
        let invalid = |axis: &Axis, key: &str, message: String| SweepError::Invalid {
            file: self.src.file.to_string(),
            line: line_of(axis),
            key: key.to_string(),
            message,
        };
        if let Some(axis) = axes.iter().find(|a| a.values.is_empty()) {
            let name = axis.keys.first().map_or("grid", |k| k.name());
            return Err(invalid(
                axis,
                name,
                format!(
                    "key '{name}' in {}: gives no value, so the sweep would have no \
                     configuration; give at least one value",
                    axis.section
                ),
            ));
        }
        let configurations = axes
            .iter()
            .try_fold(1u64, |n, a| n.checked_mul(a.values.len() as u64));
        let runs = configurations
            .and_then(|c| c.checked_mul(u64::from(seeds)))
            .filter(|r| i64::try_from(*r).is_ok());
        match (configurations, runs) {
            (Some(c), Some(_)) => Ok(c),
            _ => {
                let sizes: Vec<String> = axes.iter().map(|a| a.values.len().to_string()).collect();
                let product: f64 = axes.iter().map(|a| a.values.len() as f64).product();
                let largest = axes
                    .iter()
                    .max_by_key(|a| a.values.len())
                    .expect("more runs than i64 needs an axis");
                let name = largest.keys[0].name();
                Err(invalid(
                    largest,
                    name,
                    format!(
                        "the axes give {} = {product:.3e} configurations, x {seeds} seeds = \
                         {:.3e} runs: more than run indices hold (2^63 - 1); shrink key \
                         '{name}' in {} ({} values) or another axis",
                        sizes.join(" x "),
                        product * f64::from(seeds),
                        largest.section,
                        largest.values.len()
                    ),
                ))
            }
        }
    }

    /// Records that `key` is set in `section`; a key may be set once across `[fixed]`, `[grid]`
    /// and `[[zip]]`.
    fn claim(&mut self, key: Key, span: &Range<usize>, section: &str) -> Result<(), SweepError> {
        let line = self.src.line(span);
        if let Some(prev) = self
            .sources
            .iter()
            .find(|s| s.key == key && !s.section.starts_with("[profiles."))
        {
            return Err(self.src.err(
                span,
                key.name(),
                format!(
                    "key '{}' in {section} is already set in {} (line {}): a key may appear once \
                     across [fixed], [grid] and [[zip]]",
                    key.name(),
                    prev.section,
                    prev.line
                ),
            ));
        }
        self.sources.push(Source {
            key,
            line,
            section: section.to_string(),
        });
        Ok(())
    }

    /// One value of `key`, checked against the parameter's accepted range.
    fn scalar(
        &mut self,
        key: Key,
        v: &Spanned<DeValue<'_>>,
        section: &str,
    ) -> Result<Value, SweepError> {
        let span = v.span();
        let kind = key.kind();
        let bad = |p: &Self, what: String| {
            p.src.err(
                &span,
                key.name(),
                format!("key '{}' in {section}: {what}", key.name()),
            )
        };
        let expected = |p: &Self| {
            let lists = if matches!(kind, Kind::Real | Kind::Count) {
                ", a list or a range { from, to, steps }"
            } else {
                " or a list"
            };
            bad(
                p,
                format!(
                    "expected {}{lists}, found {}",
                    kind_name(kind),
                    type_name(v.get_ref())
                ),
            )
        };
        let value = match (kind, v.get_ref()) {
            (Kind::Real, DeValue::Integer(_) | DeValue::Float(_)) => {
                let x = as_f64(v.get_ref()).ok_or_else(|| expected(self))?;
                if !x.is_finite() {
                    return Err(bad(self, format!("{x} is not a finite number")));
                }
                Value::Real(x)
            }
            (Kind::Count, DeValue::Integer(_) | DeValue::Float(_)) => {
                // What the parameter accepts, where it says, rather than the type's range.
                let accepted = match key {
                    Key::Param(i) => crate::params::PARAMS[i].accepted.map(str::to_string),
                    _ => None,
                }
                .unwrap_or_else(|| kind_name(kind));
                let n =
                    as_int(v.get_ref()).ok_or_else(|| bad(self, format!("expected {accepted}")))?;
                let n = u32::try_from(n)
                    .map_err(|_| bad(self, format!("{n} is out of range: expected {accepted}")))?;
                Value::Count(n)
            }
            (Kind::Switch, DeValue::Boolean(b)) => Value::Switch(*b),
            (Kind::Switch, DeValue::String(s)) => match keys::normalise(s).as_str() {
                "on" | "true" => Value::Switch(true),
                "off" | "false" => Value::Switch(false),
                _ => {
                    return Err(bad(
                        self,
                        format!("unknown value '{s}'; accepted values: true, false"),
                    ));
                }
            },
            (Kind::Choice(names), DeValue::String(s)) => {
                let norm = keys::normalise(s);
                match names.iter().find(|n| **n == norm) {
                    Some(n) => Value::Choice(n),
                    None => {
                        return Err(bad(
                            self,
                            format!(
                                "unknown value '{s}'; {}accepted values: {}",
                                suggestion(s, names),
                                names.join(", ")
                            ),
                        ));
                    }
                }
            }
            (Kind::Task, DeValue::String(s)) => {
                let s = s.trim();
                // json: files are loaded (relative to the sweep file) once parsing is done; any
                // other name is checked by building it now, with the environment's own message.
                if let Some(path) = s.strip_prefix("json:") {
                    if path.is_empty() {
                        return Err(bad(self, "'json:' needs a path: json:PATH".into()));
                    }
                } else if !self.tasks_built.iter().any(|t| t == s) {
                    // Built once per name: a list may repeat a task many times.
                    if let Err(e) = env::load(s) {
                        return Err(bad(self, e.to_string()));
                    }
                    self.tasks_built.push(s.to_string());
                }
                Value::Text(s.to_string())
            }
            (Kind::Schedule, DeValue::String(s)) => match Schedule::parse(s) {
                Ok(schedule) => Value::Text(schedule.to_string()),
                Err(e) => return Err(bad(self, e.to_string())),
            },
            (Kind::Profile, DeValue::String(s)) => {
                let name = s.trim().to_ascii_lowercase().replace('_', "-");
                self.profile_uses
                    .push((name.clone(), span.clone(), section.to_string()));
                Value::Text(name)
            }
            _ => return Err(expected(self)),
        };
        // Each parameter's accepted range, checked once per value so the message points at it.
        in_range(key, &value).map_err(|e| bad(self, e.to_string()))?;
        Ok(value)
    }

    /// The values of `key` on an axis: a scalar, a list or a range.
    fn values(
        &mut self,
        key: Key,
        v: &Spanned<DeValue<'_>>,
        section: &str,
    ) -> Result<Vec<Value>, SweepError> {
        let values = match v.get_ref() {
            DeValue::Array(items) => {
                if items.is_empty() {
                    return Err(self.src.err(
                        &v.span(),
                        key.name(),
                        format!(
                            "key '{}' in {section}: an empty list gives no configuration",
                            key.name()
                        ),
                    ));
                }
                let values = items
                    .iter()
                    .map(|item| self.scalar(key, item, section))
                    .collect::<Result<Vec<_>, _>>()?;
                if section == "[grid]" {
                    self.warn_repeats(key, section, items, &values);
                }
                values
            }
            DeValue::Table(table) => self.range(key, v.span(), table, section)?,
            _ => vec![self.scalar(key, v, section)?],
        };
        if values.len() as u64 > MAX_AXIS_VALUES {
            return Err(self.src.err(
                &v.span(),
                key.name(),
                format!(
                    "key '{}' in {section}: {} values is too many (at most {MAX_AXIS_VALUES})",
                    key.name(),
                    values.len()
                ),
            ));
        }
        Ok(values)
    }

    /// Warns once per value listed more than once on a `[grid]` axis: its configurations would
    /// run twice (replicates are what `seeds` is for).
    fn warn_repeats(
        &mut self,
        key: Key,
        section: &str,
        items: &[Spanned<DeValue<'_>>],
        values: &[Value],
    ) {
        let names: Vec<String> = values.iter().map(ToString::to_string).collect();
        for (first, times) in crate::suggest::repeats(&names) {
            let item = &items[first];
            let written = match item.get_ref() {
                DeValue::String(text) => format!("\"{text}\""),
                other => as_written(other),
            };
            self.warnings.push(format!(
                "{}:{}: key '{}' in {section} lists {written} {times}: its configurations run \
                 that many times (use 'seeds' for replicates)",
                self.src.file,
                self.src.line(&item.span()),
                key.name()
            ));
        }
    }

    /// `{ from, to, steps }`, `{ from, to, steps, log = true }` or `{ from, to, by }`.
    fn range(
        &mut self,
        key: Key,
        span: Range<usize>,
        table: &DeTable<'_>,
        section: &str,
    ) -> Result<Vec<Value>, SweepError> {
        let name = key.name();
        let kind = key.kind();
        let err = |p: &Self, sp: &Range<usize>, what: String| {
            p.src
                .err(sp, name, format!("key '{name}' in {section}: {what}"))
        };
        if !matches!(kind, Kind::Real | Kind::Count) {
            return Err(err(
                self,
                &span,
                format!(
                    "ranges are for numeric keys; expected {} or a list of them",
                    kind_name(kind)
                ),
            ));
        }
        let mut from = None;
        let mut to = None;
        let mut steps = None;
        let mut by = None;
        // The numbers as written, for messages.
        let mut written = [String::new(), String::new(), String::new()];
        let mut log = false;
        for (k, v) in entries(table) {
            let field = keys::normalise(k.get_ref());
            let number = || {
                as_f64(v.get_ref())
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| {
                        err(
                            self,
                            &v.span(),
                            format!(
                                "range field '{field}' must be a finite number, found {}",
                                type_name(v.get_ref())
                            ),
                        )
                    })
            };
            match field.as_str() {
                "from" => {
                    from = Some(number()?);
                    written[0] = as_written(v.get_ref());
                }
                "to" => {
                    to = Some(number()?);
                    written[1] = as_written(v.get_ref());
                }
                "by" => {
                    by = Some((number()?, v.span()));
                    written[2] = as_written(v.get_ref());
                }
                "steps" => {
                    let n = as_int(v.get_ref())
                        .filter(|n| *n >= 1 && (*n as u64) <= MAX_AXIS_VALUES)
                        .ok_or_else(|| err(self, &v.span(), format!("range field 'steps' is the number of values: a whole number from 1 to {MAX_AXIS_VALUES}")))?;
                    steps = Some(n as u64);
                }
                "log" => {
                    log = match v.get_ref() {
                        DeValue::Boolean(b) => *b,
                        other => {
                            return Err(err(
                                self,
                                &v.span(),
                                format!(
                                    "range field 'log' must be true or false, found {}",
                                    type_name(other)
                                ),
                            ));
                        }
                    }
                }
                _ => {
                    return Err(err(
                        self,
                        &k.span(),
                        format!(
                            "unknown range field '{}'; {}accepted fields: {} (e.g. {{ from = 0, to = 20, steps = 41 }})",
                            k.get_ref(),
                            suggestion(k.get_ref(), RANGE_KEYS),
                            RANGE_KEYS.join(", ")
                        ),
                    ));
                }
            }
        }
        let (Some(from), Some(to)) = (from, to) else {
            return Err(err(
                self,
                &span,
                "a range needs 'from' and 'to', e.g. { from = 0, to = 20, steps = 41 }".into(),
            ));
        };
        let reals: Vec<f64> = match (steps, by) {
            (Some(_), Some((_, sp))) => {
                return Err(err(
                    self,
                    &sp,
                    "give either 'steps' (number of values) or 'by' (increment), not both".into(),
                ));
            }
            (None, None) => {
                return Err(err(
                    self,
                    &span,
                    "a range needs 'steps' (number of values, ends included) or 'by' (increment)"
                        .into(),
                ));
            }
            (None, Some((by, sp))) => {
                if log {
                    return Err(err(
                        self,
                        &sp,
                        "'by' is for linear ranges; a log range takes 'steps'".into(),
                    ));
                }
                if by == 0.0 || (to - from) * by < 0.0 {
                    return Err(err(
                        self,
                        &sp,
                        format!(
                            "'by = {}' never goes from {} to {}",
                            written[2], written[0], written[1]
                        ),
                    ));
                }
                // In f64 first: a tiny step (or a span beyond f64) is an infinite count, which
                // must be refused, not wrapped to no value at all.
                let count = ((to - from) / by + 1e-9).floor() + 1.0;
                if count.is_nan() || count > MAX_AXIS_VALUES as f64 {
                    let many = if count.is_finite() {
                        format!("{count:.0} values")
                    } else {
                        "more values than a number holds".to_string()
                    };
                    return Err(err(
                        self,
                        &sp,
                        format!(
                            "from {} to {} by {} gives {many} (at most {MAX_AXIS_VALUES}): use a larger 'by' or a smaller span",
                            written[0], written[1], written[2]
                        ),
                    ));
                }
                let n = count as u64;
                (0..n).map(|i| from + by * i as f64).collect()
            }
            (Some(n), None) => {
                if n == 1 {
                    if from != to {
                        return Err(err(
                            self,
                            &span,
                            format!(
                                "'steps = 1' gives a single value, but from = {from} and to = {to} differ"
                            ),
                        ));
                    }
                    vec![from]
                } else if log {
                    if from <= 0.0 || to <= 0.0 {
                        return Err(err(
                            self,
                            &span,
                            format!(
                                "a log range needs from > 0 and to > 0 (got from = {from}, to = {to})"
                            ),
                        ));
                    }
                    let (a, b) = (from.ln(), to.ln());
                    (0..n)
                        .map(|i| match i {
                            0 => from,
                            i if i == n - 1 => to,
                            i => (a + (b - a) * i as f64 / (n - 1) as f64).exp(),
                        })
                        .collect()
                } else {
                    // Ends exact; (to - from) * i / (n - 1) is the closest double to each point.
                    (0..n)
                        .map(|i| {
                            if i == n - 1 {
                                to
                            } else {
                                from + (to - from) * i as f64 / (n - 1) as f64
                            }
                        })
                        .collect()
                }
            }
        };
        let mut values = Vec::with_capacity(reals.len());
        for x in reals {
            let value = if kind == Kind::Count {
                let rounded = x.round();
                if !log && (x - rounded).abs() > 1e-9 * x.abs().max(1.0) {
                    return Err(err(
                        self,
                        &span,
                        format!(
                            "'{name}' takes whole numbers, but this range gives {x}; choose steps so that (to - from) / (steps - 1) is whole"
                        ),
                    ));
                }
                if !(0.0..=f64::from(u32::MAX)).contains(&rounded) {
                    return Err(err(
                        self,
                        &span,
                        format!("{rounded} is out of range: expected {}", kind_name(kind)),
                    ));
                }
                let v = Value::Count(rounded as u32);
                if values.last() == Some(&v) {
                    return Err(err(
                        self,
                        &span,
                        format!(
                            "this log range repeats the whole number {rounded}: use fewer steps or a list"
                        ),
                    ));
                }
                v
            } else {
                Value::Real(x)
            };
            in_range(key, &value)
                .map_err(|e| err(self, &span, format!("the range reaches {value}: {e}")))?;
            values.push(value);
        }
        Ok(values)
    }
}

/// Checks `value` against the accepted range of `key`'s parameter.
fn in_range(key: Key, value: &Value) -> Result<(), ConfigError> {
    let mut probe = Params::default();
    keys::apply(key, value, &mut probe);
    probe.validate()
}

/// Every value `[fixed]` and the axes give, with its key.
fn set_values<'a>(
    fixed: &'a [(Key, Value)],
    axes: &'a [Axis],
) -> impl Iterator<Item = (Key, &'a Value)> {
    let on_axes = axes.iter().flat_map(|a| {
        a.values
            .iter()
            .flat_map(move |row| a.keys.iter().copied().zip(row))
    });
    fixed.iter().map(|(k, v)| (*k, v)).chain(on_axes)
}

/// The tasks a sweep runs, in first-use order; tidy1 when some configurations set none.
fn tasks(fixed: &[(Key, Value)], axes: &[Axis], profiles: &[UserProfile]) -> Vec<String> {
    let mut tasks: Vec<String> = Vec::new();
    let mut task_set = false;
    let all_values = set_values(fixed, axes).chain(
        profiles
            .iter()
            .flat_map(|u| u.values.iter().map(|(k, v)| (*k, v))),
    );
    for (key, value) in all_values {
        if key == Key::Task {
            task_set = true;
            let name = value.to_string();
            if !tasks.contains(&name) {
                tasks.push(name);
            }
        }
    }
    // A task left unset anywhere (or set only by some profiles) falls back to tidy1.
    let fixed_or_axis_task = fixed.iter().any(|(k, _)| *k == Key::Task)
        || axes.iter().any(|a| a.keys.contains(&Key::Task));
    if !task_set || !fixed_or_axis_task {
        let default = "tidy1".to_string();
        if !tasks.contains(&default) {
            tasks.push(default);
        }
    }
    tasks
}

/// The `[profiles.NAME]` tables of the profile file at `path` (what `mbmf fit-human` writes):
/// TOML in the syntax of a sweep file that holds profiles only.
pub fn load_profiles(path: &Path) -> Result<Vec<UserProfile>, SweepError> {
    let sweep = Sweep::load(path)?;
    let file = sweep.file.clone();
    let stray = sweep
        .sources
        .iter()
        .find(|s| !s.section.starts_with("[profiles."));
    if let Some(stray) = stray {
        return Err(SweepError::Invalid {
            file,
            line: stray.line,
            key: stray.key.name().to_owned(),
            message: format!(
                "a profile file holds [profiles.NAME] tables only; '{}' is set in {}",
                stray.key.name(),
                stray.section
            ),
        });
    }
    if sweep.profiles.is_empty() {
        return Err(SweepError::Invalid {
            file,
            line: 1,
            key: String::new(),
            message: "no [profiles.NAME] table: a profile file defines at least one profile"
                .to_owned(),
        });
    }
    Ok(sweep.profiles)
}

impl UserProfile {
    /// Sets the human's parameters this profile gives in `params`; other keys are left to the
    /// caller (`None` when it sets none, else the first of them).
    pub fn apply_human(&self, params: &mut Params) -> Option<Key> {
        let mut other = None;
        for (key, value) in &self.values {
            if key.is_human() {
                keys::apply(*key, value, params);
            } else if other.is_none() {
                other = Some(*key);
            }
        }
        other
    }
}

impl Sweep {
    /// Reads and parses the sweep file at `path`.
    pub fn load(path: &Path) -> Result<Sweep, SweepError> {
        let file = path.display().to_string();
        // Checked before reading, so a pipe cannot block and `/dev/zero` cannot fill memory.
        let metadata = std::fs::metadata(path).map_err(|cause| SweepError::Read {
            file: file.clone(),
            cause,
        })?;
        let found = if metadata.is_dir() {
            Some("is a folder".to_string())
        } else if !metadata.is_file() {
            Some("is a device, pipe or socket".to_string())
        } else if metadata.len() > MAX_SWEEP_FILE_BYTES {
            Some(format!("is {} bytes", metadata.len()))
        } else {
            None
        };
        if let Some(found) = found {
            return Err(SweepError::NotASweepFile { file, found });
        }
        let text = std::fs::read_to_string(path).map_err(|cause| SweepError::Read {
            file: file.clone(),
            cause,
        })?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Sweep::parse(&file, &dir, &text)
    }

    /// Parses sweep text; `file` names it in messages, `dir` is where `json:` paths start.
    pub fn parse(file: &str, dir: &Path, text: &str) -> Result<Sweep, SweepError> {
        let src = Src { file, text };
        let root = DeTable::parse(text).map_err(|e| {
            let span = e.span().unwrap_or(0..0);
            src.err(&span, "", format!("not valid TOML: {}", e.message()))
        })?;
        let mut p = Parser {
            src,
            sources: Vec::new(),
            profile_uses: Vec::new(),
            fixed: Vec::new(),
            axes: Vec::new(),
            profiles: Vec::new(),
            tasks_built: Vec::new(),
            warnings: Vec::new(),
        };
        let mut seeds = 1u32;
        let mut master_seed = 1u64;
        let mut trace = false;
        for (k, v) in entries(root.get_ref()) {
            let name = keys::normalise(k.get_ref());
            let table = |p: &Parser<'_>| {
                let found = type_name(v.get_ref());
                let message = format!("'{name}' must be a table ([{name}]), found {found}");
                p.table(v, &k.span(), &name, message)
            };
            match name.as_str() {
                "seeds" => {
                    seeds = as_int(v.get_ref())
                        .and_then(|n| u32::try_from(n).ok())
                        .filter(|n| *n >= 1)
                        .ok_or_else(|| p.src.err(&v.span(), "seeds", format!("key 'seeds': the number of runs per configuration, a whole number from 1 to {}", u32::MAX)))?;
                }
                "master_seed" => {
                    master_seed = as_int(v.get_ref())
                        .and_then(|n| u64::try_from(n).ok())
                        .ok_or_else(|| {
                            p.src.err(
                                &v.span(),
                                "master_seed",
                                format!(
                                    "key 'master_seed': a whole number from 0 to {} (2^64 - 1)",
                                    u64::MAX
                                ),
                            )
                        })?;
                }
                "trace" => {
                    trace = match v.get_ref() {
                        DeValue::Boolean(b) => *b,
                        other => {
                            return Err(p.src.err(
                                &v.span(),
                                "trace",
                                format!(
                                    "key 'trace': true (write the per-step trace table) or \
                                     false, found {}",
                                    type_name(other)
                                ),
                            ));
                        }
                    };
                }
                "fixed" => p.fixed(table(&p)?)?,
                "grid" => p.grid(table(&p)?)?,
                "zip" => p.zip(k, v)?,
                "profiles" => p.profiles(table(&p)?)?,
                "profile_file" => p.profile_file(k, v, dir)?,
                _ => {
                    let message = if let Some(key) = Key::lookup(&name) {
                        format!(
                            "parameter '{}' must be inside [fixed] (one value) or [grid] (several values)",
                            key.name()
                        )
                    } else {
                        format!(
                            "unknown top-level key '{}'; {}known top-level keys and sections: {}",
                            k.get_ref(),
                            suggestion(&name, TOP_LEVEL),
                            TOP_LEVEL.join(", ")
                        )
                    };
                    return Err(p.src.err(&k.span(), k.get_ref(), message));
                }
            }
        }
        p.check_profile_uses()?;
        let mut axes = std::mem::take(&mut p.axes);
        axes.sort_by_key(|(start, _)| *start);
        let axes: Vec<Axis> = axes.into_iter().map(|(_, a)| a).collect();
        let configurations = p.configurations(&axes, seeds)?;
        let (fixed, profiles) = (
            std::mem::take(&mut p.fixed),
            std::mem::take(&mut p.profiles),
        );
        let tasks = tasks(&fixed, &axes, &profiles);
        let mut schedule_texts = vec![String::new()];
        let mut schedule_index: HashMap<String, usize> = HashMap::from([(String::new(), 0)]);
        for (key, value) in set_values(&fixed, &axes) {
            if key == Key::Change && !schedule_index.contains_key(&value.to_string()) {
                schedule_index.insert(value.to_string(), schedule_texts.len());
                schedule_texts.push(value.to_string());
            }
        }
        let schedules = schedule_texts
            .iter()
            .map(|t| {
                let mut s = Schedule::parse(t).expect("checked when parsed");
                for change in &mut s.changes {
                    if let Event::World(task) = &mut change.event
                        && let Some(path) = task.strip_prefix("json:")
                        && Path::new(path).is_relative()
                    {
                        *task = format!("json:{}", dir.join(path).display());
                    }
                }
                s
            })
            .collect();
        let mut profile_names = vec!["none".to_string(), "custom".to_string()];
        profile_names.extend(
            builtin_profile_names()
                .iter()
                .filter(|n| **n != "none")
                .map(|n| n.to_string()),
        );
        profile_names.extend(profiles.iter().map(|u| u.name.clone()));
        let mut sweep = Sweep {
            file: file.to_string(),
            dir: dir.to_path_buf(),
            text: text.to_string(),
            seeds,
            master_seed,
            trace,
            fixed,
            axes,
            profiles,
            tasks,
            profile_names,
            schedules,
            schedule_index,
            sources: p.sources,
            configurations,
            warnings: p.warnings,
        };
        let ignored = sweep.ignored_settings();
        sweep.warnings.extend(ignored);
        Ok(sweep)
    }

    /// Settings some configurations' controllers ignore, as warnings with `file:line`: a mix
    /// for a rule it does not apply to (its runs are `select`'s, its rows say `mix`), and
    /// configurations that differ only in settings their controller ignores (a rule's own
    /// parameter, `combine`, a budget without an interaction), which repeat one another with
    /// other seeds. Legal, since a grid may cross them on purpose, but analyses would take them
    /// for conditions. Looks at the first [`IGNORED_SCAN`] configurations of a larger sweep.
    fn ignored_settings(&self) -> Vec<String> {
        let combine = Key::lookup("combine");
        let budget = Key::lookup("budget");
        let own: Vec<(Key, &str)> = Controller::ALL
            .iter()
            .flat_map(|c| c.own_params().iter())
            .filter_map(|&name| Some((Key::lookup(name)?, name)))
            .collect();
        let mut mislabelled: (u64, Vec<Controller>) = (0, Vec::new());
        // Per configuration's values but the ignored ones: the distinct full sets of values
        // (configurations equal in every value are another warning's), and what was ignored.
        type Group = (HashSet<String>, Vec<Key>, Vec<Controller>);
        let mut groups: HashMap<String, Group> = HashMap::new();
        for config in 0..self.configurations.min(IGNORED_SCAN) {
            let set = self.explicit(config);
            let r = self.resolve(config);
            let c = r.params.controller;
            let mut ignored: Vec<Key> = Vec::new();
            if let Some(k) = combine
                && set[k.index()].is_some()
                && !c.combines()
            {
                ignored.push(k);
                if r.params.combine == Combine::Mix {
                    mislabelled.0 += 1;
                    if !mislabelled.1.contains(&c) {
                        mislabelled.1.push(c);
                    }
                }
            }
            ignored.extend(
                own.iter()
                    .filter(|(k, name)| set[k.index()].is_some() && !c.own_params().contains(name))
                    .map(|&(k, _)| k),
            );
            if let Some(k) = budget
                && set[k.index()].is_some()
                && r.params.human.interaction == Interaction::None
                && r.schedule == 0
            {
                ignored.push(k);
            }
            if ignored.is_empty() {
                continue;
            }
            let values = |keep: &dyn Fn(&Key) -> bool| {
                Key::all()
                    .filter(keep)
                    .filter_map(|k| Some(format!("{}={}", k.name(), set[k.index()]?)))
                    .collect::<Vec<_>>()
                    .join("\u{1f}")
            };
            let group = groups.entry(values(&|k| !ignored.contains(k))).or_default();
            group.0.insert(values(&|_| true));
            for k in ignored {
                if !group.1.contains(&k) {
                    group.1.push(k);
                }
            }
            if !group.2.contains(&c) {
                group.2.push(c);
            }
        }
        let scanned = if self.configurations > IGNORED_SCAN {
            format!(" among the first {IGNORED_SCAN}")
        } else {
            String::new()
        };
        let configurations = |n: u64| match n {
            1 => "1 configuration".to_string(),
            n => format!("{n} configurations"),
        };
        let mut warnings = Vec::new();
        if let Some(k) = combine
            && mislabelled.0 > 0
        {
            warnings.push(format!(
                "{}: combine = mix does not apply to {} ({}{scanned}): their runs are those of \
                 select, but their rows say mix",
                self.place(k),
                Controller::names(&mislabelled.1),
                configurations(mislabelled.0)
            ));
        }
        let (mut repeats, mut keys, mut controllers) = (0u64, Vec::new(), Vec::new());
        for (distinct, ks, cs) in groups.into_values().filter(|g| g.0.len() > 1) {
            repeats += distinct.len() as u64 - 1;
            keys.extend(
                ks.into_iter()
                    .filter(|k| !keys.contains(k))
                    .collect::<Vec<_>>(),
            );
            controllers.extend(
                cs.into_iter()
                    .filter(|c| !controllers.contains(c))
                    .collect::<Vec<_>>(),
            );
        }
        if repeats > 0 {
            keys.sort_by_key(|k| k.index());
            controllers.sort_by_key(|c| Controller::ALL.iter().position(|a| a == c));
            let key_names: Vec<&str> = keys.iter().map(|k| k.name()).collect();
            let why: Vec<String> = keys
                .iter()
                .map(|&k| {
                    if Some(k) == combine {
                        let ignoring: Vec<Controller> = controllers
                            .iter()
                            .copied()
                            .filter(|c| !c.combines())
                            .collect();
                        format!("combine does not apply to {}", Controller::names(&ignoring))
                    } else if Some(k) == budget {
                        "no interaction spends a budget".to_string()
                    } else {
                        let readers = Controller::readers(k.name());
                        format!("only {} reads {}", Controller::names(&readers), k.name())
                    }
                })
                .collect();
            warnings.push(format!(
                "{}: {}{scanned} of {} {} others with other seeds: they differ from them only in \
                 {}, which changes nothing there ({}); a [[zip]] pairs each {}",
                self.place(keys[0]),
                configurations(repeats),
                Controller::names(&controllers),
                if repeats == 1 { "repeats" } else { "repeat" },
                key_names.join(", "),
                why.join("; "),
                if keys.iter().all(|&k| Some(k) == budget) {
                    "interaction with its budgets"
                } else {
                    "rule with its own values"
                }
            ));
        }
        warnings
    }

    /// Number of configurations (points of the grid).
    pub fn configurations(&self) -> u64 {
        self.configurations
    }

    /// Number of runs: configurations x seeds.
    pub fn runs(&self) -> u64 {
        self.configurations * u64::from(self.seeds)
    }

    /// The configuration and seed index of global run `run`.
    pub fn split_run(&self, run: u64) -> (u64, u32) {
        let seeds = u64::from(self.seeds);
        (run / seeds, (run % seeds) as u32)
    }

    /// The value of every key set explicitly in configuration `config` (`[fixed]`, axes).
    fn explicit(&self, config: u64) -> [Option<&Value>; N_KEYS] {
        let mut set: [Option<&Value>; N_KEYS] = [None; N_KEYS];
        for (k, v) in &self.fixed {
            set[k.index()] = Some(v);
        }
        let mut rem = config;
        for axis in self.axes.iter().rev() {
            let n = axis.values.len() as u64;
            let digit = (rem % n) as usize;
            rem /= n;
            for (k, v) in axis.keys.iter().zip(&axis.values[digit]) {
                set[k.index()] = Some(v);
            }
        }
        set
    }

    /// The parameters of configuration `config` (must be below [`Sweep::configurations`]).
    ///
    /// Order: SPEC defaults (steps by task), then the profile (a built-in one is resolved for the
    /// configuration's controller, as `mbmf run --profile` does), then every key given explicitly,
    /// which overrides the profile's fields.
    pub fn resolve(&self, config: u64) -> Resolved {
        let set = self.explicit(config);
        let mut eff = set;
        let mut builtin = None;
        let mut profile = PROFILE_NONE;
        if let Some(Value::Text(name)) = set[Key::PROFILE.index()] {
            profile = self
                .profile_names
                .iter()
                .position(|n| n == name)
                .unwrap_or(PROFILE_CUSTOM);
            if let Some(user) = self.profiles.iter().find(|u| &u.name == name) {
                for (k, v) in &user.values {
                    if set[k.index()].is_none() {
                        eff[k.index()] = Some(v);
                    }
                }
            } else {
                builtin = Profile::PRESETS.iter().copied().find(|p| p.name() == name);
            }
        }
        let task_name = match eff[Key::Task.index()] {
            Some(v) => v.to_string(),
            None => "tidy1".to_string(),
        };
        let task = self.tasks.iter().position(|t| *t == task_name).unwrap_or(0);
        let mut params = Params {
            steps: registry::default_steps(&task_name),
            babbling: registry::default_babbling(&task_name),
            ..Params::default()
        };
        for key in Key::all().filter(|k| !k.is_human()) {
            if let Some(v) = eff[key.index()] {
                keys::apply(key, v, &mut params);
            }
        }
        params.human = builtin
            .and_then(|p| p.human(params.controller))
            .unwrap_or_default();
        if let Some(source) = builtin.and_then(|p| p.reward_source()) {
            params.reward_source = source;
        }
        let mut human_set = false;
        for key in Key::all().filter(|k| k.is_human()) {
            if let Some(v) = eff[key.index()] {
                keys::apply(key, v, &mut params);
                human_set = true;
            }
        }
        params.profile = match builtin {
            Some(p) => p,
            None if profile != PROFILE_NONE || human_set => Profile::Custom,
            None => Profile::None,
        };
        if profile == PROFILE_NONE && builtin.is_none() && human_set {
            profile = PROFILE_CUSTOM;
        }
        let schedule = match set[Key::Change.index()] {
            Some(v) => self
                .schedule_index
                .get(&v.to_string())
                .copied()
                .unwrap_or(0),
            None => 0,
        };
        Resolved {
            task,
            schedule,
            params,
            profile,
        }
    }

    /// The axis values of configuration `config`, e.g. `kappa_coeff = 0.5, interaction = takeover`.
    pub fn describe(&self, config: u64) -> String {
        let mut parts = Vec::new();
        let mut rem = config;
        let mut digits = vec![0; self.axes.len()];
        for (i, axis) in self.axes.iter().enumerate().rev() {
            let n = axis.values.len() as u64;
            digits[i] = (rem % n) as usize;
            rem /= n;
        }
        for (axis, d) in self.axes.iter().zip(digits) {
            for (k, v) in axis.keys.iter().zip(&axis.values[d]) {
                parts.push(format!("{} = {v}", k.name()));
            }
        }
        if parts.is_empty() {
            "the only configuration".into()
        } else {
            parts.join(", ")
        }
    }

    /// Where `key` is set, for messages: `file:line: key 'task' in [grid]` (`file` alone when
    /// the file does not set it).
    pub fn place(&self, key: Key) -> String {
        match self.source(key) {
            Some(s) => format!(
                "{}:{}: key '{}' in {}",
                self.file,
                s.line,
                key.name(),
                s.section
            ),
            None => self.file.clone(),
        }
    }

    fn source(&self, key: Key) -> Option<&Source> {
        self.sources.iter().find(|s| s.key == key)
    }

    fn err_at_key(&self, key: Key, message: String) -> SweepError {
        // A built-in profile sets human keys without naming them: point at the profile then.
        let (line, section) = self
            .source(key)
            .or_else(|| self.source(Key::PROFILE).filter(|_| key.is_human()))
            .map(|s| (s.line, s.section.clone()))
            .unwrap_or((1, "defaults".into()));
        SweepError::Invalid {
            file: self.file.clone(),
            line,
            key: key.name().to_string(),
            message: format!("key '{}' in {section}: {message}", key.name()),
        }
    }

    /// Builds the environment of every task, with `json:` paths relative to the sweep file.
    pub fn load_specs(&self) -> Result<Vec<Arc<Spec>>, SweepError> {
        self.tasks
            .iter()
            .map(|task| {
                let spec = match task.strip_prefix("json:") {
                    Some(path) => {
                        let path = Path::new(path);
                        let path = if path.is_relative() {
                            self.dir.join(path)
                        } else {
                            path.to_path_buf()
                        };
                        env::json::load(&env::JsonPaths::beside(path), task)
                            .map_err(|e| e.to_string())
                    }
                    None => env::load(task).map_err(|e| e.to_string()),
                };
                spec.map(Arc::new).map_err(|e| {
                    self.err_at_key(Key::Task, format!("cannot load task '{task}': {e}"))
                })
            })
            .collect()
    }

    /// Checks every configuration against its environment (e.g. interactions are refused on a
    /// `json:` task, SPEC 5), naming the first bad combination.
    ///
    /// Each value was checked alone when parsed; what is left are the keys that are checked
    /// together ([`INDEPENDENT`] lists the others). Only the combinations of the axes that set
    /// such keys are checked, the other axes at their first value: a configuration's result
    /// does not depend on them, so the first bad combination found is the first bad
    /// configuration, in a time that does not grow with those axes.
    pub fn check(&self, specs: &[Arc<Spec>]) -> Result<(), SweepError> {
        let interacting: Vec<Key> = Key::all().filter(|k| !INDEPENDENT.contains(k)).collect();
        let p = self.projection(&interacting);
        if p.combinations > MAX_CHECKED {
            let largest = p
                .axes
                .iter()
                .map(|&a| &self.axes[a])
                .max_by_key(|a| a.values.len())
                .expect("more than one combination needs an axis");
            let names: Vec<&str> = p
                .axes
                .iter()
                .flat_map(|&a| self.axes[a].keys.iter().map(|k| k.name()))
                .collect();
            return Err(self.err_at_key(
                largest.keys[0],
                format!(
                    "the keys checked together ({}) take {} combinations; at most \
                     {MAX_CHECKED} are checked before a sweep starts: shrink key '{}' ({} \
                     values) or split the sweep into several files",
                    names.join(", "),
                    p.combinations,
                    largest.keys[0].name(),
                    largest.values.len()
                ),
            ));
        }
        for i in 0..p.combinations {
            let config = self.representative(&p, i);
            self.check_one(specs, config)?;
        }
        Ok(())
    }

    fn check_one(&self, specs: &[Arc<Spec>], config: u64) -> Result<(), SweepError> {
        let r = self.resolve(config);
        if let Err(e) =
            crate::schedule::compile(&specs[r.task], &self.schedules[r.schedule], &r.params)
        {
            return Err(self.err_at_key(
                Key::Change,
                format!("configuration {config} ({}): {e}", self.describe(config)),
            ));
        }
        if let Err(e) = registry::check_params(&specs[r.task], &r.params) {
            // Not an exhaustive match, so a new error kind elsewhere does not break this.
            let key = if let ConfigError::InvalidParam { name, .. } = &e {
                Key::lookup(name).unwrap_or(Key::Task)
            } else if let ConfigError::ValueOverflow { because, .. } = &e {
                // Names the inputs that combine badly: point at the first one the file sets.
                Key::all()
                    .find(|k| because.contains(k.name()) && self.source(*k).is_some())
                    .unwrap_or(Key::Task)
            } else if let ConfigError::Incompatible { name, .. } = &e {
                Key::lookup(name).unwrap_or(Key::Task)
            } else if let ConfigError::InteractionUnsupported { .. } = &e {
                Key::INTERACTION
            } else {
                Key::Task
            };
            let mut what = self.describe(config);
            if !self.axes.iter().any(|a| a.keys.contains(&Key::Task)) {
                what += &format!(", task = {}", self.tasks[r.task]);
            }
            return Err(self.err_at_key(key, format!("configuration {config} ({what}): {e}")));
        }
        Ok(())
    }

    /// The axes that set any of `keys` (directly, through a `[profiles.NAME]` that sets one, or
    /// through the task for `steps`, whose default depends on it), and their combinations.
    fn projection(&self, keys: &[Key]) -> Projection {
        let mut keys = keys.to_vec();
        if keys.contains(&Key::named("steps")) && !keys.contains(&Key::Task) {
            keys.push(Key::Task);
        }
        let profile_sets = self
            .profiles
            .iter()
            .any(|u| u.values.iter().any(|(k, _)| keys.contains(k)));
        if profile_sets && !keys.contains(&Key::PROFILE) {
            keys.push(Key::PROFILE);
        }
        let axes: Vec<usize> = (0..self.axes.len())
            .filter(|&a| self.axes[a].keys.iter().any(|k| keys.contains(k)))
            .collect();
        let combinations = axes
            .iter()
            .map(|&a| self.axes[a].values.len() as u64)
            .product();
        Projection { axes, combinations }
    }

    /// The first configuration of combination `i` of `p` (every other axis at its first
    /// value). Increasing `i` gives increasing configurations.
    fn representative(&self, p: &Projection, i: u64) -> u64 {
        let mut digits = vec![0u64; self.axes.len()];
        let mut rem = i;
        for &a in p.axes.iter().rev() {
            let n = self.axes[a].values.len() as u64;
            digits[a] = rem % n;
            rem /= n;
        }
        let mut config = 0u64;
        for (axis, d) in self.axes.iter().zip(digits) {
            config = config * axis.values.len() as u64 + d;
        }
        config
    }

    /// Configurations of `shard` that stand for all of them as far as `keys` are concerned,
    /// each with the number of configurations it stands for. A shard of at most `limit`
    /// configurations is listed as it is; a larger one through the axes that set `keys`
    /// (sampled evenly when they alone have more than `limit` combinations, and scaled to the
    /// shard's share), then the weights are estimates.
    pub fn representatives(&self, shard: Shard, keys: &[Key], limit: u64) -> Representatives {
        let total = self.configurations;
        let in_shard = shard.count_of(total);
        if in_shard <= limit {
            return Representatives {
                configs: shard.configs(total).map(|c| (c, 1)).collect(),
                exact: true,
            };
        }
        let p = self.projection(keys);
        let each = u128::from(total / p.combinations.max(1));
        let samples = p.combinations.min(limit.max(1));
        let mut configs = Vec::with_capacity(samples as usize);
        for j in 0..u128::from(samples) {
            let (combos, samples) = (u128::from(p.combinations), u128::from(samples));
            let (lo, hi) = (j * combos / samples, (j + 1) * combos / samples);
            let mut weight = (hi - lo) * each;
            if shard != Shard::ALL {
                weight = weight * u128::from(in_shard) / u128::from(total);
            }
            configs.push((self.representative(&p, lo as u64), weight));
        }
        Representatives {
            configs,
            exact: samples == p.combinations && shard == Shard::ALL,
        }
    }

    /// The runs, agent-steps, series rows and parts (of `batch_size` runs at most) of `shard`,
    /// counted without enumerating a large grid (see [`Sweep::representatives`]). The parts are
    /// a lower bound: a batch too large for memory is split further when the sweep starts; and
    /// on a grid too large to enumerate they are estimated from the sampled configurations'
    /// kinds of run ([`Size::parts_exact`] false).
    pub fn size(&self, shard: Shard, batch_size: usize) -> Size {
        let keys = [
            Key::Task,
            Key::named("steps"),
            Key::named("babbling"),
            Key::named("checkpoint"),
        ];
        let reps = self.representatives(shard, &keys, SIZE_ENUMERATE_LIMIT);
        let mut size = Size::default();
        let mut parts = PartCount::new(batch_size);
        let seeds = u128::from(self.seeds);
        // Listed one by one, configurations are batched as `plan` does; a sample standing for
        // many is counted in closed form, its kind of run standing for theirs.
        let listed = reps.configs.iter().all(|&(_, weight)| weight == 1);
        for &(config, weight) in &reps.configs {
            let resolved = self.resolve(config);
            size.add(weight * seeds, &resolved.params, self.trace);
            if listed {
                parts.add(PartKey::of(&resolved), seeds);
            } else {
                parts.add_many(PartKey::of(&resolved), weight, seeds);
            }
        }
        size.parts = parts.parts();
        size.parts_exact =
            listed && reps.configs.len() as u64 == shard.count_of(self.configurations);
        if reps.exact {
            // The run count is known exactly whatever was sampled.
            size.runs = u128::from(shard.count_of(self.configurations)) * u128::from(self.seeds);
        }
        size.exact = reps.exact;
        size
    }

    /// Sizes `shard` ([`Sweep::size`]) and refuses it, before anything is loaded, when its runs
    /// cannot be indexed or its results would not fit on the disk of `out`; with `resume`, the
    /// shard's parts already in `out` count as free space (they are part of its size). The
    /// check of every front end.
    pub fn check_size(
        &self,
        shard: Shard,
        batch_size: usize,
        out: &Path,
        resume: bool,
    ) -> Result<Size, SizeError> {
        let size = self.size(shard, batch_size);
        let credit = if resume {
            super::store::shard_bytes(out, u64::from(self.seeds), shard)
        } else {
            0
        };
        sizing::check_size(&size, out, credit, &self.shrink())?;
        Ok(size)
    }

    /// What shrinks the sweep, for the messages of [`crate::sizing`].
    pub fn shrink(&self) -> Shrink {
        let largest = self
            .axes
            .iter()
            .max_by_key(|a| a.values.len())
            .filter(|a| a.values.len() > 1)
            .map(|a| {
                format!(
                    "key '{}' in {} ({} values), ",
                    a.keys[0].name(),
                    a.section,
                    a.values.len()
                )
            })
            .unwrap_or_default();
        let runs = format!(
            "shrink {largest}'seeds' ({}) or another axis of {}",
            self.seeds, self.file
        );
        Shrink {
            series: format!(
                "raise key 'checkpoint' (0 writes no series rows) or lower 'steps', or {runs}"
            ),
            time: format!("{runs}, or split it into shards (--shard I/N)"),
            parts: Some(
                "raise --batch-size (fewer, larger part files: each carries a footer of some \
                 30 KiB), or "
                    .to_string()
                    + &runs,
            ),
            runs,
        }
    }
}

/// Keys whose values are checked alone (each value as it is parsed) and that no check of a
/// combination reads: a sweep's validation need not combine their axes with the others. A key
/// missing here is checked in every combination, which is always correct.
pub const INDEPENDENT: &[Key] = &[
    Key::named("selection"),
    Key::named("cost_model"),
    Key::named("alpha_mf"),
    Key::named("tau"),
    Key::named("q_init"),
    Key::named("window_n"),
    Key::named("vi_epsilon"),
    Key::named("vi_max_sweeps"),
    Key::named("filter_alpha"),
    Key::named("kappa_coeff"),
    Key::named("normalise_entropy"),
    Key::named("forget_prob"),
    Key::named("babbling"),
    Key::named("checkpoint"),
    Key::named("reward_source"),
];

/// Most combinations of the keys checked together that validation goes through.
pub const MAX_CHECKED: u64 = 1_000_000;

/// Configurations resolved to size a sweep exactly; a larger shard is sized through its axes.
const SIZE_ENUMERATE_LIMIT: u64 = 100_000;

/// Axes of a sweep and their number of combinations.
#[derive(Debug, Clone)]
struct Projection {
    /// Indices into [`Sweep::axes`], in file order.
    axes: Vec<usize>,
    /// Product of their lengths.
    combinations: u64,
}

/// See [`Sweep::representatives`].
#[derive(Debug, Clone)]
pub struct Representatives {
    /// Configurations, each with the number of configurations it stands for.
    pub configs: Vec<(u64, u128)>,
    /// Whether the weights are exact counts.
    pub exact: bool,
}
