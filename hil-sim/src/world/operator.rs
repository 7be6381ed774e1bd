//! What a test, an experiment or the host link does to the world from outside its step:
//! datagrams in and out, switching robots off, stalls, impairments, a hand that lifts knob
//! pairs or places a robot, and the read-only views of its state.

use super::*;

impl World {
    /// A datagram from the host to robot `id` enters the radio now (impairments apply).
    /// Unknown ids are ignored (a real radio would not deliver them either).
    pub fn send_to_robot(&mut self, id: RobotId, frame: &[u8]) {
        let now = self.time_us;
        if let Some(i) = self.index(id) {
            let r = &mut self.robots[i];
            if r.fw.is_some() {
                let imp = r.impairments;
                r.down.send(now, frame, &imp);
            }
        }
    }

    /// Hand a datagram straight to robot `id`'s firmware, bypassing the radio (tests of
    /// the firmware's own rejection). Returns what the firmware said, or `None` when the
    /// robot is unknown or offline.
    pub fn inject(
        &mut self,
        id: RobotId,
        frame: &[u8],
    ) -> Option<Result<(), puzzlebot_protocol::Rejection>> {
        let now = self.time_us;
        let i = self.index(id)?;
        self.robots[i]
            .fw
            .as_mut()
            .map(|fw| fw.on_datagram(frame, now))
    }

    /// Datagrams robots sent that have arrived at the host side, in arrival order.
    pub fn take_from_robots(&mut self) -> Vec<(RobotId, Vec<u8>)> {
        std::mem::take(&mut self.outbox)
    }

    /// Motion-capture frames captured since the last call (at most [`MOCAP_BACKLOG`]).
    pub fn take_mocap(&mut self) -> Vec<MocapFrame> {
        self.mocap_out.drain(..).collect()
    }

    /// Switch robot `id` off (`false`: firmware stops, motors coast, radio silent) or on
    /// (`true`: a fresh boot with a fresh nonce). Returns false for an unknown id.
    pub fn set_online(&mut self, id: RobotId, online: bool) -> bool {
        let Some(i) = self.index(id) else {
            return false;
        };
        let now = self.time_us;
        let key = self.key.clone();
        let r = &mut self.robots[i];
        match (online, r.fw.is_some()) {
            (false, true) => {
                r.fw = None;
                r.outputs = MotorOutputs::COAST;
                r.down.clear();
                r.up.clear();
                self.events.push(SimEvent {
                    t_us: now,
                    kind: EventKind::Offline { id },
                });
            }
            (true, false) if boot(r, &key, now, ResetReason::PowerOn).is_ok() => {
                self.events.push(SimEvent {
                    t_us: now,
                    kind: EventKind::Booted { id, boot: r.boots },
                });
            }
            _ => {}
        }
        true
    }

    /// Make robot `id`'s control task stall (a hang): its firmware stops ticking and its
    /// motors keep their last duties until its watchdog resets it ([`crate::watchdog`]).
    /// Returns false for an unknown or offline robot.
    pub fn stall_control(&mut self, id: RobotId) -> bool {
        let Some(i) = self.index(id) else {
            return false;
        };
        let r = &mut self.robots[i];
        if r.fw.is_none() {
            return false;
        }
        r.supervision.set_stalled(true);
        true
    }

    /// Watchdog resets of robot `id` so far (None for an unknown id).
    pub fn watchdog_resets(&self, id: RobotId) -> Option<u32> {
        self.index(id).map(|i| self.robots[i].supervision.resets())
    }

    /// Change robot `id`'s link impairments. Returns false for an unknown id.
    pub fn set_impairments(&mut self, id: RobotId, imp: Impairments) -> bool {
        match self.index(id) {
            Some(i) => {
                self.robots[i].impairments = imp;
                true
            }
            None => false,
        }
    }

    /// A person lifts the knob pairs among robots `ids` apart (THESIS 5.5.3: a knob holds
    /// more than the robots can pull, and only the anchors can be wiggled open): every coupled
    /// knob link between two of them is removed, and the groups still joined by anchors
    /// (the rows) are set down [`LIFT_APART`] further apart across their sides, at rest.
    /// Returns the lifted pairs (knob robot, hole robot).
    pub fn lift_knobs(&mut self, ids: &[RobotId]) -> Vec<(RobotId, RobotId)> {
        let members: Vec<usize> = ids.iter().filter_map(|&id| self.index(id)).collect();
        let lifted = self.mech.lift_knobs(&members);
        if lifted.is_empty() {
            return Vec::new();
        }
        // Each row moves by its neighbour's shift plus LIFT_APART towards its own side
        // (the hole robot sits on the knob robot's left), breadth-first from the first row.
        let groups = self.mech.linked_groups(self.bodies.len());
        // The largest group stays where it is (a person lifts the smaller part away: a robot
        // clicked in beside an assembly comes off it, not the assembly off the robot).
        // Between groups of one size, the first knob robot's (the rows of a mesh: as before).
        let first = groups[lifted[0].0];
        let size = |g: usize| groups.iter().filter(|&&x| x == g).count();
        let fixed = lifted
            .iter()
            .flat_map(|&(a, b)| [groups[a], groups[b]])
            .max_by_key(|&g| (size(g), g == first))
            .unwrap_or(first);
        let mut shift: BTreeMap<usize, V2> = BTreeMap::new();
        shift.insert(fixed, [0.0, 0.0]);
        let mut grew = true;
        while grew {
            grew = false;
            for &(a, b) in &lifted {
                let (ga, gb) = (groups[a], groups[b]);
                let left = self.bodies[a].pose.rotate([0.0, LIFT_APART]);
                let next = match (shift.get(&ga), shift.get(&gb)) {
                    (Some(s), None) => Some((gb, [s[0] + left[0], s[1] + left[1]])),
                    (None, Some(s)) => Some((ga, [s[0] - left[0], s[1] - left[1]])),
                    _ => None,
                };
                if let Some((g, s)) = next {
                    shift.insert(g, s);
                    grew = true;
                }
            }
        }
        let t_us = self.time_us;
        let moves: Vec<(RobotId, Pose)> = self
            .robots
            .iter()
            .zip(&groups)
            .filter_map(|(r, g)| {
                let s = shift.get(g).filter(|s| s[0] != 0.0 || s[1] != 0.0)?;
                Some((
                    r.id,
                    Pose::new(r.pose.x + s[0], r.pose.y + s[1], r.pose.yaw),
                ))
            })
            .collect();
        for (id, p) in moves {
            self.place(id, p);
        }
        lifted
            .into_iter()
            .map(|(a, b)| {
                let (a, b) = (self.robots[a].id, self.robots[b].id);
                let kind = EventKind::Decoupled {
                    kind: LinkKind::Knob,
                    a,
                    b,
                };
                self.events.push(SimEvent { t_us, kind });
                (a, b)
            })
            .collect()
    }

    /// Place robot `id` at `pose` (at rest), as a person would. Returns false if unknown.
    pub fn place(&mut self, id: RobotId, pose: Pose) -> bool {
        let Some(i) = self.index(id) else {
            return false;
        };
        let r = &mut self.robots[i];
        r.pose = pose;
        r.trig = trig_of(pose.yaw);
        r.drive.v = 0.0;
        r.drive.vy = 0.0;
        r.drive.omega = 0.0;
        self.bodies[i].pose = pose;
        self.bodies[i].trig = r.trig;
        true
    }

    /// Couplings in every state, by robot id: (kind, a, b, state legs).
    pub fn links(&self) -> Vec<(LinkKind, RobotId, RobotId, Link)> {
        self.mech
            .links()
            .iter()
            .map(|l| (l.kind, self.robots[l.a].id, self.robots[l.b].id, *l))
            .collect()
    }

    /// The firmware of robot `id` (None when unknown or offline).
    pub fn firmware(&self, id: RobotId) -> Option<&Robot<SimNonces>> {
        self.index(id).and_then(|i| self.robots[i].fw.as_deref())
    }

    /// The drive plant state of robot `id` (wheel speeds, body velocities, battery).
    pub fn drive_state(&self, id: RobotId) -> Option<DriveState> {
        self.index(id).map(|i| self.robots[i].drive)
    }

    /// Pairs of robots whose bodies touch or overlap now (a measure of crowding).
    pub fn contact_count(&self) -> usize {
        self.mech.contact_count(&self.bodies)
    }

    /// Events so far.
    pub fn events(&self) -> &[SimEvent] {
        &self.events
    }

    /// Ground truth now.
    pub fn ground_truth(&self) -> GroundTruth {
        let rpm = 60.0 / core::f64::consts::TAU;
        GroundTruth {
            time_us: self.time_us,
            robots: self
                .robots
                .iter()
                .map(|r| {
                    let duty = |h: HBridge| h.effective_duty().unwrap_or(0);
                    RobotTruth {
                        id: r.id,
                        kind: r.kind,
                        pose: r.pose,
                        z: r.z,
                        v: r.drive.v,
                        omega: r.drive.omega,
                        wheel_rpm: [r.drive.wheel[0] * rpm, r.drive.wheel[1] * rpm],
                        duty: [duty(r.outputs.left), duty(r.outputs.right)],
                        bridge: [r.outputs.left, r.outputs.right],
                        battery_v: r.drive.battery_v,
                        encoder_edges: [r.quad[0].count(), r.quad[1].count()],
                        online: r.fw.is_some(),
                        fallen: r.fallen,
                        firmware: r.fw.as_deref().map(Robot::status),
                        rejected: r.fw.as_ref().map_or([0; 12], |f| f.stats().rejected),
                        accepted: r.fw.as_ref().map_or(0, |f| f.stats().accepted),
                    }
                })
                .collect(),
            coupled: self
                .mech
                .coupled()
                .map(|(a, b, k)| (self.robots[a].id, self.robots[b].id, k))
                .collect(),
            events: self.events.clone(),
        }
    }

    /// Trust firmware update packages signed with `key` on every robot (the update key of
    /// their provisioning records; `None`: they refuse updates).
    pub fn set_update_key(&mut self, key: Option<[u8; 32]>) {
        for r in &mut self.robots {
            r.ota.set_key(key);
        }
    }

    /// The firmware version robot `id` runs (None for an unknown id).
    pub fn firmware_version(&self, id: RobotId) -> Option<FirmwareVersion> {
        self.index(id).map(|i| self.robots[i].ota.version())
    }

    /// True when robot `id`'s firmware is in a driving mode (speed or raw duty).
    pub fn is_driving(&self, id: RobotId) -> bool {
        self.firmware(id)
            .is_some_and(|f| matches!(f.status().mode, DriveMode::Speed | DriveMode::RawDuty(_)))
    }
}
