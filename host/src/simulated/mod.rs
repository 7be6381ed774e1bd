//! A host wired to an in-process simulated fleet over real loopback sockets: the fleet
//! link and the pose input bind 127.0.0.1 ephemeral ports, the simulator's robots and
//! virtual motion capture send to them. Used by `puzzlebot demo`, `run` without `--fleet`,
//! `calibrate` without `--fleet` ([`calibrate`]), the tracking demo ([`tracking`]) and the
//! end-to-end tests.

pub mod calibrate;
pub mod tracking;

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;
use std::time::Duration;

use puzzlebot_params::{FleetParams, RobotKind, RobotParams};
use puzzlebot_protocol::{messages::RobotId, FleetKey};
use puzzlebot_sim::{Pace, Scenario, SimFleet, SimOptions};

use crate::control::{ControlLoop, HandRequest, TruthProbe};
use crate::link::{FleetLink, LinkConfig};
use crate::pose::{Pbp1Decoder, PoseInput};

/// Host side plus simulated robots, all on loopback.
pub struct SimHarness {
    /// The fleet link.
    pub link: FleetLink,
    /// The pose input.
    pub poses: PoseInput,
    /// The simulated fleet.
    pub fleet: Arc<SimFleet>,
    /// Parameters the simulator runs (the host's defaults are the same set).
    pub params: FleetParams,
}

impl SimHarness {
    /// Start link and pose input on 127.0.0.1:0, then the simulated fleet of `scenario`
    /// (real-time pace) under a fresh random fleet key.
    pub async fn start(scenario: Scenario) -> anyhow::Result<SimHarness> {
        let mut k = [0u8; 32];
        rand::fill(&mut k);
        Self::start_with_key(scenario, FleetKey(k)).await
    }

    /// As [`SimHarness::start`] with a given key.
    pub async fn start_with_key(scenario: Scenario, key: FleetKey) -> anyhow::Result<SimHarness> {
        let mut cfg = LinkConfig::new("127.0.0.1:0".parse()?);
        cfg.rates = scenario.params.rates;
        cfg.allowed = Some(
            scenario
                .robots
                .iter()
                .map(|r| r.id)
                .collect::<BTreeSet<_>>(),
        );
        let link = FleetLink::start(key.clone(), cfg).await?;
        // One clock: pose times count from the link's epoch, as the control loop's do.
        let poses = PoseInput::start("127.0.0.1:0".parse()?, Pbp1Decoder, link.epoch()).await?;
        let params = scenario.params.clone();
        let fleet = SimFleet::start(
            scenario,
            SimOptions {
                fleet_key: key,
                host_addr: link.local_addr()?,
                pose_addr: Some(poses.local_addr()),
                pace: Pace::RealTime,
            },
        )?;
        Ok(SimHarness {
            link,
            poses,
            fleet: Arc::new(fleet),
            params,
        })
    }

    /// Wait until `n` robots have sessions and fresh poses (or fail after `timeout`).
    pub async fn wait_ready(&self, n: usize, timeout: Duration) -> anyhow::Result<()> {
        if !self.link.wait_for_robots(n, timeout).await {
            anyhow::bail!(
                "only {} of {n} simulated robots opened a session within {timeout:?}",
                self.link.online().len()
            );
        }
        let end = tokio::time::Instant::now() + timeout;
        let stale = Duration::from_millis(200);
        while self
            .link
            .online()
            .iter()
            .any(|id| self.poses.table.fresh(*id, stale).is_none())
        {
            if tokio::time::Instant::now() > end {
                anyhow::bail!("no motion-capture poses within {timeout:?}");
            }
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
        Ok(())
    }

    /// Ground-truth probe for the control loop's error metrics.
    pub fn truth_probe(&self) -> TruthProbe {
        let fleet = Arc::clone(&self.fleet);
        Box::new(move || {
            fleet
                .ground_truth()
                .robots
                .iter()
                .map(|r| (r.id, [r.pose.x, r.pose.y, r.pose.yaw]))
                .collect::<BTreeMap<RobotId, [f64; 3]>>()
        })
    }

    /// A control loop over this harness, with the simulator's parameter set and ground truth.
    pub fn control_loop(&self) -> ControlLoop {
        let params = self.params.clone();
        let mut l = ControlLoop::new(
            self.link.clone(),
            self.poses.table.clone(),
            move |_, kind: RobotKind| -> RobotParams { params.robot(kind).clone() },
        );
        l.truth = Some(self.truth_probe());
        let fleet = Arc::clone(&self.fleet);
        l.hand = Some(Box::new(move |r: &HandRequest| match r {
            HandRequest::LiftKnobs { robots } => fleet.lift_knobs(robots),
        }));
        l
    }

    /// Stop the robots, the link and the simulator.
    pub async fn shutdown(self) {
        self.link.shutdown().await;
        drop(self.poses);
        if let Ok(f) = Arc::try_unwrap(self.fleet) {
            f.stop();
        }
    }
}
