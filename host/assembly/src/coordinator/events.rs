//! What the coordinator records: every status change, plan, loss and behaviour, with its time.

use super::*;

/// Something that happened, with its time.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "event")]
pub enum EventKind {
    /// A plan was made (Algorithm 2).
    Planned {
        /// Robots in the plan.
        robots: Vec<RobotId>,
        /// Number of pairs.
        pairs: usize,
    },
    /// A pair changed status.
    PairStatus {
        /// Pair index.
        pair: usize,
        /// Anchor / knob robot.
        a: RobotId,
        /// Opening / hole robot.
        b: RobotId,
        /// Pair type.
        kind: PairType,
        /// Before.
        from: PairStatus,
        /// After.
        to: PairStatus,
    },
    /// A side pair was re-targeted: the docking robot's knob / hole clicked in with a
    /// neighbour of its planned partner at the same place in the shape (a mesh side has a
    /// hole every half body; the anchors' play decides which lines up first).
    PairRetargeted {
        /// Pair index.
        pair: usize,
        /// Planned knob robot and hole robot.
        from: (RobotId, RobotId),
        /// Knob robot and hole robot now.
        to: (RobotId, RobotId),
    },
    /// Two robots coupled by an anchor the plan does not have (e.g. the wrong way round):
    /// they wiggle apart (THESIS 5.7) before formation goes on.
    UnplannedCoupling {
        /// Robot whose anchor is in.
        anchor: RobotId,
        /// Robot whose opening holds it.
        opening: RobotId,
    },
    /// An unplanned coupling came apart.
    UnplannedReleased {
        /// Robot whose anchor was in.
        anchor: RobotId,
        /// Robot whose opening held it.
        opening: RobotId,
    },
    /// A decouple behaviour has knob pairs: robots cannot pull a knob out of its hole
    /// (THESIS 5.5.3), so a person lifts them apart; the anchor pairs wiggle once every
    /// knob pair is measured out of its hole.
    LiftKnobs {
        /// Robots of the pairs being decoupled (lift the knob pairs among them).
        robots: Vec<RobotId>,
        /// The tracked knob pairs (knob robot, hole robot).
        pairs: Vec<(RobotId, RobotId)>,
    },
    /// A robot was declared lost.
    RobotLost {
        /// The robot.
        robot: RobotId,
    },
    /// The plan was recomputed without lost robots.
    Replanned {
        /// Robots in the new plan.
        robots: Vec<RobotId>,
    },
    /// Re-planning failed; the coordinator holds everyone.
    ReplanFailed {
        /// Why.
        reason: String,
    },
    /// Every pair of the plan is connected.
    FormationComplete,
    /// A grown formation counts as complete with these closing knobs of its layout open
    /// (knob robot, hole robot): they did not seat within
    /// [`super::CoordinatorConfig::closure_wait_s`] ([`super::Closure`]).
    ClosuresOpen {
        /// The open knobs (knob robot, hole robot).
        pairs: Vec<(RobotId, RobotId)>,
    },
    /// A behaviour started.
    BehaviourStarted {
        /// Its name.
        name: String,
    },
    /// A scenario step started.
    StepStarted {
        /// Step index (0-based).
        index: usize,
        /// Its label or behaviour name.
        label: String,
    },
    /// A scenario step finished.
    StepFinished {
        /// Step index.
        index: usize,
    },
    /// A scenario step failed (timeout or planning error); the scenario stops.
    StepFailed {
        /// Step index.
        index: usize,
        /// Why.
        reason: String,
    },
    /// A pair came apart while its assembly moved: the move stops and the pair is coupled
    /// again (the plan's formation) before the move goes on.
    Recoupling {
        /// Anchor / knob robot.
        a: RobotId,
        /// Opening / hole robot.
        b: RobotId,
        /// The move step.
        index: usize,
    },
    /// Every pair is coupled again after [`EventKind::Recoupling`]; the move goes on.
    Recoupled {
        /// Anchor / knob robot.
        a: RobotId,
        /// Opening / hole robot.
        b: RobotId,
    },
    /// A pair was released after decoupling and is no longer tracked.
    PairReleased {
        /// Anchor / knob robot.
        a: RobotId,
        /// Opening / hole robot.
        b: RobotId,
    },
    /// A released pair came back together before its decouple behaviour ended: it is
    /// wiggled open again.
    PairRecoupled {
        /// Anchor / knob robot.
        a: RobotId,
        /// Opening / hole robot.
        b: RobotId,
    },
}

/// A timed event.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// Time (s).
    pub t: f64,
    /// What happened.
    #[serde(flatten)]
    pub kind: EventKind,
}

impl Coordinator {
    /// All events so far.
    pub fn events(&self) -> &[Event] {
        &self.events
    }

    /// Record an event (e.g. from a scenario runner); it is returned with the next tick.
    pub fn record(&mut self, t: f64, kind: EventKind) {
        self.push(t, kind);
    }

    /// Events recorded since the last tick (drained).
    pub fn tick_events(&mut self) -> Vec<Event> {
        std::mem::take(&mut self.pending)
    }

    pub(super) fn push(&mut self, t: f64, kind: EventKind) {
        let e = Event { t, kind };
        self.events.push(e.clone());
        self.pending.push(e);
    }

    /// Record pair `i`'s status changes as events.
    pub(super) fn push_transitions(&mut self, i: usize, transitions: Vec<crate::pair::Transition>) {
        let Some(p) = self.pairs.get(i).map(|tp| tp.pair) else {
            return;
        };
        for x in transitions {
            self.push(
                x.t,
                EventKind::PairStatus {
                    pair: i,
                    a: p.a,
                    b: p.b,
                    kind: p.kind,
                    from: x.from,
                    to: x.to,
                },
            );
        }
    }
}
