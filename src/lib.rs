//! mbmf: a batch simulator of model-free / model-based expert coordination under variable human
//! feedback (Dromnelle et al., RO-MAN 2020). The project's `SPEC.md` section numbers are cited
//! throughout as "SPEC n".
//!
//! The library is the engine, its outputs and analyses; the `mbmf` command line is the binary
//! (`src/main.rs`, `src/cli/`), built with the default `cli` feature. Without that feature the
//! library pulls in no terminal crate (clap, indicatif, signal-hook), so another front end (a
//! Python binding, a server) calls [`run::execute`] and the other entries directly.
#![warn(missing_docs)]
// The per-run kernels take the spec, the parameters and each piece of state as separate
// arguments, as rapier's pipeline does: nothing hidden, and the borrow checker can split work.
#![allow(clippy::too_many_arguments)]

pub mod analysis;
pub mod arbiter;
pub mod batch;
pub mod bench;
pub mod env;
pub mod error;
pub mod expert;
pub mod huge_pages;
pub mod human;
pub mod limits;
pub mod meta;
pub mod output;
pub mod params;
pub mod pipeline;
pub mod plot;
pub mod reproduce;
pub mod rng;
pub mod run;
pub mod run_stats;
pub mod schedule;
pub mod session;
pub mod sizing;
pub mod suggest;
pub mod sweep;
pub mod vec_env;
#[cfg(feature = "web")]
pub mod web;
pub mod whole_file;
