//! Input files (JSON and TOML), the text/JSON report, and `gate_command` (the CLI entry point).

use crate::gate::{evaluate, Report, Verdict};
use crate::model::{Assembly, ModelError};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Everything that can go wrong in `gate_command`.
#[derive(Debug, thiserror::Error)]
pub enum GateError {
    /// The file could not be read or written.
    #[error("{path}: {cause}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause (shown in the message, not repeated as an error source).
        cause: std::io::Error,
    },
    /// The file does not parse or a field has the wrong type; names file, line and field.
    #[error("{path}:{line}:{column}: field `{field}`: {message}")]
    Parse {
        /// File.
        path: PathBuf,
        /// Line (1-based; 0 when unknown).
        line: usize,
        /// Column (1-based; 0 when unknown).
        column: usize,
        /// Field path, e.g. `connections[2].point`.
        field: String,
        /// Parser message.
        message: String,
    },
    /// The content is inconsistent (unknown ids, negative mass, ...); names the field.
    #[error("{path}: {cause}")]
    Model {
        /// File.
        path: PathBuf,
        /// Cause (shown in the message, not repeated as an error source).
        cause: ModelError,
    },
    /// Unknown file extension.
    #[error("{0}: unknown extension (use .json or .toml)")]
    Extension(PathBuf),
    /// The picture could not be drawn.
    #[error("picture {path}: {message}")]
    Picture {
        /// File.
        path: PathBuf,
        /// Cause.
        message: String,
    },
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let col = before.len() - before.rfind('\n').map_or(0, |p| p + 1) + 1;
    (line, col)
}

/// Parse an assembly from text; `toml` selects the format. Errors name line and field.
pub fn parse_assembly(text: &str, toml_format: bool, path: &Path) -> Result<Assembly, GateError> {
    if toml_format {
        let de = toml::Deserializer::new(text);
        serde_path_to_error::deserialize(de).map_err(|e| {
            let field = e.path().to_string();
            let inner = e.into_inner();
            let (line, column) = inner.span().map_or((0, 0), |s| line_col(text, s.start));
            GateError::Parse {
                path: path.to_path_buf(),
                line,
                column,
                field,
                message: inner.message().to_string(),
            }
        })
    } else {
        let mut de = serde_json::Deserializer::from_str(text);
        serde_path_to_error::deserialize(&mut de).map_err(|e| {
            let field = e.path().to_string();
            let inner = e.into_inner();
            GateError::Parse {
                path: path.to_path_buf(),
                line: inner.line(),
                column: inner.column(),
                field,
                message: inner.to_string(),
            }
        })
    }
}

/// Load an assembly file (`.json` or `.toml`) and check it.
pub fn load_assembly(path: &Path) -> Result<Assembly, GateError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let toml_format = match ext.as_deref() {
        Some("toml") => true,
        Some("json") => false,
        _ => return Err(GateError::Extension(path.to_path_buf())),
    };
    let text = std::fs::read_to_string(path).map_err(|cause| GateError::Io {
        path: path.to_path_buf(),
        cause,
    })?;
    let a = parse_assembly(&text, toml_format, path)?;
    a.resolve().map_err(|cause| GateError::Model {
        path: path.to_path_buf(),
        cause,
    })?;
    Ok(a)
}

/// Human-readable report: verdict, margin, worst connections, solve time.
pub fn render_text(r: &Report) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "verdict: {}", r.verdict.name());
    if let Verdict::NotProven { reason } = &r.verdict {
        let _ = writeln!(s, "  reason: {reason}");
    }
    match r.margin {
        Some(m) => {
            let _ = writeln!(s, "internal stability margin: {m:.6}");
        }
        None => {
            let _ = writeln!(s, "internal stability margin: none");
        }
    }
    if let Some(w) = r.max_strength {
        let _ = writeln!(s, "required max characteristic strength: {w:.6}");
    }
    let broken = r.broken();
    if !broken.is_empty() {
        let names: Vec<String> = broken
            .iter()
            .map(|&k| {
                let c = &r.connections[k];
                format!("#{k} {}→{}", c.child, c.parent)
            })
            .collect();
        let _ = writeln!(s, "potential broken connections: {}", names.join(", "));
    }
    let worst = r.worst_connections(5);
    if !worst.is_empty() {
        let _ = writeln!(
            s,
            "worst connections (child→parent: use of limit, strength, f̄ = fx fy fcon mx my mz):"
        );
        for c in worst {
            let u = c
                .use_of_limit
                .map_or("unlimited".to_string(), |u| format!("{:.1} %", 100.0 * u));
            let w = c.wrench;
            let _ = writeln!(
                s,
                "  #{} {}→{} [{}]: {u}, w = {:.4}, f̄ = [{:.4} {:.4} {:.4} {:.5} {:.5} {:.5}]{}",
                c.index,
                c.child,
                c.parent,
                c.connector,
                c.strength,
                w[0],
                w[1],
                w[2],
                w[3],
                w[4],
                w[5],
                if c.over_limit { " OVER LIMIT" } else { "" }
            );
        }
    }
    if let Some(c) = r
        .contacts
        .iter()
        .chain(&r.module_contacts)
        .min_by(|a, b| a.friction_margin.total_cmp(&b.friction_margin))
    {
        let _ = writeln!(
            s,
            "smallest friction margin: {:.6} N (contact #{} on {})",
            c.friction_margin, c.index, c.module
        );
    }
    let st = &r.stats;
    let _ = writeln!(
        s,
        "solve: {:?}, {} modules, {} connections, {} contacts; {} cone program(s), {} iterations{}; build {:.3} ms, solve {:.3} ms, total {:.3} ms",
        st.path,
        st.size[0],
        st.size[1],
        st.size[2],
        st.solves,
        st.iterations,
        if st.fallbacks > 0 {
            format!(" ({} handed to Clarabel)", st.fallbacks)
        } else {
            String::new()
        },
        st.build_seconds * 1e3,
        st.solve_seconds * 1e3,
        st.total_seconds * 1e3
    );
    s
}

/// JSON report.
pub fn render_json(r: &Report) -> String {
    serde_json::to_string_pretty(r).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"))
}

/// The `puzzlebot gate FILE [--json] [--picture SVG]` entry point: load, solve, render,
/// and draw the assembly coloured by connection load when `picture` is given.
pub fn gate_command(path: &Path, json: bool, picture: Option<&Path>) -> Result<String, GateError> {
    let a = load_assembly(path)?;
    let report = evaluate(&a).map_err(|cause| GateError::Model {
        path: path.to_path_buf(),
        cause,
    })?;
    if let Some(pic) = picture {
        crate::picture::draw(&a, &report, pic).map_err(|message| GateError::Picture {
            path: pic.to_path_buf(),
            message,
        })?;
    }
    Ok(if json {
        render_json(&report)
    } else {
        render_text(&report)
    })
}
