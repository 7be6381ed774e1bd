//! One alignment run: `align_debug X Y HEADING_WEIGHT HORIZON PRE_OFFSET`; prints the outcome.
use puzzlebot_mpc::*;
use puzzlebot_params::{drive::Drive, RobotKind};

fn main() {
    let a: Vec<f64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let get = |i: usize, d: f64| a.get(i).copied().unwrap_or(d);
    let (x, y, hw, h, pre) = (
        get(0, 0.08),
        get(1, 0.04),
        get(2, 1e-3),
        get(3, 10.0) as usize,
        get(4, 0.0),
    );
    let (ws, sqp) = (get(5, 1e3), get(6, 1.0) as usize);
    let cfg = MpcConfig {
        horizon: h,
        sqp_iterations: sqp,
        ..MpcConfig::default()
    };
    let g = cfg.geometry.clone();
    let limits = Limits::from_drive(&Drive::for_kind(RobotKind::NonPilot));
    let mut mpc = DistributedMpc::with_threads(cfg, 1).expect("config");
    let partner = Pose::new(0.0, 0.0, 0.0);
    let mut me = Pose::new(x, y, 0.0);
    let mut stage_pre = pre > 0.0;
    for t in 0..400 {
        let off = if stage_pre { pre } else { 0.0 };
        let task = CostTerm::AlignPair {
            partner: 2,
            own: ConnectionPoint {
                pos: g.anchor_head,
                angle: 0.0,
            },
            partner_point: ConnectionPoint {
                pos: [g.anchor_opening[0] + off, 0.0],
                angle: 0.0,
            },
            weights: StageWeights {
                stage: ws,
                terminal: 1.0e4,
            },
            heading: hw,
        };
        let robots = [
            RobotInput {
                id: 1,
                pose: me,
                limits,
                costs: vec![task],
            },
            RobotInput {
                id: 2,
                pose: partner,
                limits,
                costs: vec![],
            },
        ];
        let out = mpc.tick(&robots, &[]).expect("tick");
        let r = &out.robots[0];
        for _ in 0..10 {
            me = r.command.drive(&me, 0.01);
        }
        let head = me.transform(g.anchor_head);
        let d = (head[0] - g.anchor_opening[0] - off).hypot(head[1]);
        if stage_pre && d < 0.005 && me.yaw.sin().abs() < 0.2 {
            stage_pre = false;
        }
        if !stage_pre && d < 0.0035 && me.yaw.sin().abs() < 0.479 {
            println!("aligned at t={:.1}s pose {me:?}", f64::from(t + 1) * 0.1);
            return;
        }
    }
    println!("FAILED: pose {me:?} stage_pre {stage_pre}");
}
