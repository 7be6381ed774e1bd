//! `milestones.svg`: the run at each milestone (start, formed, after each move, dissolved,
//! end) as one panel of robot footprints to scale, with anchors, knobs, couplings and the
//! time, every robot's whole path faint behind.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;

use super::milestones::{milestones, Milestone};
use super::timeline::{Body, Kind, Sample, State, Timeline};

/// File name of the milestone picture in a run folder.
pub const MILESTONES_SVG: &str = "milestones.svg";

/// Panel width (px).
const PANEL_W: f64 = 420.0;
/// Panels per row.
const COLUMNS: usize = 3;
/// Panel height (px).
const PANEL_H: f64 = 300.0;
/// Margin around the robots of a panel (m).
const ZOOM_PAD: f64 = 0.1;
/// Smallest width and height a panel shows (m).
const MIN_SPAN: f64 = 0.3;
/// Anchor head drawn with this radius (m).
const HEAD_R: f64 = 0.004;

const PILOT: &str = "#5c7cfa";
const NON_PILOT: &str = "#b0bec5";
const ANCHOR_LINK: &str = "#ef6c00";
const KNOB_LINK: &str = "#1565c0";

/// World (m, y up) to panel pixels.
struct Frame {
    x0: f64,
    y1: f64,
    scale: f64,
    left: f64,
    top: f64,
}

impl Frame {
    fn px(&self, p: [f64; 2]) -> (f64, f64) {
        (
            self.left + (p[0] - self.x0) * self.scale,
            self.top + (self.y1 - p[1]) * self.scale,
        )
    }

    fn points(&self, pts: &[[f64; 2]]) -> String {
        pts.iter()
            .map(|&p| {
                let (x, y) = self.px(p);
                format!("{x:.1},{y:.1}")
            })
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// Body-frame point `b` of a robot at `pose`, in the world.
fn world(pose: [f64; 3], b: [f64; 2]) -> [f64; 2] {
    let (s, c) = pose[2].sin_cos();
    [pose[0] + c * b[0] - s * b[1], pose[1] + s * b[0] + c * b[1]]
}

/// The frame of a panel at `(left, top)` that shows every robot of `s` (padded by
/// [`ZOOM_PAD`], at least [`MIN_SPAN`] wide and high) as large as the panel allows.
fn zoom(s: &Sample, left: f64, top: f64) -> Frame {
    let mut b = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for p in s
        .poses
        .values()
        .filter(|p| p[0].is_finite() && p[1].is_finite())
    {
        b = (b.0.min(p[0]), b.1.max(p[0]), b.2.min(p[1]), b.3.max(p[1]));
    }
    if !b.0.is_finite() {
        b = (0.0, 0.0, 0.0, 0.0);
    }
    let (cx, cy) = ((b.0 + b.1) / 2.0, (b.2 + b.3) / 2.0);
    let w = (b.1 - b.0 + 2.0 * ZOOM_PAD).max(MIN_SPAN);
    let h = (b.3 - b.2 + 2.0 * ZOOM_PAD).max(MIN_SPAN);
    let scale = (PANEL_W / w).min(PANEL_H / h);
    Frame {
        x0: cx - PANEL_W / 2.0 / scale,
        y1: cy + PANEL_H / 2.0 / scale,
        scale,
        left,
        top,
    }
}

/// One robot's footprint at `pose`: body, heading mark, anchor with its head coloured by the
/// anchor's state, knobs (green in a hole), id.
fn footprint(
    out: &mut String,
    f: &Frame,
    body: &Body,
    pose: [f64; 3],
    anchor: Option<State>,
    knob_in: bool,
) {
    let g = &body.geometry;
    let (hl, hw) = (f64::from(g.length) / 2.0, f64::from(g.width) / 2.0);
    let at = |b: [f64; 2]| world(pose, b);
    let head = [f64::from(g.anchor_head[0]), f64::from(g.anchor_head[1])];
    let (tx, ty) = f.px(at([-hl, 0.0]));
    let (hx, hy) = f.px(at(head));
    let _ = write!(
        out,
        r##"<line x1="{tx:.1}" y1="{ty:.1}" x2="{hx:.1}" y2="{hy:.1}" stroke="#455a64" stroke-width="1.5"/>"##
    );
    let fill = match body.kind {
        puzzlebot_params::RobotKind::Pilot => PILOT,
        puzzlebot_params::RobotKind::NonPilot => NON_PILOT,
    };
    let corners = [[hl, hw], [-hl, hw], [-hl, -hw], [hl, -hw]].map(at);
    let _ = write!(
        out,
        r##"<polygon points="{}" fill="{fill}" stroke="#37474f" stroke-width="1"/>"##,
        f.points(&corners)
    );
    let nose = [[hl * 0.9, 0.0], [hl * 0.4, hw * 0.3], [hl * 0.4, -hw * 0.3]].map(at);
    let _ = write!(
        out,
        r##"<polygon points="{}" fill="#37474f"/>"##,
        f.points(&nose)
    );
    let k = f64::from(g.knob_length).max(0.003);
    for sx in [-1.0, 1.0] {
        let cx = f64::from(g.knob_left[0]) + sx * f64::from(g.side_point_x);
        let y = f64::from(g.knob_left[1]);
        let knob = [
            [cx - 0.002, y],
            [cx + 0.002, y],
            [cx + 0.002, y + k],
            [cx - 0.002, y + k],
        ]
        .map(at);
        let c = if knob_in { "#2e7d32" } else { "#616161" };
        let _ = write!(
            out,
            r##"<polygon points="{}" fill="{c}"/>"##,
            f.points(&knob)
        );
    }
    let colour = match anchor {
        None => "#9e9e9e",
        Some(State::Inserting) => "#fb8c00",
        Some(State::Coupled) => "#2e7d32",
        Some(State::Releasing) => "#d32f2f",
    };
    let _ = write!(
        out,
        r##"<circle cx="{hx:.1}" cy="{hy:.1}" r="{:.1}" fill="{colour}" stroke="#263238" stroke-width="0.8"/>"##,
        (HEAD_R * f.scale).max(2.0)
    );
    let (cx, cy) = f.px([pose[0], pose[1]]);
    let _ = write!(
        out,
        r##"<text x="{cx:.1}" y="{:.1}" font-size="11" font-weight="bold" text-anchor="middle">{}</text>"##,
        cy + 4.0,
        body.id
    );
}

/// One panel: terrain, faint paths, the footprints and couplings of `s`, the caption.
fn panel(out: &mut String, tl: &Timeline, f: &Frame, size: (f64, f64), m: &Milestone, s: &Sample) {
    let _ = write!(
        out,
        r##"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="#fff" stroke="#b0bec5"/>"##,
        f.left, f.top, size.0, size.1
    );
    for p in &tl.terrain.platforms {
        let _ = write!(
            out,
            r##"<polygon points="{}" fill="rgba(121,85,72,0.25)" stroke="#6d4c41"/>"##,
            f.points(&p.polygon)
        );
    }
    for b in &tl.bodies {
        // Points closer than a pixel to the last one kept add nothing to the drawing.
        let mut pts: Vec<[f64; 2]> = Vec::new();
        for p in tl.samples.iter().filter_map(|s| s.poses.get(&b.id)) {
            let far = pts
                .last()
                .is_none_or(|l| (p[0] - l[0]).hypot(p[1] - l[1]) * f.scale >= 1.0);
            if far {
                pts.push([p[0], p[1]]);
            }
        }
        if pts.len() > 1 {
            let _ = write!(
                out,
                r##"<polyline points="{}" fill="none" stroke="#cfd8dc" stroke-width="1.2"/>"##,
                f.points(&pts)
            );
        }
    }
    let coupled: Vec<_> = s
        .couplings
        .iter()
        .filter(|c| c.state == State::Coupled)
        .collect();
    for b in &tl.bodies {
        let Some(&pose) = s.poses.get(&b.id) else {
            continue;
        };
        let anchor = s
            .couplings
            .iter()
            .find(|c| c.kind == Kind::Anchor && c.a == b.id)
            .map(|c| c.state);
        let knob_in = coupled.iter().any(|c| c.kind == Kind::Knob && c.a == b.id);
        footprint(out, f, b, pose, anchor, knob_in);
    }
    for c in &coupled {
        let (Some(pa), Some(pb)) = (s.poses.get(&c.a), s.poses.get(&c.b)) else {
            continue;
        };
        let (x1, y1) = f.px([pa[0], pa[1]]);
        let (x2, y2) = f.px([pb[0], pb[1]]);
        let colour = match c.kind {
            Kind::Anchor => ANCHOR_LINK,
            Kind::Knob => KNOB_LINK,
        };
        let _ = write!(
            out,
            r##"<line x1="{x1:.1}" y1="{y1:.1}" x2="{x2:.1}" y2="{y2:.1}" stroke="{colour}" stroke-width="4" stroke-linecap="round" opacity="0.7"/>"##
        );
    }
    let _ = write!(
        out,
        r##"<text x="{:.1}" y="{:.1}" font-size="14"><tspan font-weight="bold">{:.1} s</tspan> {} · {} coupled</text>"##,
        f.left + 8.0,
        f.top + 18.0,
        m.t,
        m.label,
        coupled.len()
    );
}

/// The milestone picture of `tl` titled `title` (SVG text).
pub fn svg(tl: &Timeline, title: &str) -> String {
    let marks = milestones(tl);
    let cols = marks.len().clamp(1, COLUMNS);
    let rows = marks.len().div_ceil(COLUMNS).max(1);
    let gap = 10.0;
    let head = 34.0;
    let foot = 26.0;
    let width = cols as f64 * (PANEL_W + gap) + gap;
    let height = head + rows as f64 * (PANEL_H + gap) + foot;
    let mut out = format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="sans-serif">"##
    );
    let _ = write!(
        out,
        r##"<rect width="100%" height="100%" fill="#fafafa"/><text x="{gap}" y="22" font-size="16" font-weight="bold">{} — footprints at the milestones</text>"##,
        super::page_escape(title)
    );
    for (i, m) in marks.iter().enumerate() {
        let s = &tl.samples[tl.index_at(m.t)];
        let f = zoom(
            s,
            gap + (i % COLUMNS) as f64 * (PANEL_W + gap),
            head + (i / COLUMNS) as f64 * (PANEL_H + gap),
        );
        let _ = write!(
            out,
            r##"<clipPath id="panel{i}"><rect x="{:.1}" y="{:.1}" width="{PANEL_W}" height="{PANEL_H}"/></clipPath><g clip-path="url(#panel{i})">"##,
            f.left, f.top
        );
        panel(&mut out, tl, &f, (PANEL_W, PANEL_H), m, s);
        let bar = 0.1 * f.scale;
        let (bx, by) = (f.left + PANEL_W - bar - 10.0, f.top + PANEL_H - 10.0);
        let _ = write!(
            out,
            r##"<line x1="{bx:.1}" y1="{by:.1}" x2="{:.1}" y2="{by:.1}" stroke="#263238" stroke-width="2"/><text x="{:.1}" y="{:.1}" font-size="11" text-anchor="middle">10 cm</text></g>"##,
            bx + bar,
            bx + bar / 2.0,
            by - 4.0
        );
    }
    let dot = |c: &str| format!(r##"<tspan fill="{c}">●</tspan>"##);
    let _ = write!(
        out,
        r##"<text x="{gap}" y="{:.0}" font-size="12"><tspan fill="{PILOT}">■</tspan> pilot, <tspan fill="{NON_PILOT}">■</tspan> non-pilot · anchor head {} free, {} inserting, {} coupled, {} releasing · coupled <tspan fill="{ANCHOR_LINK}">━</tspan> anchor, <tspan fill="{KNOB_LINK}">━</tspan> knob · paths faint</text></svg>"##,
        height - 9.0,
        dot("#9e9e9e"),
        dot("#fb8c00"),
        dot("#2e7d32"),
        dot("#d32f2f")
    );
    out
}

/// Write `dir/milestones.svg` for the timeline `tl` of run folder `dir`; returns its path.
pub fn write(dir: &Path, tl: &Timeline) -> anyhow::Result<PathBuf> {
    let path = dir.join(MILESTONES_SVG);
    std::fs::write(&path, svg(tl, &super::title_of(dir)))
        .with_context(|| format!("{}", path.display()))?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::replay::timeline::{Coupling, CouplingSource};
    use std::collections::BTreeMap;

    #[test]
    fn every_milestone_gets_a_panel_with_its_robots_and_couplings() {
        let g = puzzlebot_params::FleetParams::default().non_pilot.geometry;
        let body = |id| Body {
            id,
            kind: puzzlebot_params::RobotKind::NonPilot,
            geometry: g,
        };
        let samples: Vec<Sample> = (0..30)
            .map(|i| {
                let t = f64::from(i) * 0.1;
                Sample {
                    t,
                    poses: BTreeMap::from([(1, [0.0, 0.0, 0.0]), (2, [0.1 - 0.001 * t, 0.0, 0.0])]),
                    couplings: if t > 1.0 {
                        vec![Coupling {
                            kind: Kind::Anchor,
                            a: 2,
                            b: 1,
                            state: State::Coupled,
                        }]
                    } else {
                        Vec::new()
                    },
                }
            })
            .collect();
        let tl = Timeline {
            bodies: vec![body(1), body(2)],
            terrain: Default::default(),
            samples,
            pairs: Vec::new(),
            notes: Vec::new(),
            couplings_from: CouplingSource::Simulator,
        };
        let s = svg(&tl, "t");
        // start and end: two panels, each with two bodies (a body, a nose, two knobs each).
        assert_eq!(s.matches("0 coupled").count(), 1, "{s}");
        assert_eq!(s.matches("1 coupled").count(), 1);
        assert!(s.contains("0.0 s</tspan> start") && s.contains("2.9 s</tspan> end"));
        assert_eq!(s.matches(&format!("stroke=\"{ANCHOR_LINK}\"")).count(), 1);
        assert_eq!(s.matches("font-weight=\"bold\" text-anchor").count(), 4);
    }
}
