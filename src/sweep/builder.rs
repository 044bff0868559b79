//! Sweeps built in code: [`Builder`] takes typed keys and values (what a sweep file's
//! `[fixed]`, `[grid]` and `[[zip]]` sections hold) and gives the [`Sweep`] and its canonical
//! text. The text is the sweep's identity — stored with its dataset (`mbmf_sweep`, its sha256)
//! and the file `mbmf sweep` runs again — so [`Builder::build`] validates it through the one
//! parser of sweep files: a built sweep and the file it writes cannot disagree.

use std::fmt::Write as _;
use std::path::Path;

use super::file::{Sweep, SweepError};
use super::keys::{Key, Value};

/// A sweep under construction; see the module documentation.
#[derive(Debug, Clone)]
pub struct Builder {
    comments: Vec<String>,
    seeds: u32,
    master_seed: u64,
    fixed: Vec<(Key, Value)>,
    grid: Vec<(Key, Vec<Value>)>,
    zips: Vec<Vec<(Key, Vec<Value>)>>,
}

impl Default for Builder {
    fn default() -> Builder {
        Builder::new()
    }
}

impl Builder {
    /// One seed, master seed 1, no key set: the defaults of a sweep file.
    pub fn new() -> Builder {
        Builder {
            comments: Vec::new(),
            seeds: 1,
            master_seed: 1,
            fixed: Vec::new(),
            grid: Vec::new(),
            zips: Vec::new(),
        }
    }

    /// A comment line at the top of the text (without its `#`).
    pub fn comment(mut self, line: &str) -> Builder {
        self.comments.push(line.to_string());
        self
    }

    /// Runs per configuration.
    pub fn seeds(mut self, seeds: u32) -> Builder {
        self.seeds = seeds;
        self
    }

    /// The master seed.
    pub fn master_seed(mut self, seed: u64) -> Builder {
        self.master_seed = seed;
        self
    }

    /// `[fixed]`: one value of `key` for every configuration.
    pub fn fixed(mut self, key: Key, value: Value) -> Builder {
        self.fixed.push((key, value));
        self
    }

    /// `[grid]`: an axis of the values of `key`.
    pub fn grid(mut self, key: Key, values: Vec<Value>) -> Builder {
        self.grid.push((key, values));
        self
    }

    /// `[[zip]]`: lists of equal length that vary together, one axis.
    pub fn zip(mut self, columns: Vec<(Key, Vec<Value>)>) -> Builder {
        self.zips.push(columns);
        self
    }

    /// The sweep file of this sweep.
    pub fn text(&self) -> String {
        let mut s = String::new();
        for line in &self.comments {
            let _ = writeln!(s, "# {line}");
        }
        let _ = writeln!(
            s,
            "seeds = {}\nmaster_seed = {}",
            self.seeds, self.master_seed
        );
        if !self.fixed.is_empty() {
            s.push_str("\n[fixed]\n");
            for (key, value) in &self.fixed {
                let _ = writeln!(s, "{} = {}", key.name(), toml_value(value));
            }
        }
        let list = |values: &[Value]| {
            let items: Vec<String> = values.iter().map(toml_value).collect();
            format!("[{}]", items.join(", "))
        };
        if !self.grid.is_empty() {
            s.push_str("\n[grid]\n");
            for (key, values) in &self.grid {
                let _ = writeln!(s, "{} = {}", key.name(), list(values));
            }
        }
        for zip in &self.zips {
            s.push_str("\n[[zip]]\n");
            for (key, values) in zip {
                let _ = writeln!(s, "{} = {}", key.name(), list(values));
            }
        }
        s
    }

    /// The sweep, checked as a sweep file is; `file` names it in messages and in its dataset,
    /// `dir` is where `json:` paths start.
    pub fn build(&self, file: &str, dir: &Path) -> Result<Sweep, SweepError> {
        Sweep::parse(file, dir, &self.text())
    }
}

/// `value` as TOML: numbers as themselves (reals always with a point or an exponent), names and
/// texts as basic strings.
fn toml_value(value: &Value) -> String {
    match value {
        Value::Real(x) => format!("{x:?}"),
        Value::Count(n) => n.to_string(),
        Value::Switch(b) => b.to_string(),
        Value::Choice(s) => quoted(s),
        Value::Text(s) => quoted(s),
    }
}

/// A TOML basic string.
fn quoted(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if c.is_control() => {
                let _ = write!(out, "\\u{:04X}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_built_sweep_is_the_sweep_of_its_text() {
        let builder = Builder::new()
            .comment("two controllers")
            .seeds(3)
            .master_seed(9)
            .fixed(Key::named("steps"), Value::Count(500))
            .grid(
                Key::named("kappa_coeff"),
                vec![Value::Real(1.0), Value::Real(0.25)],
            )
            .zip(vec![
                (Key::Task, vec![Value::Text("tidy1".into()); 2]),
                (
                    Key::named("controller"),
                    vec![Value::Choice("mf"), Value::Choice("ec")],
                ),
            ]);
        let text = builder.text();
        assert_eq!(
            text,
            "# two controllers\nseeds = 3\nmaster_seed = 9\n\n[fixed]\nsteps = 500\n\n[grid]\n\
             kappa_coeff = [1.0, 0.25]\n\n[[zip]]\ntask = [\"tidy1\", \"tidy1\"]\n\
             controller = [\"mf\", \"ec\"]\n"
        );
        let sweep = builder.build("built.toml", Path::new(".")).expect("valid");
        assert_eq!(sweep.text, text);
        assert_eq!((sweep.seeds, sweep.master_seed), (3, 9));
        assert_eq!(sweep.configurations(), 4);
        let last = sweep.resolve(3).params;
        assert_eq!((last.steps, last.kappa_coeff), (500, 0.25));
        assert_eq!(last.controller, crate::params::Controller::Ec);
    }

    #[test]
    fn a_bad_value_is_refused_as_a_sweep_file_would_be() {
        let error = Builder::new()
            .fixed(Key::named("alpha_mf"), Value::Real(2.0))
            .build("built.toml", Path::new("."))
            .expect_err("alpha_mf > 1");
        assert!(error.to_string().contains("alpha_mf"), "{error}");
        assert_eq!(quoted("a\"b\\c\n"), "\"a\\\"b\\\\c\\u000A\"");
    }
}
