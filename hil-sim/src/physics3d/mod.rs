//! 3-D crossing physics (DESIGN §6, issue "cross the gap"): formed assemblies on platforms
//! with heights, gaps and steps, on the `rapier3d` engine, every robot driven by
//! `firmware/core` through its motor and gearbox model.
//!
//! * [`config`]: settings the parameter set does not carry; connector strength.
//! * [`terrain`]: platforms as colliders, and the checks a terrain must pass.
//! * [`body`]: a robot as chassis, driven wheels and casters with mass and inertia.
//! * [`motor`]: DC motor + gearbox as a wheel-joint motor (torque, not velocity).
//! * [`coupling`]: soft anchors and knobs as joints with limits and strength.
//! * [`onboard`]: the firmware and the host session of each robot.
//! * [`world`]: the lockstep [`World3d`].
//! * [`assembly`]: formed lines and meshes as THESIS starts its crossings.
//!
//! Robot parts touch the terrain, not each other: robots interact through their couplings.

pub mod assembly;
pub mod body;
pub mod config;
pub mod coupling;
pub mod motor;
pub mod onboard;
pub mod terrain;
pub mod world;

pub use config::{Config3d, Strength};
pub use world::{Event3d, RobotState3d, World3d, World3dError};
