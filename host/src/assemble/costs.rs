//! Cost terms of each robot's MPC problem, one set per coordinator task (THESIS 4.5–4.8,
//! 5.25, 5.26), and the heading weights they use.

use puzzlebot_assembly::{PairStatus, PairType, Role};
use puzzlebot_mpc::{Command, ConnectionPoint, CostTerm, StageWeights};

/// Heading weight of the anchors' maintenance cost (THESIS 4.8; relative to its position
/// weight W_c = 1000, see `MpcConfig::maintain_heading`) while a shape forms: keeps coupled
/// joints straight while their robots align with others, and loose enough that a segment
/// can still turn to meet its partner (a stiffer joint holds the segment off).
pub const MAINTAIN_HEADING_FORM: f64 = 0.008;
/// Heading weight of the anchors' maintenance cost when not forming (holding, decoupling):
/// a train that bent in a turn (≈ 0.2 rad at a 0.3 m radius) is not straightened. While
/// assemblies move the maintenance cost is off (see `AssemblyController::update`).
pub const MAINTAIN_HEADING_HOLD: f64 = 0.003;

/// Heading weight (relative to position) of a robot hanging at a connected anchor while its
/// assembly moves (its role aligns it with its partner, see `Coordinator::tasks`) when that
/// assembly is a mesh (a connected knob pair makes it rigid in part): keeps it steering in
/// line like a knob pair does. A robot pushed along at an anchor (a pilot at the front of a
/// driving mesh) swings into the anchor's play and turns the mesh after it. A train keeps the
/// anchors' weak heading term: it bends in turns.
pub const HANG_HEADING: f64 = 0.1;

/// Heading weight (relative to position) of a held member of a grown assembly keeping its
/// pose (`Role::Keep`): it turns back when a robot docking at its side turns it about its
/// anchor. Only the held robots of a grown assembly keep their poses: in an assembly formed
/// in parallel the held robots turning back strain the couplings already made.
pub const KEEP_HEADING: f64 = 0.01;

/// THESIS (4.5)–(4.7), (5.25), (5.26): a task's cost terms; `in_mesh`: the robot's
/// assembly has a connected knob pair.
pub fn costs(role: &Role, in_mesh: bool) -> Vec<CostTerm> {
    let lead = StageWeights {
        stage: 1.0e3,
        terminal: 1.0e4,
    };
    let follow = StageWeights {
        stage: 1.0e2,
        terminal: 1.0e3,
    };
    match role {
        Role::Hold | Role::Wait => Vec::new(),
        Role::Keep { pose } => vec![CostTerm::FollowTrajectory {
            reference: vec![*pose],
            weights: lead,
            heading: KEEP_HEADING,
        }],
        Role::Align {
            partner,
            own_point,
            partner_point,
            relative_yaw,
            kind,
            phase,
            ..
        } => vec![CostTerm::AlignPair {
            partner: *partner,
            own: ConnectionPoint {
                pos: *own_point,
                angle: 0.0,
            },
            partner_point: ConnectionPoint {
                pos: *partner_point,
                angle: *relative_yaw,
            },
            weights: lead,
            // A knob fits only within atan(1/25) ≈ 0.04 rad (THESIS 5.2.3): its pair
            // needs the heading as much as the position.
            heading: match kind {
                PairType::KnobHole => 1.0e-1,
                PairType::AnchorOpening if in_mesh && *phase == PairStatus::Connected => {
                    HANG_HEADING
                }
                PairType::AnchorOpening => 1.0e-3,
            },
        }],
        Role::Follow { leader, offset } => vec![CostTerm::FollowLeader {
            leader: *leader,
            offset: *offset,
            weights: follow,
            heading: 1.0e-3,
        }],
        // A hitched train member drives its command directly; its MPC fits the same
        // twist so the plan its neighbours see is the one it drives.
        Role::Velocity { v, w } | Role::Hitch { v, w, .. } => vec![CostTerm::FitVelocity {
            target: Command { v: *v, omega: *w },
            w_v: 1.0e3,
            w_omega: 1.0e2,
        }],
        Role::GoTo { goal, use_yaw } => {
            if *use_yaw {
                vec![CostTerm::FollowTrajectory {
                    reference: vec![*goal],
                    weights: lead,
                    heading: 1.0e-2,
                }]
            } else {
                vec![CostTerm::GoToGoal {
                    goal: [goal.x, goal.y],
                    point: [0.0, 0.0],
                    weights: lead,
                }]
            }
        }
        Role::Track { reference } => vec![CostTerm::FollowTrajectory {
            reference: reference.clone(),
            weights: lead,
            heading: 1.0e-3,
        }],
        // Docking and the point law drive directly (see `Role::Dock`, `Role::Drive`).
        Role::Dock { .. } | Role::Drive { .. } => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use puzzlebot_assembly::Pose;

    #[test]
    fn a_robot_hanging_at_an_anchor_keeps_in_line_in_a_mesh_and_bends_in_a_train() {
        let hanging = |phase| Role::Align {
            pair: 0,
            partner: 2,
            own_point: [0.04, 0.0],
            partner_point: [-0.04, 0.0],
            relative_yaw: 0.0,
            kind: PairType::AnchorOpening,
            phase,
        };
        let heading = |role: &Role, in_mesh| match costs(role, in_mesh)[..] {
            [CostTerm::AlignPair { heading, .. }] => heading,
            ref c => panic!("costs {c:?}"),
        };
        let moving = hanging(PairStatus::Connected);
        assert_eq!(heading(&moving, true), HANG_HEADING);
        // A train bends in turns; an anchor being inserted is steered by its position.
        assert!(heading(&moving, false) < HANG_HEADING / 10.0);
        assert!(heading(&hanging(PairStatus::HeadAligned), true) < HANG_HEADING / 10.0);
    }

    #[test]
    fn a_kept_robot_is_driven_back_to_its_pose_and_a_held_one_is_not_driven() {
        let pose = Pose::new(0.1, -0.2, 0.3);
        match &costs(&Role::Keep { pose }, false)[..] {
            [CostTerm::FollowTrajectory {
                reference, heading, ..
            }] => {
                assert_eq!(reference, &vec![Pose::new(0.1, -0.2, 0.3)]);
                assert_eq!(*heading, KEEP_HEADING);
            }
            c => panic!("costs {c:?}"),
        }
        assert!(costs(&Role::Hold, false).is_empty());
    }
}
