//! Both ends of the handshake and of a session: key choice, counters, replay windows.
//!
//! Handshake (hello stream, robot's hello key):
//! 1. robot → host `Announce { robot_nonce }`, repeated until welcomed; the robot draws a
//!    fresh nonce at boot and whenever it starts announcing again (link lost);
//! 2. host → robot `Welcome { robot_nonce, host_nonce }` with a fresh host nonce;
//! 3. both derive `session_key(robot_nonce, host_nonce)`; counters restart at 0 per
//!    direction. The robot accepts exactly one welcome per announce nonce, so old welcomes
//!    and frames of any earlier session never verify or are refused.

use crate::crypto::{MacKey, Nonce, RobotKey};
use crate::envelope::{open, peek_header, seal, Direction, Header, Stream};
use crate::messages::{Announce, HostMsg, Message, RobotId, RobotMsg};
use crate::reject::{EncodeError, Rejection};
use crate::replay::ReplayWindow;
use crate::MAX_COUNTER;

/// One established direction pair: key, send counter, receive window.
#[derive(Debug, Clone)]
struct Active {
    /// The session key, pre-keyed (HMAC pads hashed once per session).
    key: MacKey,
    robot_nonce: Nonce,
    host_nonce: Nonce,
    tx: u64,
    rx: ReplayWindow,
}

impl Active {
    fn new(robot: &RobotKey, robot_nonce: Nonce, host_nonce: Nonce) -> Self {
        Active {
            key: MacKey::new(&robot.session_key(&robot_nonce, &host_nonce)),
            robot_nonce,
            host_nonce,
            tx: 0,
            rx: ReplayWindow::new(),
        }
    }
}

fn next_counter(c: &mut u64) -> Result<u64, EncodeError> {
    if *c > MAX_COUNTER {
        return Err(EncodeError::CounterExhausted);
    }
    let v = *c;
    *c += 1;
    Ok(v)
}

fn seal_as<M: Message>(
    key: &MacKey,
    robot_id: RobotId,
    stream: Stream,
    counter: u64,
    msg: &M,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    let header = Header {
        direction: M::DIRECTION,
        stream,
        robot_id,
        counter,
    };
    seal(key, header, msg, out)
}

/// The robot's end: announces, accepts one welcome per nonce, seals and opens session frames.
#[derive(Debug, Clone)]
pub struct RobotSession {
    robot_id: RobotId,
    key: RobotKey,
    hello_key: MacKey,
    robot_nonce: Nonce,
    hello_tx: u64,
    active: Option<Active>,
    reset_reason: crate::ResetReason,
}

impl RobotSession {
    /// A robot with `key` that just booted with the random `boot_nonce`.
    pub fn new(robot_id: RobotId, key: RobotKey, boot_nonce: Nonce) -> Self {
        let hello_key = MacKey::new(&key.hello_key());
        RobotSession {
            robot_id,
            key,
            hello_key,
            robot_nonce: boot_nonce,
            hello_tx: 0,
            active: None,
            reset_reason: crate::ResetReason::Unknown,
        }
    }

    /// Set the reset reason every later announce carries (once, at boot).
    pub fn set_reset_reason(&mut self, reason: crate::ResetReason) {
        self.reset_reason = reason;
    }

    /// The reset reason the announces carry.
    pub fn reset_reason(&self) -> crate::ResetReason {
        self.reset_reason
    }

    /// This robot's id.
    pub fn robot_id(&self) -> RobotId {
        self.robot_id
    }

    /// True once a welcome for the current nonce was accepted.
    pub fn is_established(&self) -> bool {
        self.active.is_some()
    }

    /// The nonce the robot currently announces.
    pub fn robot_nonce(&self) -> &Nonce {
        &self.robot_nonce
    }

    /// Drop the session and announce again with a fresh nonce (link lost, host restarted).
    pub fn restart(&mut self, fresh_nonce: Nonce) {
        self.robot_nonce = fresh_nonce;
        self.active = None;
    }

    /// Seal an announce for the current nonce into `out`.
    pub fn announce(
        &mut self,
        kind: crate::RobotKind,
        firmware: crate::FirmwareVersion,
        out: &mut [u8],
    ) -> Result<usize, EncodeError> {
        let c = next_counter(&mut self.hello_tx)?;
        let msg = RobotMsg::Announce(Announce {
            kind,
            firmware,
            protocol_version: crate::PROTOCOL_VERSION,
            robot_nonce: self.robot_nonce,
            reset_reason: self.reset_reason,
        });
        seal_as(&self.hello_key, self.robot_id, Stream::Hello, c, &msg, out)
    }

    /// Seal a session message (telemetry, pong, reply) into `out`.
    pub fn send(&mut self, msg: &RobotMsg, out: &mut [u8]) -> Result<usize, EncodeError> {
        let a = self.active.as_mut().ok_or(EncodeError::NoSession)?;
        let c = next_counter(&mut a.tx)?;
        seal_as(&a.key, self.robot_id, Stream::Session, c, msg, out)
    }

    /// Authenticate, check freshness and decode a frame from the host.
    ///
    /// A welcome for the current nonce opens the session and is returned so the caller
    /// can react; every other rejection leaves the state untouched.
    pub fn receive(&mut self, frame: &[u8]) -> Result<(Header, HostMsg), Rejection> {
        let h = peek_header(frame)?;
        if h.direction != Direction::HostToRobot {
            return Err(Rejection::WrongDirection);
        }
        if h.robot_id != self.robot_id {
            return Err(Rejection::UnknownRobot);
        }
        match h.stream {
            Stream::Hello => {
                let (h, msg) = open::<HostMsg>(&self.hello_key, frame)?;
                let HostMsg::Welcome {
                    robot_nonce,
                    host_nonce,
                } = msg
                else {
                    return Err(Rejection::BadFlags);
                };
                if robot_nonce != self.robot_nonce {
                    return Err(Rejection::StaleHandshake);
                }
                if self.active.is_some() {
                    // One welcome per announce nonce: duplicates and competitors are refused.
                    return Err(Rejection::Replay);
                }
                self.active = Some(Active::new(&self.key, robot_nonce, host_nonce));
                Ok((h, msg))
            }
            Stream::Session => {
                let a = self.active.as_mut().ok_or(Rejection::NoSession)?;
                let (h, msg) = open::<HostMsg>(&a.key, frame)?;
                a.rx.accept(h.counter)?;
                Ok((h, msg))
            }
        }
    }
}

/// What the host got from a robot.
#[derive(Debug, Clone, PartialEq)]
pub enum HostReceived {
    /// An announce; `welcome_len` bytes of welcome were written to the output buffer.
    Announce {
        /// The announce.
        announce: Announce,
        /// Length of the welcome written into `out`.
        welcome_len: usize,
        /// True when this announce started a new (pending) session.
        new_session: bool,
    },
    /// A session message.
    Message(Header, RobotMsg),
}

/// The host's end for one robot: answers announces, seals commands, opens telemetry.
#[derive(Debug, Clone)]
pub struct HostSession {
    robot_id: RobotId,
    key: RobotKey,
    hello_key: MacKey,
    hello_tx: u64,
    hello_rx: ReplayWindow,
    /// Session the robot has proven (a valid frame arrived under it).
    active: Option<Active>,
    /// Sessions offered by our latest welcomes, not yet proven (newest last).
    ///
    /// More than one is kept so that a single replayed old announce cannot push the
    /// robot's genuine, not yet proven offer out (the robot would then be locked out
    /// until its failsafe makes it announce again).
    pending: [Option<Active>; PENDING_OFFERS],
}

/// How many unproven session offers the host keeps per robot.
pub const PENDING_OFFERS: usize = 4;

impl HostSession {
    /// Host side for robot `robot_id` with its derived key.
    pub fn new(robot_id: RobotId, key: RobotKey) -> Self {
        let hello_key = MacKey::new(&key.hello_key());
        HostSession {
            robot_id,
            key,
            hello_key,
            hello_tx: 0,
            hello_rx: ReplayWindow::new(),
            active: None,
            pending: [const { None }; PENDING_OFFERS],
        }
    }

    /// The robot this session talks to.
    pub fn robot_id(&self) -> RobotId {
        self.robot_id
    }

    /// True when the robot has proven a session (a valid session frame arrived).
    pub fn is_established(&self) -> bool {
        self.active.is_some()
    }

    /// Forget every session (robot marked offline); the robot must announce again.
    pub fn reset(&mut self) {
        self.active = None;
        self.pending = [const { None }; PENDING_OFFERS];
    }

    /// True when at least one offered session (welcome sent) is not yet proven.
    pub fn has_pending(&self) -> bool {
        self.pending.iter().any(Option::is_some)
    }

    /// Remember a new offer, evicting the oldest when all slots are taken.
    fn offer(&mut self, a: Active) {
        match self.pending.iter().position(Option::is_none) {
            Some(i) => self.pending[i] = Some(a),
            None => {
                self.pending.rotate_left(1);
                self.pending[PENDING_OFFERS - 1] = Some(a);
            }
        }
    }

    /// Handle a frame from this robot. `fresh_host_nonce` is called only when a new
    /// session is offered; a welcome is written to `out` for every valid announce.
    pub fn receive(
        &mut self,
        frame: &[u8],
        fresh_host_nonce: impl FnOnce() -> Nonce,
        out: &mut [u8],
    ) -> Result<HostReceived, Rejection> {
        let h = peek_header(frame)?;
        if h.direction != Direction::RobotToHost {
            return Err(Rejection::WrongDirection);
        }
        if h.robot_id != self.robot_id {
            return Err(Rejection::UnknownRobot);
        }
        match h.stream {
            Stream::Hello => {
                let (h, msg) = open::<RobotMsg>(&self.hello_key, frame)?;
                let RobotMsg::Announce(announce) = msg else {
                    return Err(Rejection::BadFlags);
                };
                // Announce counters restart at boot; they are not replay-checked here
                // (a replayed announce only yields an unproven pending offer, which
                // never displaces the proven session). Recorded for statistics only.
                let _ = self.hello_rx.accept(h.counter);
                let known = self
                    .pending
                    .iter()
                    .flatten()
                    .chain(self.active.as_ref())
                    .find(|a| a.robot_nonce == announce.robot_nonce)
                    .map(|a| a.host_nonce);
                let (host_nonce, new_session) = match known {
                    Some(n) => (n, false),
                    None => (fresh_host_nonce(), true),
                };
                let welcome = HostMsg::Welcome {
                    robot_nonce: announce.robot_nonce,
                    host_nonce,
                };
                // Seal before touching any state, so a too-small `out` changes nothing.
                let c = self.hello_tx;
                let welcome_len = seal_as(
                    &self.hello_key,
                    self.robot_id,
                    Stream::Hello,
                    c,
                    &welcome,
                    out,
                )
                .map_err(|_| Rejection::NoSession)?;
                self.hello_tx += 1;
                if new_session {
                    self.offer(Active::new(&self.key, announce.robot_nonce, host_nonce));
                }
                Ok(HostReceived::Announce {
                    announce,
                    welcome_len,
                    new_session,
                })
            }
            Stream::Session => {
                // Try the proven session first; only a frame that does not verify under
                // it (BadTag) may belong to a newer offer. Any other verdict (replay,
                // too old, malformed) is final and reported as such.
                let mut last = if self.active.is_some() {
                    Rejection::BadTag
                } else {
                    Rejection::NoSession
                };
                if let Some(a) = self.active.as_mut() {
                    match open::<RobotMsg>(&a.key, frame) {
                        Ok((h, msg)) => {
                            a.rx.accept(h.counter)?;
                            return Ok(HostReceived::Message(h, msg));
                        }
                        Err(Rejection::BadTag) => {}
                        Err(e) => return Err(e),
                    }
                }
                for i in (0..PENDING_OFFERS).rev() {
                    let Some(p) = self.pending[i].as_mut() else {
                        continue;
                    };
                    match open::<RobotMsg>(&p.key, frame) {
                        Ok((h, msg)) => {
                            p.rx.accept(h.counter)?;
                            // The robot proved this offer: it replaces the old session, and
                            // every other unproven offer is void.
                            self.active = self.pending[i].take();
                            self.pending = [const { None }; PENDING_OFFERS];
                            return Ok(HostReceived::Message(h, msg));
                        }
                        Err(e) => last = e,
                    }
                }
                Err(last)
            }
        }
    }

    /// Seal a command under the proven session; [`EncodeError::NoSession`] until the robot
    /// has proven one (its first session frame after the welcome).
    ///
    /// Nothing is ever sealed under an unproven offer: a welcome can be lost, the host can
    /// restart, and a captured copy of that welcome can later be delivered to a robot still
    /// announcing the same nonce. Frames sealed under such an offer would then be replayable
    /// into the robot's session; frames that were never sealed cannot be.
    pub fn send(&mut self, msg: &HostMsg, out: &mut [u8]) -> Result<usize, EncodeError> {
        let a = self.active.as_mut().ok_or(EncodeError::NoSession)?;
        let c = next_counter(&mut a.tx)?;
        seal_as(&a.key, self.robot_id, Stream::Session, c, msg, out)
    }
}
