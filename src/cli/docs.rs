//! Shell completions and man pages, generated from the same clap definition as the parser, so
//! they never drift from the flags the binary accepts.

use std::path::PathBuf;

use anyhow::Context as _;
use clap::{Args, CommandFactory, ValueEnum};

use super::{Cli, Failure, runtime, usage};

/// Shells `mbmf completions` writes a script for.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Shell {
    /// Bash (source it, or put it in bash-completion's folder).
    Bash,
    /// Zsh (put it on $fpath as `_mbmf`).
    Zsh,
    /// Fish (put it in ~/.config/fish/completions/mbmf.fish).
    Fish,
    /// PowerShell (dot-source it from $PROFILE).
    Powershell,
    /// Elvish (`eval` it from rc.elv).
    Elvish,
}

/// Arguments of `mbmf completions`.
#[derive(Debug, Args)]
pub struct CompletionsArgs {
    /// The shell to write a completion script for.
    #[arg(value_enum)]
    pub shell: Shell,
}

/// Arguments of `mbmf man`.
#[derive(Debug, Args)]
pub struct ManArgs {
    /// Write one page per verb (mbmf.1, mbmf-run.1, ...) into this folder instead of printing
    /// the main page.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `mbmf completions SHELL`: the completion script on standard output.
pub fn completions(args: &CompletionsArgs) -> Result<(), Failure> {
    use clap_complete::Shell as S;
    let shell = match args.shell {
        Shell::Bash => S::Bash,
        Shell::Zsh => S::Zsh,
        Shell::Fish => S::Fish,
        Shell::Powershell => S::PowerShell,
        Shell::Elvish => S::Elvish,
    };
    let mut buffer = Vec::new();
    clap_complete::generate(shell, &mut Cli::command(), "mbmf", &mut buffer);
    out!("{}", String::from_utf8_lossy(&buffer));
    Ok(())
}

/// `mbmf man`: the roff page on standard output, or one page per verb into `--out`.
pub fn man(args: &ManArgs) -> Result<(), Failure> {
    let command = Cli::command();
    let Some(dir) = &args.out else {
        let mut buffer = Vec::new();
        clap_mangen::Man::new(command)
            .render(&mut buffer)
            .context("cannot render the man page")
            .map_err(runtime)?;
        out!("{}", String::from_utf8_lossy(&buffer));
        return Ok(());
    };
    if dir.exists() && !dir.is_dir() {
        return Err(usage(anyhow::anyhow!(
            "--out {}: it is a file, not a folder; give a folder to write the man pages into",
            dir.display()
        )));
    }
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create folder {}", dir.display()))
        .map_err(runtime)?;
    clap_mangen::generate_to(command, dir)
        .with_context(|| format!("cannot write the man pages into {}", dir.display()))
        .map_err(runtime)?;
    outln!("wrote the man pages into {}", dir.display());
    Ok(())
}
