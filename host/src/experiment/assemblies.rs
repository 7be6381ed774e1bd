//! `puzzlebot experiment assemblies`: randomized assembly episodes ([`Episode`]) run in
//! parallel over the cores in the lockstep simulator, judged against its ground truth
//! ([`run_episode`]), and summarised: success rate per bucket (fleet size, shape, pilots,
//! profile) with a 95 % Wilson interval, median and p95 formation time, and the failure
//! taxonomy with every failed episode's seed. Output: a table on the terminal, `summary.json`
//! (with every episode) and `success.svg` in a run folder.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use plotters::prelude::*;
use serde::Serialize;

use super::episode::{custom_shapes, CustomShape, Episode, Profile};
use super::verdict::{run_episode, Failure, Outcome};
use crate::report::RunFolder;

/// What to run.
#[derive(Debug, Clone)]
pub struct Options {
    /// Episodes.
    pub episodes: usize,
    /// Impairment profile.
    pub profile: Profile,
    /// Seed of the first episode; episode `i` has seed `seed + i`.
    pub seed: u64,
    /// Worker threads (0: one per core).
    pub threads: usize,
    /// Folder of the custom shapes.
    pub shapes_dir: PathBuf,
    /// Draw a progress bar.
    pub progress: bool,
    /// Share of the episodes (without two pilots) formed in parallel instead of grown.
    pub parallel: f64,
    /// Largest fleet drawn (6…12).
    pub max_robots: usize,
    /// Mean controller latency instead of the profile's (ms).
    pub latency_ms: Option<f64>,
}

impl Options {
    /// `episodes` episodes under `profile` from seed `seed`, the default draw, no progress bar.
    pub fn new(episodes: usize, profile: Profile, seed: u64) -> Options {
        Options {
            episodes,
            profile,
            seed,
            threads: 0,
            shapes_dir: super::episode::default_shapes_dir(),
            progress: false,
            parallel: 0.0,
            max_robots: super::episode::MAX_ROBOTS,
            latency_ms: None,
        }
    }

    fn draw(&self, seed: u64, shapes: &[CustomShape]) -> Episode {
        let mut ep =
            Episode::draw_up_to(seed, self.profile, shapes, self.parallel, self.max_robots);
        ep.latency_ms = self.latency_ms;
        ep
    }
}

/// A success rate with its 95 % Wilson score interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Rate {
    /// Successes.
    pub passed: usize,
    /// Episodes.
    pub total: usize,
    /// passed / total.
    pub rate: f64,
    /// Lower end of the 95 % interval.
    pub low: f64,
    /// Upper end.
    pub high: f64,
}

impl Rate {
    /// The rate of `passed` of `total`, with the Wilson interval at z = 1.96.
    pub fn of(passed: usize, total: usize) -> Rate {
        if total == 0 {
            return Rate {
                passed,
                total,
                rate: 0.0,
                low: 0.0,
                high: 1.0,
            };
        }
        let n = total as f64;
        let p = passed as f64 / n;
        let z: f64 = 1.96;
        let z2 = z * z;
        let centre = (p + z2 / (2.0 * n)) / (1.0 + z2 / n);
        let half = z / (1.0 + z2 / n) * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt();
        Rate {
            passed,
            total,
            rate: p,
            low: (centre - half).max(0.0),
            high: (centre + half).min(1.0),
        }
    }
}

/// One failed episode in the taxonomy.
#[derive(Debug, Clone, Serialize)]
pub struct FailedEpisode {
    /// Its seed (`--replay SEED`).
    pub seed: u64,
    /// One line describing the episode.
    pub episode: String,
    /// What went wrong.
    pub detail: String,
}

/// The summary of a batch.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// Profile.
    pub profile: Profile,
    /// First seed.
    pub seed: u64,
    /// Overall success.
    pub overall: Rate,
    /// Success per bucket: `size 2-4`, `shape mesh3`, `pilots 1`, `profile lab`, ….
    pub buckets: BTreeMap<String, Rate>,
    /// Median formation time over the episodes that formed (simulated s).
    pub formation_median_s: Option<f64>,
    /// 95th percentile of the formation time (simulated s).
    pub formation_p95_s: Option<f64>,
    /// Median formation time of 8-robot episodes (simulated s).
    pub formation_median_8_s: Option<f64>,
    /// Planned anchor pairs that came apart after formation, summed over the episodes.
    pub pops: usize,
    /// Failed episodes by class.
    pub failures: BTreeMap<Failure, Vec<FailedEpisode>>,
    /// Wall-clock time of the batch (s).
    pub wall_s: f64,
    /// Every episode's outcome.
    pub episodes: Vec<Outcome>,
}

/// Run the batch of `opts`, calling `on_done` after each episode.
pub fn run(opts: &Options, on_done: &(dyn Fn(&Outcome) + Sync)) -> anyhow::Result<Summary> {
    let shapes = custom_shapes(&opts.shapes_dir)?;
    let start = std::time::Instant::now();
    let episodes: Vec<Episode> = (0..opts.episodes as u64)
        .map(|i| opts.draw(opts.seed.wrapping_add(i), &shapes))
        .collect();
    let threads = match opts.threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n,
    }
    .min(episodes.len().max(1));
    let next = AtomicUsize::new(0);
    let results = Mutex::new(Vec::with_capacity(episodes.len()));
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(ep) = episodes.get(i) else { break };
                let o = run_episode(ep, None);
                on_done(&o);
                if let Ok(mut r) = results.lock() {
                    r.push(o);
                }
            });
        }
    });
    let mut outcomes = results
        .into_inner()
        .map_err(|_| anyhow::anyhow!("an episode thread panicked"))?;
    if outcomes.len() != episodes.len() {
        anyhow::bail!(
            "{} of {} episodes did not report (a worker panicked)",
            episodes.len() - outcomes.len(),
            episodes.len()
        );
    }
    outcomes.sort_by_key(|o| o.episode.seed);
    Ok(summarise(
        opts.profile,
        opts.seed,
        outcomes,
        start.elapsed().as_secs_f64(),
    ))
}

fn percentile(sorted: &[f64], q: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted.get(i).copied()
}

/// Summarise a batch's outcomes.
pub fn summarise(profile: Profile, seed: u64, episodes: Vec<Outcome>, wall_s: f64) -> Summary {
    let mut counts: BTreeMap<String, (usize, usize)> = BTreeMap::new();
    for o in &episodes {
        let e = &o.episode;
        for key in [
            format!("size {}", e.size_bucket()),
            format!("shape {}", e.shape.bucket()),
            format!("pilots {}", e.pilots),
            format!("profile {}", e.profile.name()),
            format!("robots {:02}", e.robots),
            format!("dissolve {}", if e.dissolve { "yes" } else { "no" }),
            format!("grow {}", if e.grow { "yes" } else { "no" }),
        ] {
            let c = counts.entry(key).or_default();
            c.0 += usize::from(o.success);
            c.1 += 1;
        }
    }
    let passed = episodes.iter().filter(|o| o.success).count();
    let mut formed: Vec<f64> = episodes.iter().filter_map(|o| o.formation_s).collect();
    formed.sort_by(f64::total_cmp);
    let mut formed8: Vec<f64> = episodes
        .iter()
        .filter(|o| o.episode.robots == 8)
        .filter_map(|o| o.formation_s)
        .collect();
    formed8.sort_by(f64::total_cmp);
    let mut failures: BTreeMap<Failure, Vec<FailedEpisode>> = BTreeMap::new();
    for o in episodes.iter().filter(|o| !o.success) {
        failures
            .entry(o.failure.unwrap_or(Failure::Other))
            .or_default()
            .push(FailedEpisode {
                seed: o.episode.seed,
                episode: o.episode.describe(),
                detail: o.detail.clone(),
            });
    }
    Summary {
        profile,
        seed,
        overall: Rate::of(passed, episodes.len()),
        buckets: counts
            .into_iter()
            .map(|(k, (p, n))| (k, Rate::of(p, n)))
            .collect(),
        formation_median_s: percentile(&formed, 0.5),
        formation_p95_s: percentile(&formed, 0.95),
        formation_median_8_s: percentile(&formed8, 0.5),
        pops: episodes.iter().map(|o| o.pops).sum(),
        failures,
        wall_s,
        episodes,
    }
}

fn pct(r: &Rate) -> String {
    format!(
        "{:>4}/{:<4} {:5.1} %  [{:5.1}, {:5.1}]",
        r.passed,
        r.total,
        100.0 * r.rate,
        100.0 * r.low,
        100.0 * r.high
    )
}

/// The summary as a table for the terminal.
pub fn describe(s: &Summary) -> String {
    let latency = s
        .episodes
        .first()
        .and_then(|o| o.episode.latency_ms)
        .map_or(String::new(), |ms| format!(" at {ms} ms latency"));
    let mut t = format!(
        "assemblies, profile {}{latency}, seeds {}..{}: {}   (95 % Wilson interval)\n",
        s.profile.name(),
        s.seed,
        s.seed + s.overall.total as u64,
        pct(&s.overall)
    );
    let secs = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.1} s"));
    t.push_str(&format!(
        "formation time (simulated): median {}, p95 {}, median of 8-robot fleets {}\n",
        secs(s.formation_median_s),
        secs(s.formation_p95_s),
        secs(s.formation_median_8_s)
    ));
    t.push_str(&format!(
        "anchors that came apart after formation: {} in {} episodes\n",
        s.pops,
        s.episodes.iter().filter(|o| o.pops > 0).count()
    ));
    t.push_str(&format!(
        "wall time {:.1} s\n\nbucket                  passed     rate     95 % interval\n",
        s.wall_s
    ));
    for (k, r) in &s.buckets {
        if k.starts_with("robots ") {
            continue;
        }
        t.push_str(&format!("  {k:<20} {}\n", pct(r)));
    }
    t.push_str("\nfailures by class\n");
    if s.failures.is_empty() {
        t.push_str("  none\n");
    }
    for f in Failure::ALL {
        if let Some(list) = s.failures.get(&f) {
            let seeds: Vec<String> = list.iter().map(|e| e.seed.to_string()).collect();
            t.push_str(&format!(
                "  {:<20} {:>3}  seeds {}\n",
                f.name(),
                list.len(),
                seeds.join(" ")
            ));
        }
    }
    t
}

/// Bar chart of the success per bucket with the 95 % intervals as whiskers.
pub fn plot(path: &Path, s: &Summary) -> Result<(), String> {
    let rows: Vec<(&String, &Rate)> = s
        .buckets
        .iter()
        .filter(|(k, _)| !k.starts_with("robots "))
        .collect();
    let h = 80 + 26 * rows.len() as u32;
    let root = SVGBackend::new(path, (760, h)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let n = rows.len() as i32;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!(
                "assembly success, profile {} ({} episodes)",
                s.profile.name(),
                s.overall.total
            ),
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(150)
        .build_cartesian_2d(0.0..100.0, 0..n.max(1))
        .map_err(|e| e.to_string())?;
    let labels: Vec<String> = rows.iter().map(|(k, _)| (*k).clone()).collect();
    chart
        .configure_mesh()
        .x_desc("success (%)")
        .y_labels(rows.len().max(1))
        .y_label_formatter(&|i| {
            labels
                .get((n - 1 - *i).max(0) as usize)
                .cloned()
                .unwrap_or_default()
        })
        .draw()
        .map_err(|e| e.to_string())?;
    for (i, (_, r)) in rows.iter().enumerate() {
        let y = n - 1 - i as i32;
        let colour = if r.rate >= 0.95 {
            RGBColor(60, 150, 80)
        } else {
            RGBColor(200, 80, 60)
        };
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(0.0, y), (100.0 * r.rate, y + 1)],
                colour.mix(0.7).filled(),
            )))
            .map_err(|e| e.to_string())?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(100.0 * r.low, y), (100.0 * r.high, y)],
                BLACK.stroke_width(2),
            )))
            .map_err(|e| e.to_string())?;
    }
    root.present().map_err(|e| e.to_string())
}

/// `puzzlebot experiment assemblies`: run, print, write `summary.json` and `success.svg`.
pub fn command(opts: &Options, runs_dir: &Path) -> anyhow::Result<Summary> {
    use std::io::IsTerminal;
    // Piped or logged, a bar would not show: one line per finished episode instead.
    let lines = opts.progress && !std::io::stderr().is_terminal();
    let done = AtomicUsize::new(0);
    let bar = if opts.progress && !lines {
        let b = indicatif::ProgressBar::new(opts.episodes as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} episodes, {elapsed} elapsed, ~{eta} left  {msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        Some(b)
    } else {
        None
    };
    let failed = AtomicUsize::new(0);
    let s = run(opts, &|o| {
        if !o.success {
            failed.fetch_add(1, Ordering::Relaxed);
        }
        if lines {
            let n = done.fetch_add(1, Ordering::Relaxed) + 1;
            let e = &o.episode;
            eprintln!(
                "{n}/{} seed {} ({} robots, {}): {} in {:.0} s",
                opts.episodes,
                e.seed,
                e.robots,
                e.shape.bucket(),
                o.failure.map_or("ok", |f| f.name()),
                o.wall_s
            );
        }
        if let Some(b) = &bar {
            b.set_message(format!("{} failed", failed.load(Ordering::Relaxed)));
            b.inc(1);
        }
    })?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let folder = RunFolder::create(runs_dir, &format!("assemblies-{}", opts.profile.name()))?;
    folder.write_json("summary.json", &s)?;
    plot(&folder.dir().join("success.svg"), &s).map_err(|e| anyhow::anyhow!("chart: {e}"))?;
    println!("{}", describe(&s));
    println!("run folder: {}", folder.dir().display());
    Ok(s)
}

/// `--replay SEED`: one episode again, with its run folder; prints its outcome.
pub fn replay(opts: &Options, seed: u64, runs_dir: &Path) -> anyhow::Result<Outcome> {
    let shapes: Vec<CustomShape> = custom_shapes(&opts.shapes_dir)?;
    let ep = opts.draw(seed, &shapes);
    // With `--json` (no progress) stdout gets the JSON alone; these lines go to stderr.
    let say = |line: String| {
        if opts.progress {
            println!("{line}");
        } else {
            eprintln!("{line}");
        }
    };
    say(ep.describe());
    let o = run_episode(&ep, Some(runs_dir));
    say(format!(
        "{}{}; formation {}, {:.1} s simulated in {:.1} s",
        match o.failure {
            Some(f) => format!("FAILED: {}", f.name()),
            None if o.success => "passed".to_string(),
            None => "FAILED".to_string(),
        },
        if o.detail.is_empty() {
            String::new()
        } else {
            format!(" ({})", o.detail)
        },
        o.formation_s
            .map_or("not complete".to_string(), |t| format!("{t:.1} s")),
        o.sim_s,
        o.wall_s
    ));
    Ok(o)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_intervals_match_the_textbook_values() {
        // 95 of 100: [0.888, 0.978] (Wilson 1927; Newcombe 1998, table I).
        let r = Rate::of(95, 100);
        assert!(
            (r.low - 0.8882).abs() < 1e-3 && (r.high - 0.9785).abs() < 1e-3,
            "{r:?}"
        );
        let all = Rate::of(20, 20);
        assert_eq!(all.high, 1.0);
        assert!((all.low - 0.8389).abs() < 1e-3, "{all:?}");
        assert_eq!(Rate::of(0, 0).total, 0);
    }
}
