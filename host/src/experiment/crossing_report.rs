//! Tables and plots of `puzzlebot experiment crossing`: the maximum gap and step crossed with
//! more than 80 % completion per configuration beside what THESIS reports (3.5.3, 5.2.4),
//! completion against heading (Figure 5.7 C), and the gate's predicted advance beside the
//! physics' (issue "cross the gap", item 5).

use super::crossing::{Config, CrossRun, CrossingData, CROSSED, GAP_DROP};
use plotters::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// What THESIS reports for a configuration, where its text gives a number.
pub fn thesis(c: &Config) -> &'static str {
    match (c.shape.as_str(), c.pilots.as_str()) {
        ("line 1", "none") => "10 mm (5.2.4)",
        ("line 1", "front") => "20 mm (5.2.4)",
        ("line 8", "front+back") => "21 % of length (3.5.3)",
        ("mesh 2x4", "front+back") => "36 % of length (3.5.3)",
        _ => "",
    }
}

/// Mean completion per (config, obstacle width, drop, heading), widths and drops in µm.
fn completion(d: &CrossingData) -> BTreeMap<(usize, u64, u64, i64), f64> {
    let mut sum: BTreeMap<(usize, u64, u64, i64), (f64, f64)> = BTreeMap::new();
    for r in &d.runs {
        let k = (
            r.config,
            (r.obstacle.width * 1e6).round() as u64,
            (r.obstacle.drop * 1e6).round() as u64,
            r.heading_deg.round() as i64,
        );
        let e = sum.entry(k).or_default();
        e.0 += r.completion;
        e.1 += 1.0;
    }
    sum.into_iter().map(|(k, (s, n))| (k, s / n)).collect()
}

/// The summary of one configuration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConfigSummary {
    /// Configuration.
    pub config: Config,
    /// Widest gap with the far platform 6 mm lower crossed with > 80 % completion at 20°
    /// (THESIS 3.5.3's heading) (m).
    pub gap_drop_20: Option<f64>,
    /// Widest gap with the far platform 6 mm lower, best heading (m).
    pub gap_drop: Option<f64>,
    /// Widest gap between platforms of equal height, best heading (m).
    pub gap_level: Option<f64>,
    /// Highest descending step, best heading (m).
    pub step: Option<f64>,
    /// Per heading (degrees): the widest level gap crossed (m), and the completion at the
    /// next wider gap run (the bisection's failing bracket; `None` when the heading crossed
    /// every gap).
    pub completion_by_heading: Vec<(f64, Option<f64>, Option<f64>)>,
    /// Heading with the widest level gap, the higher completion at the next wider gap
    /// breaking ties (degrees).
    pub best_heading: Option<f64>,
}

/// Gate against physics over every run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GateSummary {
    /// Runs.
    pub runs: usize,
    /// Runs in which a robot fell or a connector opened.
    pub failed: usize,
    /// Runs in which the gate called safe an advance at which the driven run failed.
    pub overconfident: usize,
    /// Runs in which the gate called safe an advance past the physics' static tipping point.
    pub past_tip: usize,
    /// Mesh runs that tipped with a measured static tipping point: how many, how many with
    /// the rigid gate within 10 mm of it, largest distance (m).
    pub rigid_tips: (usize, usize, f64),
}

/// The experiment's summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Per configuration.
    pub configs: Vec<ConfigSummary>,
    /// Gate against physics.
    pub gate: GateSummary,
}

/// Summarise the runs.
pub fn summarise(d: &CrossingData) -> Summary {
    let comp = completion(d);
    let headings: Vec<i64> = {
        let mut h: Vec<i64> = comp.keys().map(|k| k.3).collect();
        h.sort_unstable();
        h.dedup();
        h
    };
    let widest = |c: usize, step: bool, drop: Option<u64>, heading: Option<i64>| {
        comp.iter()
            .filter(|(k, v)| {
                k.0 == c
                    && (k.1 == 0) == step
                    && drop.is_none_or(|d| k.2 == d)
                    && heading.is_none_or(|h| k.3 == h)
                    && **v > CROSSED
            })
            .map(|(k, _)| if step { k.2 } else { k.1 })
            .max()
            .map(|um| um as f64 * 1e-6)
    };
    let drop_um = (GAP_DROP * 1e6).round() as u64;
    let configs = d
        .configs
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let gap_level = widest(i, false, Some(0), None);
            let by_heading: Vec<(f64, Option<f64>, Option<f64>)> = headings
                .iter()
                .filter(|&&h| {
                    comp.keys()
                        .any(|k| k.0 == i && k.1 > 0 && k.2 == 0 && k.3 == h)
                })
                .map(|&h| {
                    let w = widest(i, false, Some(0), Some(h));
                    let from = w.map_or(0, |w| (w * 1e6).round() as u64);
                    let beyond = comp
                        .iter()
                        .filter(|(k, _)| k.0 == i && k.2 == 0 && k.3 == h && k.1 > from)
                        .min_by_key(|(k, _)| k.1)
                        .map(|(_, v)| *v);
                    (h as f64, w, beyond)
                })
                .collect();
            let best_heading = by_heading
                .iter()
                .max_by(|a, b| {
                    a.1.unwrap_or(0.0)
                        .total_cmp(&b.1.unwrap_or(0.0))
                        .then(a.2.unwrap_or(1.0).total_cmp(&b.2.unwrap_or(1.0)))
                        .then(b.0.total_cmp(&a.0))
                })
                .map(|b| b.0);
            ConfigSummary {
                config: c.clone(),
                gap_drop_20: widest(i, false, Some(drop_um), Some(20)),
                gap_drop: widest(i, false, Some(drop_um), None),
                gap_level,
                step: widest(i, true, None, None),
                completion_by_heading: by_heading,
                best_heading,
            }
        })
        .collect();
    let failed: Vec<&CrossRun> = d.runs.iter().filter(|r| r.physics_fail.is_some()).collect();
    let tips: Vec<f64> = failed
        .iter()
        .filter(|r| d.configs[r.config].mesh && r.fail_kind.as_deref() == Some("fell"))
        .filter_map(|r| r.physics_tip.map(|t| (r.rigid_advance - t).abs()))
        .collect();
    Summary {
        configs,
        gate: GateSummary {
            runs: d.runs.len(),
            failed: failed.len(),
            overconfident: d.runs.iter().filter(|r| r.gate_overconfident()).count(),
            past_tip: d.runs.iter().filter(|r| r.gate_past_tip()).count(),
            rigid_tips: (
                tips.len(),
                tips.iter().filter(|&&e| e <= 0.010).count(),
                tips.iter().copied().fold(0.0, f64::max),
            ),
        },
    }
}

fn mm(v: Option<f64>) -> String {
    v.map_or("-".into(), |v| format!("{:.0}", v * 1e3))
}

/// The tables as text.
pub fn render(s: &Summary, d: &CrossingData) -> String {
    let mut t = String::from(
        "max gap / step crossed with > 80 % completion (mm; drop: far platform 6 mm lower)\n\
         shape     pilots      length  alpha  drop@20°  drop  level  level/length  step  best_θ  THESIS\n",
    );
    for c in &s.configs {
        let k = &c.config;
        t += &format!(
            "{:<9} {:<10} {:>7.0}  {:>4.1}°  {:>8}  {:>4}  {:>5}  {:>11}  {:>4}  {:>6}  {}\n",
            k.shape,
            k.pilots,
            k.length * 1e3,
            k.alpha_deg,
            mm(c.gap_drop_20),
            mm(c.gap_drop),
            mm(c.gap_level),
            c.gap_level
                .map_or("-".into(), |g| format!("{:.0} %", 100.0 * g / k.length)),
            mm(c.step),
            c.best_heading.map_or("-".into(), |h| format!("{h:.0}°")),
            thesis(k)
        );
    }
    t += "\nby heading (Figure 5.7 C; level gaps): widest gap crossed / completion at the next \
          wider gap run\n";
    for c in s
        .configs
        .iter()
        .filter(|c| c.config.pilots == "front+back" && [4, 8].contains(&c.config.robots))
    {
        t += &format!(
            "{:<9} α {:>4.1}°  best {:>4}: {}\n",
            c.config.shape,
            c.config.alpha_deg,
            c.best_heading.map_or("-".into(), |h| format!("{h:.0}°")),
            c.completion_by_heading
                .iter()
                .map(|(h, w, v)| {
                    let v = v.map_or("-".into(), |v| format!("{:.0} %", v * 100.0));
                    format!("{h:.0}° {} mm {v}", mm(*w))
                })
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let g = &s.gate;
    t += &format!(
        "\ngate against physics: {} runs, {} failed in the physics; the gate called safe an \
         advance at which the driven run failed in {}, and past the static tipping point in {}; \
         meshes that tipped (first runs, where the static tipping point is measured): {} of {} \
         with the rigid gate's limit within 10 mm of it (largest {:.0} mm)\n",
        g.runs,
        g.failed,
        g.overconfident,
        g.past_tip,
        g.rigid_tips.1,
        g.rigid_tips.0,
        g.rigid_tips.2 * 1e3
    );
    t += "shape     pilots      gap  drop  θ    run  needed  gate  rigid  limited_by        \
          physics_fail      tip\n";
    for r in d.runs.iter().filter(|r| r.physics_fail.is_some()) {
        let c = &d.configs[r.config];
        t += &format!(
            "{:<9} {:<10} {:>4.0} {:>5.0} {:>3.0}° {:>4} {:>7.0} {:>5.0} {:>6.0}  {:<16}  {:>4.0} mm \
             {:<5} {}\n",
            c.shape,
            c.pilots,
            r.obstacle.width * 1e3,
            r.obstacle.drop * 1e3,
            r.heading_deg,
            r.run,
            r.required * 1e3,
            r.gate_advance * 1e3,
            r.rigid_advance * 1e3,
            r.gate_limited_by.chars().take(16).collect::<String>(),
            r.physics_fail.unwrap_or(0.0) * 1e3,
            r.fail_kind.as_deref().unwrap_or(""),
            r.physics_tip
                .map_or(String::new(), |t| format!("{:.0} mm", t * 1e3))
        );
    }
    t
}

type Res = Result<(), String>;

fn e<E: std::fmt::Display>(x: E) -> String {
    x.to_string()
}

/// Maximum gap against robots, line and mesh, one series per pilot setting (Figures
/// 3.15–3.16; the far platform 6 mm lower, best heading).
pub fn plot_max_gap(path: &Path, s: &Summary) -> Res {
    let root = SVGBackend::new(path, (1000, 420)).into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    let panels = root.split_evenly((1, 2));
    for (panel, mesh) in panels.iter().zip([false, true]) {
        let mut ch = ChartBuilder::on(panel)
            .caption(if mesh { "mesh" } else { "line" }, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(45)
            .build_cartesian_2d(0.0..10.0, 0.0..110.0)
            .map_err(e)?;
        ch.configure_mesh()
            .x_desc("robots")
            .y_desc("max gap, far side 6 mm lower (mm)")
            .draw()
            .map_err(e)?;
        for (k, pilots) in ["none", "front", "back", "front+back"].iter().enumerate() {
            let pts: Vec<(f64, f64)> = s
                .configs
                .iter()
                .filter(|c| c.config.mesh == mesh && c.config.pilots == *pilots)
                .map(|c| (c.config.robots as f64, c.gap_drop.unwrap_or(0.0) * 1e3))
                .collect();
            let col = Palette99::pick(k).to_rgba();
            ch.draw_series(LineSeries::new(pts.clone(), col.stroke_width(2)))
                .map_err(e)?
                .label(*pilots)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], col));
            ch.draw_series(pts.iter().map(|p| Circle::new(*p, 3, col.filled())))
                .map_err(e)?;
        }
        ch.configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE)
            .position(SeriesLabelPosition::UpperLeft)
            .draw()
            .map_err(e)?;
    }
    root.present().map_err(e)
}

/// The widest level gap crossed with > 80 % completion against heading (Figure 5.7 C, whose
/// completion at one gap falls where this widest gap does): lines and meshes of 4 and 8
/// robots with two pilots.
pub fn plot_heading(path: &Path, s: &Summary) -> Res {
    let root = SVGBackend::new(path, (700, 420)).into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    let mut ch = ChartBuilder::on(&root)
        .caption(
            "widest level gap crossed (> 80 % of the robots) against heading",
            ("sans-serif", 16),
        )
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(45)
        .build_cartesian_2d(-2.0..52.0, 0.0..110.0)
        .map_err(e)?;
    ch.configure_mesh()
        .x_desc("heading θ (°)")
        .y_desc("widest level gap (mm)")
        .draw()
        .map_err(e)?;
    let chosen = s
        .configs
        .iter()
        .filter(|c| c.config.pilots == "front+back" && [4, 8].contains(&c.config.robots));
    for (k, c) in chosen.enumerate() {
        let col = Palette99::pick(k).to_rgba();
        let pts: Vec<(f64, f64)> = c
            .completion_by_heading
            .iter()
            .map(|(h, w, _)| (*h, w.unwrap_or(0.0) * 1e3))
            .collect();
        let label = format!(
            "{} (α {:.1}°, gap {} mm)",
            c.config.shape,
            c.config.alpha_deg,
            mm(c.gap_level)
        );
        ch.draw_series(LineSeries::new(pts.clone(), col.stroke_width(2)))
            .map_err(e)?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], col));
        ch.draw_series(pts.iter().map(|p| Circle::new(*p, 3, col.filled())))
            .map_err(e)?;
    }
    ch.configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE)
        .position(SeriesLabelPosition::LowerLeft)
        .draw()
        .map_err(e)?;
    root.present().map_err(e)
}

/// The gate's proven advance against the advance at which the physics failed (its static
/// tipping point where measured), one point per failed run; below the diagonal the gate
/// stopped short, above it the gate was wrong.
pub fn plot_gate(path: &Path, d: &CrossingData) -> Res {
    let root = SVGBackend::new(path, (600, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    let pts: Vec<(f64, f64, bool)> = d
        .runs
        .iter()
        .filter_map(|r| {
            r.physics_limit()
                .map(|f| (f * 1e3, r.gate_advance * 1e3, d.configs[r.config].mesh))
        })
        .collect();
    let top = pts.iter().map(|p| p.0.max(p.1)).fold(50.0, f64::max) * 1.05;
    let mut ch = ChartBuilder::on(&root)
        .caption("gate against physics", ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(45)
        .build_cartesian_2d(0.0..top, 0.0..top)
        .map_err(e)?;
    ch.configure_mesh()
        .x_desc("advance at which the physics tipped or a connector opened (mm)")
        .y_desc("advance the gate proves safe (mm)")
        .draw()
        .map_err(e)?;
    ch.draw_series(LineSeries::new(vec![(0.0, 0.0), (top, top)], BLACK))
        .map_err(e)?;
    for (mesh, col, name) in [(false, BLUE, "line"), (true, RED, "mesh")] {
        ch.draw_series(
            pts.iter()
                .filter(|p| p.2 == mesh)
                .map(|p| Circle::new((p.0, p.1), 3, col.filled())),
        )
        .map_err(e)?
        .label(name)
        .legend(move |(x, y)| Circle::new((x, y), 3, col.filled()));
    }
    ch.configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(e)?;
    root.present().map_err(e)
}

/// Run the experiment with a progress bar (or, with `regate`, re-run the gate's side of the
/// stored runs of that `crossing.json`), write its files into a new run folder
/// (`crossing.json`: every run; `summary.json`; `crossing.txt`: the tables; `max_gap.svg`,
/// `heading.svg`, `gate_vs_physics.svg`) and return the summary, the tables and the folder.
pub fn command(
    opt: &super::crossing::Options,
    regate: Option<&Path>,
    runs_dir: &Path,
    progress: bool,
) -> anyhow::Result<(Summary, String, std::path::PathBuf)> {
    let (d, n) = match regate {
        None => {
            let n = super::crossing::series_count(opt);
            let pb = crate::app::Progress::new(n, "series", progress);
            let d = super::crossing::run(opt, &|| pb.inc());
            pb.finish();
            (d, format!("{n} series"))
        }
        Some(file) => {
            let text = std::fs::read_to_string(file)
                .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
            let mut d: CrossingData = serde_json::from_str(&text)
                .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
            let n = super::crossing_regate::stored_cases(&d);
            let steps = super::crossing_regate::regate_steps(&d);
            let pb = crate::app::Progress::new(steps, "gate evaluations", progress);
            let t0 = std::time::Instant::now();
            super::crossing_regate::regate(&mut d, opt.threads, &|| pb.inc())
                .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
            pb.finish();
            let tips = super::crossing_regate::pending_tips(&d);
            if tips > 0 {
                let pb = crate::app::Progress::new(tips, "tipping points", progress);
                super::crossing_regate::fill_tips(&mut d, opt.threads, &|| pb.inc())
                    .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
                pb.finish();
            }
            d.wall_s = t0.elapsed().as_secs_f64();
            (d, format!("{n} cases"))
        }
    };
    let s = summarise(&d);
    let mut text = render(&s, &d);
    if !d.skipped.is_empty() {
        text += &format!("\n{} cases not started:\n", d.skipped.len());
        for k in &d.skipped {
            text += &format!("  {k}\n");
        }
    }
    text += &format!("\n{}, {} runs in {:.0} s\n", n, d.runs.len(), d.wall_s);
    let folder = crate::report::RunFolder::create(runs_dir, "crossing")?;
    folder.write_json("crossing.json", &d)?;
    folder.write_json("summary.json", &s)?;
    let dir = folder.dir().to_path_buf();
    std::fs::write(dir.join("crossing.txt"), &text)?;
    plot_max_gap(&dir.join("max_gap.svg"), &s).map_err(anyhow::Error::msg)?;
    plot_heading(&dir.join("heading.svg"), &s).map_err(anyhow::Error::msg)?;
    plot_gate(&dir.join("gate_vs_physics.svg"), &d).map_err(anyhow::Error::msg)?;
    Ok((s, text, dir))
}
