//! Re-evaluation of stored crossing runs (`puzzlebot experiment crossing --regate`): the
//! gate's side again with the gate as it is now, and the physics' static tipping point of
//! the runs stored without one, keeping every driven run as it was.

use super::crossing::{
    configs, judge_start, predict, run_scenario, set_down, settings, CrossingData, Obstacle,
};
use super::tip_point::{static_tip_point, TipSearch};
use super::workers::map_parallel;
use puzzlebot_params::FleetParams;

/// Re-run the gate's side of stored runs (a `crossing.json` of an earlier run) with the gate
/// as it is now, keeping the physics' results: the gate against physics without the
/// simulation's minutes. `on_case` after each gate evaluation ([`regate_steps`]). The error
/// names what does not match.
pub fn regate(
    d: &mut CrossingData,
    threads: usize,
    on_case: &(dyn Fn() + Sync),
) -> Result<(), String> {
    let params = d.params.clone();
    let mut robots: Vec<usize> = d.configs.iter().map(|c| c.robots).collect();
    robots.dedup();
    let now = configs(&robots, &params);
    if now.len() != d.configs.len()
        || now
            .iter()
            .zip(&d.configs)
            .any(|(a, b)| a.shape != b.shape || a.pilot_places != b.pilot_places)
    {
        return Err("configs: the stored configurations are not this version's".into());
    }
    d.configs = now;
    let mut keys: Vec<(usize, Obstacle, f64)> = Vec::new();
    for r in &d.runs {
        if r.config >= d.configs.len() {
            return Err(format!("runs[].config: {} out of range", r.config));
        }
        let k = (r.config, r.obstacle, r.heading_deg);
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    let cfgs = &d.configs;
    let out = map_parallel(
        &keys,
        threads,
        &|&(c, o, h)| predict(&cfgs[c], o, h, &params),
        on_case,
    );
    let mut jittered = Vec::new();
    for (i, r) in d.runs.iter_mut().enumerate() {
        let k = keys
            .iter()
            .position(|k| *k == (r.config, r.obstacle, r.heading_deg));
        match k.and_then(|k| out.get(k)) {
            Some(Ok((cand, rigid))) => {
                r.gate_advance = cand.advance.distance;
                r.gate_limited_by = format!("{:?}", cand.advance.limited_by);
                r.gate_stop_limit = Some(cand.advance.stop_limit());
                r.rigid_advance = rigid.distance;
                if r.run > 0 {
                    jittered.push((i, cand.clone()));
                }
            }
            Some(Err(e)) => return Err(e.clone()),
            None => return Err("a case was not evaluated".into()),
        }
    }
    // The jittered runs from their own starts, as the experiment judges them.
    let data = &*d;
    let judged = map_parallel(
        &jittered,
        threads,
        &|(i, cand)| {
            let r = &data.runs[*i];
            let cfg = &data.configs[r.config];
            let formed = set_down(cfg, &params)?;
            let terrain = r.obstacle.terrain();
            let s = run_scenario(&formed, cand, &terrain, &params, data.seed, r.run);
            judge_start(cfg, cand, &s, &terrain, &params)
        },
        on_case,
    );
    for ((i, _), a) in jittered.iter().zip(judged) {
        let a = a.map_err(|e| format!("runs[{i}]: {e}"))?;
        let r = &mut d.runs[*i];
        r.gate_advance = a.distance;
        r.gate_limited_by = format!("{:?}", a.limited_by);
        r.gate_stop_limit = Some(a.stop_limit());
    }
    Ok(())
}

/// Number of distinct cases of stored runs (progress bar length of [`regate`]).
pub fn stored_cases(d: &CrossingData) -> usize {
    let mut keys: Vec<(usize, u64, u64, u64)> = d
        .runs
        .iter()
        .map(|r| {
            (
                r.config,
                r.obstacle.width.to_bits(),
                r.obstacle.drop.to_bits(),
                r.heading_deg.to_bits(),
            )
        })
        .collect();
    keys.sort_unstable();
    keys.dedup();
    keys.len()
}

/// Number of gate evaluations [`regate`] makes: one per stored case and one per jittered run
/// (its progress bar's length).
pub fn regate_steps(d: &CrossingData) -> usize {
    stored_cases(d) + d.runs.iter().filter(|r| r.run > 0).count()
}

/// Stored runs that need the physics' static tipping point: first runs of meshes that
/// fell, stored without one.
fn needs_tip(d: &CrossingData, r: &super::crossing::CrossRun) -> bool {
    r.run == 0
        && r.physics_tip.is_none()
        && r.physics_fail.is_some()
        && r.fail_kind.as_deref() == Some("fell")
        && d.configs.get(r.config).is_some_and(|c| c.mesh)
}

/// Number of stored runs [`fill_tips`] measures (its progress bar's length).
pub fn pending_tips(d: &CrossingData) -> usize {
    d.runs.iter().filter(|r| needs_tip(d, r)).count()
}

/// Measure the physics' static tipping point of the stored runs without one (meshes that
/// fell), each from its own seed and jitter as the experiment drove it; `on_run` after each.
pub fn fill_tips(
    d: &mut CrossingData,
    threads: usize,
    on_run: &(dyn Fn() + Sync),
) -> Result<(), String> {
    let params = d.params.clone();
    let todo: Vec<usize> = (0..d.runs.len())
        .filter(|&i| needs_tip(d, &d.runs[i]))
        .collect();
    let data = &*d;
    let tips = map_parallel(&todo, threads, &|&i| tip_of(data, i, &params), on_run);
    for (&i, tip) in todo.iter().zip(tips) {
        d.runs[i].physics_tip = tip.map_err(|e| format!("runs[{i}]: {e}"))?;
    }
    Ok(())
}

/// The static tipping point of stored run `i`.
fn tip_of(d: &CrossingData, i: usize, params: &FleetParams) -> Result<Option<f64>, String> {
    let r = &d.runs[i];
    let cfg = &d.configs[r.config];
    let Some(fell_at) = r.physics_fail else {
        return Ok(None);
    };
    let (cand, _) = predict(cfg, r.obstacle, r.heading_deg, params)?;
    let formed = set_down(cfg, params)?;
    let terrain = r.obstacle.terrain();
    let s = run_scenario(&formed, &cand, &terrain, params, d.seed, r.run);
    let search = TipSearch::default();
    static_tip_point(&s, &cand, &terrain, params, &settings(), &search, fell_at)
}
