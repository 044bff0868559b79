//! The documentation holds to the code: every relative link and anchor of README.md, docs/,
//! benches/README.md and sweeps/README.md resolves; every `mbmf` command of the shell blocks of README.md and docs/
//! runs (or says why not); `docs/schema.md` is what the files mbmf writes carry; `docs/architecture.md` names
//! every source folder and module.

mod common;

use std::collections::{BTreeSet, HashMap};
use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::Command;

use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use tempfile::TempDir;

use common::{mbmf, repo};

/// The pages a newcomer reads: the README, every page of docs/, the benchmarks' and the sweeps'
/// READMEs.
fn pages() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.expect("a folder entry").path())
            .collect();
        entries.sort();
        for path in entries {
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "md") {
                out.push(path);
            }
        }
    }
    let mut pages = vec![
        repo().join("README.md"),
        repo().join("benches/README.md"),
        repo().join("sweeps/README.md"),
    ];
    walk(&repo().join("docs"), &mut pages);
    pages
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn shown(path: &Path) -> String {
    path.strip_prefix(repo())
        .unwrap_or(path)
        .display()
        .to_string()
}

/// The lines of a page outside fenced code blocks, with their 1-based numbers.
fn prose(text: &str) -> Vec<(usize, &str)> {
    let mut fenced = false;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        } else if !fenced {
            out.push((i + 1, line));
        }
    }
    out
}

/// GitHub's anchor of a heading: lower case, punctuation dropped but `-` and `_`, spaces as `-`.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || matches!(c, ' ' | '-' | '_'))
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// The anchors of a page's headings, numbered as GitHub numbers repeated ones (`name-1`, ...).
fn anchors(text: &str) -> BTreeSet<String> {
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut out = BTreeSet::new();
    for (_, line) in prose(text) {
        let level = line.chars().take_while(|&c| c == '#').count();
        if level == 0 || level > 6 || !line[level..].starts_with(' ') {
            continue;
        }
        let base = slug(&line[level..]);
        let n = seen.entry(base.clone()).or_insert(0);
        out.insert(if *n == 0 {
            base.clone()
        } else {
            format!("{base}-{n}")
        });
        *n += 1;
    }
    out
}

/// The targets of the markdown links and images of a line, outside inline code.
fn link_targets(line: &str) -> Vec<String> {
    let mut code = false;
    let mut plain = String::new();
    for c in line.chars() {
        if c == '`' {
            code = !code;
        } else if !code {
            plain.push(c);
        }
    }
    let mut out = Vec::new();
    let mut rest = plain.as_str();
    while let Some(i) = rest.find("](") {
        let after = &rest[i + 2..];
        let Some(end) = after.find(')') else { break };
        out.push(after[..end].trim().to_string());
        rest = &after[end..];
    }
    out
}

#[test]
fn every_relative_link_and_anchor_resolves() {
    let mut broken = Vec::new();
    let mut checked = 0;
    for page in pages() {
        let text = read(&page);
        for (number, line) in prose(&text) {
            for target in link_targets(line) {
                if target.contains("://") || target.starts_with("mailto:") {
                    continue;
                }
                checked += 1;
                let (path, anchor) = target.split_once('#').unwrap_or((&target, ""));
                let file = if path.is_empty() {
                    page.clone()
                } else {
                    page.parent().expect("a folder").join(path)
                };
                let at = format!("{}:{number}: ({target})", shown(&page));
                if !file.exists() {
                    broken.push(format!("{at}: no file {}", shown(&file)));
                } else if !anchor.is_empty() {
                    if file.extension().is_none_or(|e| e != "md") {
                        broken.push(format!("{at}: an anchor into a file that is not markdown"));
                    } else if !anchors(&read(&file)).contains(anchor) {
                        broken.push(format!("{at}: {} has no heading #{anchor}", shown(&file)));
                    }
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
    assert!(
        checked > 20,
        "only {checked} links found: is the parser broken?"
    );
}

#[test]
fn slugs_follow_github() {
    assert_eq!(
        slug(" `mbmf pareto`: the trade-off between reward, cost and learning quality"),
        "mbmf-pareto-the-trade-off-between-reward-cost-and-learning-quality"
    );
    assert_eq!(
        slug("Decisions beyond the SPEC"),
        "decisions-beyond-the-spec"
    );
    let text = "# A\n```\n# not a heading\n```\n## A\n";
    assert_eq!(
        anchors(text),
        BTreeSet::from(["a".to_string(), "a-1".to_string()])
    );
    assert_eq!(
        link_targets("see [x](a.md#b), `[y](not)` and ![z](f.png)"),
        ["a.md#b", "f.png"]
    );
}

/// A command of a page's shell block.
struct Doc {
    page: PathBuf,
    line: usize,
    command: String,
    /// The output a `console` block shows after the command, if any: what it must print.
    shown: Option<String>,
}

/// What a page's fenced blocks ask to run, in order: `mbmf` commands of `sh` blocks (every line)
/// and `console` blocks (lines after `$ `), joined over `\` continuations; sweep files of `toml`
/// blocks whose first line is `# NAME.toml...`, to be written before the commands that follow.
/// A block right after `<!-- not run: REASON -->` is listed with its reason instead.
enum Step {
    Run(Doc),
    Write(String, String),
    NotRun(Doc, String),
}

fn steps(page: &Path) -> Vec<Step> {
    let text = read(page);
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let Some(info) = lines[i].trim_start().strip_prefix("```") else {
            i += 1;
            continue;
        };
        let not_run = i
            .checked_sub(1)
            .and_then(|p| lines[p].trim().strip_prefix("<!-- not run:"))
            .map(|r| r.trim_end_matches("-->").trim().to_string());
        let start = i + 1;
        let end = start
            + lines[start..]
                .iter()
                .position(|l| l.trim_start().starts_with("```"))
                .unwrap_or_else(|| panic!("{}:{}: an unclosed block", shown(page), i + 1));
        let body = &lines[start..end];
        match info.trim() {
            "toml" => {
                if let Some(name) = body.first().and_then(|l| l.strip_prefix("# ")) {
                    let name = name.split([':', ' ']).next().unwrap_or("");
                    if name.ends_with(".toml") {
                        out.push(Step::Write(name.to_string(), body.join("\n") + "\n"));
                    }
                }
            }
            "sh" | "console" => {
                let mut k = 0;
                while k < body.len() {
                    let line_no = start + k + 1;
                    let first = body[k];
                    let mut command = if info.trim() == "console" {
                        match first.strip_prefix("$ ") {
                            Some(c) => c.to_string(),
                            None => {
                                k += 1;
                                continue;
                            }
                        }
                    } else {
                        first.to_string()
                    };
                    while command.trim_end().ends_with('\\') && k + 1 < body.len() {
                        k += 1;
                        command = format!(
                            "{} {}",
                            command.trim_end().trim_end_matches('\\'),
                            body[k].trim()
                        );
                    }
                    k += 1;
                    let mut shown = Vec::new();
                    while info.trim() == "console" && k < body.len() && !body[k].starts_with("$ ") {
                        shown.push(body[k]);
                        k += 1;
                    }
                    let command = command.trim().to_string();
                    if !command.starts_with("mbmf ") {
                        continue;
                    }
                    let doc = Doc {
                        page: page.to_path_buf(),
                        line: line_no,
                        command,
                        shown: (!shown.is_empty()).then(|| shown.join("\n")),
                    };
                    out.push(match &not_run {
                        Some(reason) => Step::NotRun(doc, reason.clone()),
                        None => Step::Run(doc),
                    });
                }
            }
            _ => {}
        }
        i = end + 1;
    }
    out
}

/// Every `mbmf` command shown in a shell block runs and succeeds (printing on stdout what a
/// `console` block shows after it, when it shows something), page by page in a fresh folder
/// (the commands of a page run in order, as a reader would type them), with the authors' data at
/// `../shared/data/navworld` when it is beside the checkout (skipped otherwise, failed under
/// `CI=true`). Blocks marked `<!-- not run: REASON -->` are counted and listed.
#[test]
fn every_command_in_the_docs_runs() {
    let bin = Path::new(env!("CARGO_BIN_EXE_mbmf"))
        .parent()
        .expect("the binary's folder")
        .to_path_buf();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let shared = repo().join("../shared");
    let navworld = Path::new(common::NAVWORLD).exists();
    let (mut ran, mut compared, mut skipped, mut not_run) = (0, 0, Vec::new(), Vec::new());
    // The README and docs/ show what a newcomer types; the benchmarks' and the sweeps' pages
    // show jobs of minutes on purpose, and say how long.
    let for_newcomers =
        |p: &PathBuf| *p == repo().join("README.md") || p.starts_with(repo().join("docs"));
    for page in pages().into_iter().filter(for_newcomers) {
        let steps = steps(&page);
        if steps.is_empty() {
            continue;
        }
        let root = TempDir::new().expect("a temporary folder");
        let work = root.path().join("work");
        std::fs::create_dir_all(&work).expect("a working folder");
        if navworld {
            std::os::unix::fs::symlink(&shared, root.path().join("shared")).expect("a link");
        }
        // The docs run commands from the repository's root, naming the shipped sweep files.
        std::os::unix::fs::symlink(repo().join("sweeps"), work.join("sweeps")).expect("a link");
        for step in steps {
            let doc = match step {
                Step::Write(name, text) => {
                    std::fs::write(work.join(name), text).expect("the sweep file");
                    continue;
                }
                Step::NotRun(doc, reason) => {
                    not_run.push(format!(
                        "{}:{}: {} ({reason})",
                        shown(&doc.page),
                        doc.line,
                        doc.command
                    ));
                    continue;
                }
                Step::Run(doc) => doc,
            };
            let at = format!("{}:{}", shown(&doc.page), doc.line);
            if doc.command.contains("../shared/data/navworld") && !navworld {
                assert!(common::navworld_task().is_none());
                skipped.push(at);
                continue;
            }
            let output = Command::new("sh")
                .arg("-c")
                .arg(&doc.command)
                .current_dir(&work)
                .env("PATH", &path)
                .env("HOME", root.path())
                .output()
                .expect("sh starts");
            assert!(
                output.status.success(),
                "{at}: `{}` failed ({}):\n{}",
                doc.command,
                output.status,
                String::from_utf8_lossy(&output.stderr)
            );
            if let Some(shown) = &doc.shown {
                let printed = String::from_utf8_lossy(&output.stdout);
                assert!(
                    printed.trim_end() == shown.trim_end(),
                    "{at}: `{}` prints other lines than the page shows; page:\n{shown}\nprinted:\n{printed}",
                    doc.command
                );
                compared += 1;
            }
            ran += 1;
        }
    }
    println!(
        "{ran} documented commands ran ({compared} printing what their page shows); {} skipped \
         without the authors' data; {} not run:",
        skipped.len(),
        not_run.len()
    );
    for line in &not_run {
        println!("  {line}");
    }
    assert!(
        ran >= 10,
        "only {ran} commands ran: is the extraction broken?"
    );
}

/// Where `docs/schema.md`'s generated tables start and end.
const BEGIN: &str =
    "<!-- generated from the code: MBMF_BLESS=1 cargo test --release --test docs rewrites it -->";
const END: &str = "<!-- end of the generated tables -->";

/// The schema of a Parquet file as written, field metadata included.
fn schema_of(file: &Path) -> arrow::datatypes::SchemaRef {
    ParquetRecordBatchReaderBuilder::try_new(File::open(file).expect("the file"))
        .expect("a Parquet file")
        .schema()
        .clone()
}

/// `docs/schema.md` shows the columns, types, units and descriptions of the files a run writes
/// (read back from them) and the registry's defaults. `MBMF_BLESS=1` rewrites the page's
/// generated part instead of failing.
#[test]
fn the_schema_page_is_what_the_files_carry() {
    let dir = TempDir::new().expect("a temporary folder");
    let out = dir.path().join("out");
    let status = mbmf()
        .args([
            "run", "--runs", "1", "--steps", "200", "--trace", "-q", "--out",
        ])
        .arg(&out)
        .status()
        .expect("mbmf runs");
    assert!(status.success());
    let generated =
        mbmf::output::columns::schema_markdown(
            &schema_of(&out.join("runs.parquet")),
            &schema_of(&out.join("series.parquet")),
        ) + &mbmf::output::columns::trace_markdown(&schema_of(&out.join("trace.parquet")));
    assert!(generated.contains("| `kappa_coeff` | f64 | `kappa_coeff` | `9` |"));
    assert!(generated.contains("| `first_reward_step` | i64, null | steps |"));
    let page = repo().join("docs/schema.md");
    let text = read(&page);
    let start = text.find(BEGIN).expect("docs/schema.md: the start marker") + BEGIN.len();
    let end = start
        + text[start..]
            .find(END)
            .expect("docs/schema.md: the end marker");
    let wanted = format!("\n\n{generated}\n");
    if std::env::var("MBMF_BLESS").is_ok_and(|v| v == "1") {
        let blessed = format!("{}{wanted}{}", &text[..start], &text[end..]);
        std::fs::write(&page, blessed).expect("docs/schema.md written");
        return;
    }
    assert!(
        text[start..end] == wanted,
        "docs/schema.md differs from the columns mbmf writes; regenerate it with\n  \
         MBMF_BLESS=1 cargo test --release --test docs the_schema_page\nand review the diff.\n\
         generated:\n{generated}"
    );
}

/// The entries of a folder with their names.
fn entries(dir: &Path) -> Vec<(PathBuf, String)> {
    std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| {
            let path = e.expect("a folder entry").path();
            let name = path
                .file_name()
                .expect("a name")
                .to_string_lossy()
                .to_string();
            (path, name)
        })
        .collect()
}

/// `docs/architecture.md` names every folder and module of `src/` (as `src/NAME/` or
/// `src/NAME.rs`, or a file of a named folder as `NAME.rs`), so the map cannot fall behind.
#[test]
fn the_architecture_names_every_source_module() {
    let text = read(&repo().join("docs/architecture.md"));
    let mut missing = Vec::new();
    for (path, name) in entries(&repo().join("src")) {
        if path.is_dir() {
            if name == "assets" {
                continue;
            }
            if !text.contains(&format!("`src/{name}/`")) {
                missing.push(format!("src/{name}/"));
            }
            for (_, module) in entries(&path) {
                if module != "mod.rs"
                    && module.ends_with(".rs")
                    && !text.contains(&format!("`{module}`"))
                    && !text.contains(&format!("`src/{name}/{module}`"))
                {
                    missing.push(format!("src/{name}/{module}"));
                }
            }
        } else if name.ends_with(".rs") && !text.contains(&format!("`src/{name}`")) {
            missing.push(format!("src/{name}"));
        }
    }
    missing.sort();
    assert!(
        missing.is_empty(),
        "docs/architecture.md does not name: {}",
        missing.join(", ")
    );
}
