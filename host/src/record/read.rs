//! Reading a recording back: every message as JSON with its topic and time, and the run's
//! robots, parameters and terrain.

use std::path::Path;

use anyhow::Context;
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_protocol::RobotId;
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// Name of the attachment that carries the run's robots, parameters and terrain.
pub const RUN_ATTACHMENT: &str = "puzzlebot_run.json";

/// The run's robots, robot parameters and terrain, attached to the recording so a replay
/// draws the bodies the run had (and sent first to a live page).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunInfo {
    /// Every robot: id and kind.
    pub robots: Vec<(RobotId, RobotKind)>,
    /// The robot parameters.
    pub params: FleetParams,
    /// The terrain.
    pub terrain: Terrain,
}

/// One recorded message.
#[derive(Debug, Clone)]
pub struct Message {
    /// Channel topic.
    pub topic: String,
    /// Log time (s since the run started).
    pub t: f64,
    /// The message.
    pub data: Value,
}

/// A recording read back from `run.mcap`.
#[derive(Debug, Clone)]
pub struct Recording {
    /// The run's robots, robot parameters and terrain.
    pub info: RunInfo,
    /// Every message, in log-time order.
    pub messages: Vec<Message>,
}

impl Recording {
    /// Read `path` (a recording written by [`super::Recorder::write`]).
    pub fn read(path: &Path) -> anyhow::Result<Recording> {
        let bytes = std::fs::read(path).with_context(|| format!("{}", path.display()))?;
        let what = || format!("{}: not a PuzzleBot recording", path.display());
        let mut messages = Vec::new();
        for m in mcap::MessageStream::new(&bytes).with_context(what)? {
            let m = m.with_context(what)?;
            messages.push(Message {
                topic: m.channel.topic.clone(),
                t: m.log_time as f64 * 1e-9,
                data: serde_json::from_slice(&m.data).with_context(what)?,
            });
        }
        messages.sort_by(|a, b| a.t.total_cmp(&b.t));
        let summary = mcap::Summary::read(&bytes)
            .with_context(what)?
            .with_context(what)?;
        let index = summary
            .attachment_indexes
            .iter()
            .find(|a| a.name == RUN_ATTACHMENT)
            .with_context(|| format!("{}: no {RUN_ATTACHMENT} attachment", path.display()))?;
        let attachment = mcap::read::attachment(&bytes, index).with_context(what)?;
        let info = serde_json::from_slice(&attachment.data).with_context(what)?;
        Ok(Recording { info, messages })
    }

    /// The messages on `topic`, in time order.
    pub fn topic<'a>(&'a self, topic: &'a str) -> impl Iterator<Item = &'a Message> + 'a {
        self.messages.iter().filter(move |m| m.topic == topic)
    }
}
