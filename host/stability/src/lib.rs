//! Quasi-static stability of modular assemblies as a second-order cone program (the stability
//! gate, SOCP paper §2–4, DESIGN.md §7).
//!
//! - [`model`]: the general model (modules, connections, contacts, loads, connectors) and its
//!   file format (JSON/TOML, see README.md);
//! - [`socp`]: the sparse equilibrium system Zx = b (29) and the cone programs (41)/(51);
//! - [`dual`]: the relaxed program (41) in its equilibrium-multiplier (dual) form (fast);
//! - [`ipm`]: our interior-point method for that form, on the normal equations factorised by
//!   [`blockchol`] (6×6 blocks over the module graph; default solver, Clarabel as fallback);
//! - [`gate`]: Theorem 2 verdicts, margins (42)/(52), broken connections (44), the
//!   determinate-tree fast path;
//! - [`range`]: admissible external load at a point by bisection (SOCP 4.1);
//! - [`puzzlebot`]: PuzzleBot adapter and `max_safe_advance`; [`judge`]: its verdict on a
//!   model; [`transfer`]: the connectors' elastic loads and their peak when the support
//!   changes;
//! - [`crossing`]: which shape, pilot places and heading cross a gap, ranked by the gate;
//! - [`io`]: files, reports and [`io::gate_command`] (the CLI entry point); [`picture`]: SVG.
#![deny(unsafe_code)] // one exception: the thread CPU clock of the benchmarks
#![warn(missing_docs)]

pub mod bench_problems;
pub mod blockchol;
pub mod crossing;
pub mod dual;
pub mod elastic;
pub mod events;
pub mod gate;
pub mod io;
pub mod ipm;
pub mod judge;
pub mod model;
pub mod picture;
pub mod poe;
pub mod puzzlebot;
pub mod range;
pub mod sag;
pub mod socp;
pub mod transfer;

pub use gate::{evaluate, evaluate_with, Formulation, Options, Report, Verdict};
pub use io::{gate_command, load_assembly, GateError};
pub use model::{Assembly, ConnectorSpec, Limits6, ModelError};
pub use puzzlebot::{max_safe_advance, Advance, LimitedBy};
pub use range::{load_range, LoadRange};
