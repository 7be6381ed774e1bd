//! The physics' static tipping point against the gate's: a 2 × 2 mesh with a pilot in front
//! and one at the back, driven over a level 60 mm gap at 20°, tips in the 3-D physics; the
//! farthest advance at which it stands when stopped lies before the advance at which the
//! driven run saw a robot fall, and the gate's limit with unbreakable couplings lies at most
//! 10 mm before it (issue "cross the gap": rigid meshes within 10 mm of the tipping point).

use puzzlebot_host::crossing::drive3d;
use puzzlebot_host::experiment::crossing::{
    configs, predict, run_scenario, set_down, settings, Obstacle,
};
use puzzlebot_host::experiment::tip_point::{static_tip_point, TipSearch};
use puzzlebot_params::FleetParams;
use puzzlebot_sim::physics3d::World3d;

#[test]
fn a_mesh_tips_where_the_rigid_gate_says() {
    let params = FleetParams::default();
    let cfg = configs(&[4], &params)
        .into_iter()
        .find(|c| c.mesh && c.pilots == "front+back")
        .expect("the 2 x 2 mesh with two pilots");
    let gap = Obstacle {
        width: 0.06,
        drop: 0.0,
    };
    let (cand, rigid) = predict(&cfg, gap, 20.0, &params).expect("the gate's prediction");
    let formed = set_down(&cfg, &params).expect("set down");
    let terrain = gap.terrain();
    let s = run_scenario(&formed, &cand, &terrain, &params, 1, 0);
    let base = settings();
    let mut w = World3d::new(&s, base.world).expect("world");
    let o = drive3d::cross(&mut w, &cand, &terrain, &params, &base);
    let fell = o.fell.first().expect("the mesh tips into the gap").1;
    let tip = static_tip_point(
        &s,
        &cand,
        &terrain,
        &params,
        &base,
        &TipSearch::default(),
        fell,
    )
    .expect("tip search")
    .expect("the mesh stands when stopped at once");
    assert!(
        tip < fell,
        "static tip {tip} after the detected fall {fell}"
    );
    assert!(
        rigid.distance <= tip && tip - rigid.distance <= 0.010,
        "rigid gate {} against the physics' static tipping point {tip} (fall detected at {fell})",
        rigid.distance
    );
}
