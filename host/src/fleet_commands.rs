//! `puzzlebot fleet …`: set up a fleet config, list and check its robots, provision them
//! and update their firmware over the air.

use std::path::PathBuf;
use std::time::Duration;

use puzzlebot_host::app;
use puzzlebot_host::config::Fleet;

use crate::cli::{FleetCmd, KindArg};

/// Run a `puzzlebot fleet` subcommand.
pub(crate) async fn run(cmd: FleetCmd) -> anyhow::Result<()> {
    match cmd {
        FleetCmd::Init { dir } => {
            let (config, key) = puzzlebot_host::fleet_setup::init(&dir)?;
            println!(
                "wrote {} and {} (owner-only; keep it off the robots and out of version control)",
                config.display(),
                key.display()
            );
        }
        FleetCmd::Add { id, kind, fleet } => {
            let kind = match kind {
                KindArg::Pilot => puzzlebot_params::RobotKind::Pilot,
                KindArg::NonPilot => puzzlebot_params::RobotKind::NonPilot,
            };
            puzzlebot_host::fleet_setup::add_robot(&fleet, id, kind)?;
            println!("{}: robot {id} ({kind:?}) listed", fleet.display());
        }
        FleetCmd::Check { fleet, seconds } => {
            let fleet = Fleet::load(&fleet)?;
            let (link, _poses) = app::start_host(&fleet).await?;
            let listed = &fleet.config.robots;
            let end = tokio::time::Instant::now() + Duration::from_secs_f64(seconds.max(0.0));
            let mut report = puzzlebot_host::fleet_setup::check_report(listed, &link.statuses());
            while !report.1.is_empty() && tokio::time::Instant::now() < end {
                tokio::time::sleep(Duration::from_millis(200)).await;
                report = puzzlebot_host::fleet_setup::check_report(listed, &link.statuses());
            }
            link.shutdown().await;
            print!("{}", report.0);
            if !report.1.is_empty() {
                anyhow::bail!("fleet not ready: {}", report.1.join("; "));
            }
            println!("{}: ready", fleet.path.display());
        }
        FleetCmd::Provision {
            id,
            ssid,
            password_file,
            host,
            out,
            fleet,
        } => {
            use puzzlebot_host::fleet_provision as prov;
            // The config and its key first: a bad one is reported before any note.
            Fleet::load(&fleet)?;
            let req = prov::Request {
                id,
                ssid,
                password: prov::read_password(password_file.as_deref())?,
                host,
            };
            let update_key = puzzlebot_host::fleet_update::verifying_key(&fleet)?;
            if update_key.is_none() {
                eprintln!(
                    "note: {} has no update key; this robot will refuse over-the-air updates",
                    fleet.display()
                );
            }
            let blob = prov::record(&fleet, &req, update_key)?;
            let out = out.unwrap_or_else(|| PathBuf::from(format!("robot-{id}.bin")));
            prov::write_blob(&out, &blob)?;
            println!(
                "wrote {} ({} bytes, owner-only); flash it with:\n  espflash write-bin {:#x} {}",
                out.display(),
                blob.len(),
                prov::PARTITION_OFFSET,
                out.display()
            );
        }
        FleetCmd::UpdateKey { fleet } => {
            let path = puzzlebot_host::fleet_setup::add_update_key(&fleet)?;
            println!(
                "wrote {} (owner-only); re-provision the robots to trust it",
                path.display()
            );
        }
        FleetCmd::Update {
            image,
            version,
            ids,
            fleet,
            seconds,
        } => {
            let fleet = Fleet::load(&fleet)?;
            let patience = Duration::from_secs_f64(seconds.max(1.0));
            let ids = if ids.is_empty() {
                fleet.config.robots.iter().map(|r| r.id).collect()
            } else {
                ids
            };
            // Key and image first: a bad one is reported before any robot is touched.
            puzzlebot_host::fleet_update::read_signing_key(&fleet.path)?;
            puzzlebot_host::fleet_update::read_image(&image, version.as_deref())?;
            let (link, _poses) = app::start_host(&fleet).await?;
            let done = puzzlebot_host::fleet_update::run(
                &link,
                &fleet.path,
                &image,
                version.as_deref(),
                &ids,
                patience,
            )
            .await;
            link.shutdown().await;
            for line in done? {
                println!("{line}");
            }
        }
        FleetCmd::RobotKey { id, fleet } => {
            println!(
                "{}",
                puzzlebot_host::fleet_setup::robot_key_hex(&fleet, id)?
            );
        }
    }
    Ok(())
}
