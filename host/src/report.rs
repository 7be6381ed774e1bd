//! Run folders: `runs/<UTC timestamp>-<name>/` with JSON-lines telemetry and events, a
//! summary, and SVG plots of path tracking and wheel speeds. Pictures of assembly runs
//! (footprints at the milestones) and the replay page come from [`crate::replay`].

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use plotters::prelude::*;
use puzzlebot_protocol::messages::RobotId;
use serde::Serialize;

/// Picks one wheel-speed series out of a trace sample.
type WheelGetter = fn(&(f64, f64, f64, f64, f64)) -> f64;

/// One robot's traces kept for the plots.
#[derive(Debug, Clone, Default)]
pub struct Traces {
    /// Actual positions (t, x, y).
    pub actual: Vec<(f64, f64, f64)>,
    /// Reference positions (t, x, y).
    pub reference: Vec<(f64, f64, f64)>,
    /// Wheel speeds (t, target left, target right, measured left, measured right), RPM.
    pub wheels: Vec<(f64, f64, f64, f64, f64)>,
}

/// An open run folder.
pub struct RunFolder {
    dir: PathBuf,
    telemetry: BufWriter<File>,
    events: BufWriter<File>,
    /// Traces per robot for the plots.
    pub traces: BTreeMap<RobotId, Traces>,
}

/// UTC date-time `YYYYMMDD-HHMMSS` of the system clock (for folder names only).
pub fn utc_stamp() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    // Civil from days (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}{m:02}{d:02}-{:02}{:02}{:02}",
        rem / 3600,
        (rem / 60) % 60,
        rem % 60
    )
}

impl RunFolder {
    /// Create `<base>/<timestamp>-<name>/` (a numeric suffix keeps folders unique).
    pub fn create(base: &Path, name: &str) -> std::io::Result<RunFolder> {
        let safe: String = name
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        let stamp = utc_stamp();
        std::fs::create_dir_all(base)?;
        // `create_dir` fails on an existing folder, so two runs started in the same second
        // (two processes) never share one.
        let mut i = 1;
        let dir = loop {
            let dir = match i {
                1 => base.join(format!("{stamp}-{safe}")),
                _ => base.join(format!("{stamp}-{safe}-{i}")),
            };
            match std::fs::create_dir(&dir) {
                Ok(()) => break dir,
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => i += 1,
                Err(e) => return Err(e),
            }
        };
        Ok(RunFolder {
            telemetry: BufWriter::new(File::create(dir.join("telemetry.jsonl"))?),
            events: BufWriter::new(File::create(dir.join("events.jsonl"))?),
            dir,
            traces: BTreeMap::new(),
        })
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Append one telemetry record.
    pub fn telemetry(&mut self, rec: &impl Serialize) -> std::io::Result<()> {
        serde_json::to_writer(&mut self.telemetry, rec)?;
        self.telemetry.write_all(b"\n")
    }

    /// Append one event.
    pub fn event(&mut self, rec: &impl Serialize) -> std::io::Result<()> {
        serde_json::to_writer(&mut self.events, rec)?;
        self.events.write_all(b"\n")
    }

    /// Write a JSON file into the folder.
    pub fn write_json(&self, file: &str, value: &impl Serialize) -> std::io::Result<PathBuf> {
        let p = self.dir.join(file);
        let f = BufWriter::new(File::create(&p)?);
        serde_json::to_writer_pretty(f, value)?;
        Ok(p)
    }

    /// Flush the logs and draw the plots; returns the files written. `trajectories.svg`
    /// (measured against reference paths) is drawn for runs that follow references.
    pub fn finish(&mut self) -> std::io::Result<Vec<PathBuf>> {
        self.telemetry.flush()?;
        self.events.flush()?;
        let mut out = Vec::new();
        if self.traces.values().any(|t| !t.reference.is_empty()) {
            let p = self.dir.join("trajectories.svg");
            plot_trajectories(&p, &self.traces).map_err(std::io::Error::other)?;
            out.push(p);
        }
        if self.traces.values().any(|t| !t.wheels.is_empty()) {
            let p = self.dir.join("wheel_speeds.svg");
            plot_wheels(&p, &self.traces).map_err(std::io::Error::other)?;
            out.push(p);
        }
        Ok(out)
    }
}

fn bounds(it: impl Iterator<Item = (f64, f64)>) -> ((f64, f64), (f64, f64)) {
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for (x, y) in it {
        if x.is_finite() && y.is_finite() {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
    }
    if !x0.is_finite() {
        return ((0.0, 1.0), (0.0, 1.0));
    }
    let pad = 0.05 * (x1 - x0).max(y1 - y0).max(0.02);
    ((x0 - pad, x1 + pad), (y0 - pad, y1 + pad))
}

/// Plot every robot's actual path (solid) and reference (thin) in the x–y plane: how well
/// paths were tracked.
pub fn plot_trajectories(path: &Path, traces: &BTreeMap<RobotId, Traces>) -> Result<(), String> {
    let root = SVGBackend::new(path, (900, 800)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let ((x0, x1), (y0, y1)) = bounds(traces.values().flat_map(|t| {
        t.actual
            .iter()
            .chain(t.reference.iter())
            .map(|p| (p.1, p.2))
    }));
    // Equal scale on both axes.
    let span = (x1 - x0).max(y1 - y0);
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Trajectories (solid: measured, thin: reference)",
            ("sans-serif", 20),
        )
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(
            cx - span / 2.0..cx + span / 2.0,
            cy - span / 2.0..cy + span / 2.0,
        )
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc("x (m)")
        .y_desc("y (m)")
        .draw()
        .map_err(|e| e.to_string())?;
    for (i, (id, t)) in traces.iter().enumerate() {
        let c = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(
                t.reference.iter().map(|p| (p.1, p.2)),
                c.mix(0.4).stroke_width(1),
            ))
            .map_err(|e| e.to_string())?;
        chart
            .draw_series(LineSeries::new(
                t.actual.iter().map(|p| (p.1, p.2)),
                c.stroke_width(2),
            ))
            .map_err(|e| e.to_string())?
            .label(format!("robot {id}"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())?;
    root.present().map_err(|e| e.to_string())
}

/// Plot wheel-speed targets (thin) and measured speeds (solid) per robot over time.
pub fn plot_wheels(path: &Path, traces: &BTreeMap<RobotId, Traces>) -> Result<(), String> {
    let n = traces.len().max(1);
    let root = SVGBackend::new(path, (900, 260 * n as u32)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let panels = root.split_evenly((n, 1));
    for (panel, (id, t)) in panels.iter().zip(traces.iter()) {
        let ((t0, t1), (w0, w1)) = bounds(
            t.wheels
                .iter()
                .flat_map(|w| [(w.0, w.1), (w.0, w.2), (w.0, w.3), (w.0, w.4)]),
        );
        let mut chart = ChartBuilder::on(panel)
            .caption(
                format!("robot {id}: wheel speed (thin: target, solid: measured)"),
                ("sans-serif", 16),
            )
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(50)
            .build_cartesian_2d(t0..t1, w0..w1)
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc("t (s)")
            .y_desc("RPM")
            .draw()
            .map_err(|e| e.to_string())?;
        let series: [(&str, RGBColor, WheelGetter, u32); 4] = [
            ("left target", BLUE, |w| w.1, 1),
            ("right target", RED, |w| w.2, 1),
            ("left measured", BLUE, |w| w.3, 2),
            ("right measured", RED, |w| w.4, 2),
        ];
        for (name, color, get, width) in series {
            chart
                .draw_series(LineSeries::new(
                    t.wheels.iter().map(|w| (w.0, get(w))),
                    color.stroke_width(width),
                ))
                .map_err(|e| e.to_string())?
                .label(name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(width))
                });
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| e.to_string())?;
    }
    root.present().map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folder_logs_and_plots() {
        let base = std::env::temp_dir().join(format!("pb-runs-{}", std::process::id()));
        let mut f = RunFolder::create(&base, "unit test").expect("create");
        assert!(f
            .dir()
            .file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n.ends_with("-unit_test")));
        f.telemetry(&serde_json::json!({"t": 0.0})).expect("write");
        f.event(&serde_json::json!({"event": "start"}))
            .expect("write");
        let tr = f.traces.entry(1).or_default();
        for i in 0..20 {
            let t = f64::from(i) * 0.1;
            tr.actual.push((t, t * 0.1, 0.001 * t));
            tr.reference.push((t, t * 0.1, 0.0));
            tr.wheels.push((t, 50.0, 50.0, 49.0, 51.0));
        }
        let files = f.finish().expect("finish");
        assert_eq!(files.len(), 2);
        let svg = std::fs::read_to_string(&files[0]).expect("svg");
        assert!(svg.contains("<svg") && svg.contains("robot 1"));
        let lines = std::fs::read_to_string(f.dir().join("telemetry.jsonl")).expect("read");
        assert_eq!(lines.lines().count(), 1);
        assert_eq!(utc_stamp().len(), 15);
    }

    #[test]
    fn paths_without_references_get_no_tracking_plot() {
        let base = std::env::temp_dir().join(format!("pb-runs-paths-{}", std::process::id()));
        let mut f = RunFolder::create(&base, "paths").expect("create");
        f.traces.entry(1).or_default().actual = vec![(0.0, 0.0, 0.0), (0.1, 0.01, 0.0)];
        assert!(f.finish().expect("finish").is_empty());
        assert!(!f.dir().join("trajectories.svg").exists());
        std::fs::remove_dir_all(&base).ok();
    }

    #[test]
    fn runs_started_together_get_folders_of_their_own() {
        // Two processes starting a run in the same second once shared a folder (checked,
        // then created: both saw it missing) and interleaved their telemetry.
        let base = std::env::temp_dir().join(format!("pb-runs-race-{}", std::process::id()));
        let dirs: Vec<std::path::PathBuf> = std::thread::scope(|s| {
            let hs: Vec<_> = (0..8)
                .map(|_| s.spawn(|| RunFolder::create(&base, "race").expect("create")))
                .collect();
            hs.into_iter()
                .map(|h| h.join().expect("thread").dir().to_path_buf())
                .collect()
        });
        let unique: std::collections::BTreeSet<_> = dirs.iter().collect();
        assert_eq!(unique.len(), dirs.len(), "{dirs:?}");
        std::fs::remove_dir_all(&base).ok();
    }
}
