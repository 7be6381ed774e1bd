//! Seeing a run: `replay.html` (a self-contained page that plays the run back) and
//! `milestones.svg` (footprints at the milestones) from a run folder, the progress line while
//! a run goes and the summary table at its end (host README, "Replay").

pub mod milestones;
pub mod page;
pub mod progress;
pub mod snapshots;
pub mod summary;
pub mod timeline;
pub mod words;

use std::path::{Path, PathBuf};

pub use page::REPLAY_HTML;
pub use progress::{PlanPair, Progress};
pub use snapshots::MILESTONES_SVG;
pub use summary::Summary;
pub use timeline::Timeline;

/// What [`write`] wrote.
#[derive(Debug, Clone)]
pub struct Written {
    /// The run as read back.
    pub timeline: Timeline,
    /// `replay.html`.
    pub page: PathBuf,
    /// `milestones.svg`.
    pub picture: PathBuf,
}

/// Write `replay.html` and `milestones.svg` into the run folder `dir` (read from its
/// `run.mcap`, or its telemetry without one).
pub fn write(dir: &Path) -> anyhow::Result<Written> {
    let timeline = Timeline::from_folder(dir)?;
    if timeline.samples.is_empty() {
        anyhow::bail!("{}: the run has no poses to replay", dir.display());
    }
    let page = page::write(dir, &timeline)?;
    let picture = snapshots::write(dir, &timeline)?;
    Ok(Written {
        timeline,
        page,
        picture,
    })
}

/// A run folder's name, for titles.
fn title_of(dir: &Path) -> String {
    dir.file_name()
        .map_or_else(|| "run".to_string(), |n| n.to_string_lossy().into_owned())
}

/// Text safe inside an HTML or SVG element.
fn page_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
