//! Loading parameter files with errors that name the file, line and field.

use std::path::{Path, PathBuf};

/// A parameter or config file that could not be used.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file could not be read.
    #[error("{path}: cannot read: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause (in the message, so it is not repeated as an error source).
        cause: std::io::Error,
    },
    /// A value is out of its range.
    #[error("{path}: {message}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What was wrong, naming the field.
        message: String,
    },
    /// The file is not valid TOML or a field is wrong.
    #[error("{path}:{line}:{column}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line of the error.
        line: usize,
        /// 1-based column of the error.
        column: usize,
        /// What was wrong, naming the field.
        message: String,
    },
}

/// Parse TOML text into `T`, mapping errors to file, line, column and field.
pub fn from_toml_str<T: serde::de::DeserializeOwned>(
    path: &Path,
    text: &str,
) -> Result<T, LoadError> {
    toml::from_str(text).map_err(|e| {
        // An error raised above the field that is wrong (a kind's table laid over its
        // defaults) has no span of its own: the keys its message names give one.
        let (line, column) = e
            .span()
            .filter(|s| s.start > 0)
            .map(|s| line_col(text, s.start))
            .or_else(|| locate(text, e.message()))
            .unwrap_or((1, 1));
        LoadError::Parse {
            path: path.to_path_buf(),
            line,
            column,
            message: e.message().trim().to_string(),
        }
    })
}

/// Read and parse a TOML file into `T`.
pub fn from_toml_file<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, LoadError> {
    let text = std::fs::read_to_string(path).map_err(|cause| LoadError::Io {
        path: path.to_path_buf(),
        cause,
    })?;
    from_toml_str(path, &text)
}

/// Where an error `message` that names keys (`pilot: coupling: unknown field `knob_hold``)
/// points in `text`: the deepest key it names that the text has, as line and column.
fn locate(text: &str, message: &str) -> Option<(usize, usize)> {
    let doc = toml_edit::ImDocument::parse(text).ok()?;
    let mut table = doc.as_table();
    let mut at = None;
    let mut rest = message;
    while let Some((head, tail)) = rest.split_once(": ") {
        let Some(key) = table.key(head.trim()) else {
            break;
        };
        at = key.span().or(at);
        rest = tail;
        match table.get(head.trim()).and_then(|i| i.as_table()) {
            Some(t) => table = t,
            None => break,
        }
    }
    // A field the rest names in backquotes (`unknown field `x``, `missing field `x``).
    let field = rest.split('`').nth(1);
    if let Some(span) = field.and_then(|f| table.key(f)).and_then(|k| k.span()) {
        at = Some(span);
    }
    at.map(|s| line_col(text, s.start))
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

impl crate::FleetParams {
    /// Load fleet parameters from a TOML file, missing fields keeping THESIS defaults, and
    /// check their ranges ([`crate::FleetParams::check`]).
    pub fn from_file(path: &Path) -> Result<Self, LoadError> {
        let p: Self = from_toml_file(path)?;
        p.check().map_err(|message| LoadError::Invalid {
            path: path.to_path_buf(),
            message,
        })?;
        Ok(p)
    }
}

impl crate::RobotParams {
    /// Load one robot's parameters (e.g. a calibration result) from a TOML file; missing
    /// fields keep the non-pilot's defaults ([`crate::RobotParams::from_file_for`] takes the
    /// robot's kind).
    pub fn from_file(path: &Path) -> Result<Self, LoadError> {
        from_toml_file(path)
    }

    /// Load one robot's parameters from a TOML file, missing fields keeping the defaults of
    /// a robot of `kind`.
    pub fn from_file_for(kind: crate::RobotKind, path: &Path) -> Result<Self, LoadError> {
        let text = std::fs::read_to_string(path).map_err(|cause| LoadError::Io {
            path: path.to_path_buf(),
            cause,
        })?;
        let table: toml::Table = from_toml_str(path, &text)?;
        crate::kind_defaults::robot_over_defaults(kind, table).map_err(|message| {
            let (line, column) = locate(&text, &message).unwrap_or((1, 1));
            LoadError::Parse {
                path: path.to_path_buf(),
                line,
                column,
                message,
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::FleetParams;

    #[test]
    fn partial_file_overrides_only_named_fields() {
        let p: FleetParams = from_toml_str(
            Path::new("fleet.toml"),
            "[pilot.drive]\nk_v = 0.003\n[rates]\nmpc_hz = 20.0\n",
        )
        .expect("valid");
        assert_eq!(p.pilot.drive.k_v, 0.003);
        assert!(
            p.pilot.plant.four_wheels,
            "the pilot keeps its own defaults"
        );
        assert_eq!(p.rates.mpc_hz, 20.0);
        assert_eq!(p.non_pilot, FleetParams::default().non_pilot);
    }

    #[test]
    fn an_error_inside_a_kinds_table_names_its_line() {
        let err = from_toml_str::<FleetParams>(
            Path::new("fleet.toml"),
            "[rates]\nmpc_hz = 10.0\n\n[pilot.coupling]\nknob_hold_force = 6.4\nknob_hold = 1.0\n",
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.starts_with("fleet.toml:6:1: pilot: coupling: unknown field `knob_hold`"),
            "{err}"
        );
        let dir = std::env::temp_dir().join(format!("pb-params-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("pilot.toml");
        std::fs::write(
            &f,
            "[drive]\nk_v = 0.003\n[coupling]\nknob_hold_force = \"x\"\n",
        )
        .unwrap();
        let err = crate::RobotParams::from_file_for(crate::RobotKind::Pilot, &f)
            .unwrap_err()
            .to_string();
        std::fs::remove_dir_all(&dir).ok();
        assert!(err.contains("pilot.toml:3:"), "{err}");
    }

    #[test]
    fn errors_name_file_line_and_field() {
        let err = from_toml_str::<FleetParams>(
            Path::new("fleet.toml"),
            "[rates]\nmpc_hz = 10.0\ncommand_hz = \"fast\"\n",
        )
        .expect_err("wrong type");
        let msg = err.to_string();
        assert!(msg.starts_with("fleet.toml:3:"), "{msg}");
        let err = from_toml_str::<FleetParams>(Path::new("f.toml"), "[rates]\nmpc_herz = 1.0\n")
            .expect_err("unknown field");
        let msg = err.to_string();
        assert!(
            msg.contains("f.toml:2:") && msg.contains("mpc_herz"),
            "{msg}"
        );
    }
}
