//! Recording the 3-D part of a run: where a lockstep run hands its assembly to the 3-D world
//! at a cross step, the recording goes on with the 3-D world's terrain, poses (their height
//! included, so a fall shows), couplings and events, on the same topics as the flat part.

use puzzlebot_params::terrain::Terrain;
use puzzlebot_sim::mechanics::LinkState;
use puzzlebot_sim::physics3d::{Event3d, World3d};
use serde_json::json;

use super::super::foxglove as fg;
use super::{Recorder, SAMPLE_PERIOD};
use crate::crossing::drive3d::held;

impl Recorder {
    /// The run moves to the 3-D world on `terrain`: the replay draws that terrain.
    pub fn enter_3d(&mut self, terrain: &Terrain) {
        self.info.terrain = terrain.clone();
        self.events_3d_seen = 0;
    }

    /// Controller time `t` of the 3-D part: every [`SAMPLE_PERIOD`] each robot's true pose,
    /// the couplings that hold, and the world's new breaks and falls.
    pub fn sample_3d(&mut self, t: f64, w: &World3d) {
        if t + 1e-9 < self.next_sample {
            return;
        }
        self.next_sample = t + SAMPLE_PERIOD;
        for r in w.states() {
            let [x, y, z] = r.position;
            let m = fg::pose_in_frame(t, x, y, z, r.rpy[2]);
            self.push(
                format!("/robot_{}/pose/true", r.id),
                "foxglove.PoseInFrame",
                t,
                &m,
            );
        }
        let links: Vec<_> = held(w)
            .into_iter()
            .map(|(k, a, b)| {
                json!({"kind": k, "a": a, "b": b, "state": LinkState::Coupled, "legs": [true, true]})
            })
            .collect();
        self.push(
            "/couplings/true".into(),
            "puzzlebot.Couplings",
            t,
            &json!({"timestamp": fg::time(t), "links": links}),
        );
        // World times are µs since the 3-D world started; the controller's clock goes on.
        let offset = w.time_us() as f64 * 1e-6 - t;
        let events = w.events();
        for e in &events[self.events_3d_seen.min(events.len())..] {
            let (t_us, level, text) = match *e {
                Event3d::Broke {
                    t_us,
                    kind,
                    a,
                    b,
                    force,
                    moment,
                } => (
                    t_us,
                    4,
                    format!("{kind:?} {a}-{b} broke ({force:.1} N, {moment:.3} N·m)"),
                ),
                Event3d::Fell { t_us, id } => (t_us, 4, format!("robot {id} fell")),
            };
            let te = t_us as f64 * 1e-6 - offset;
            self.push(
                "/events".into(),
                "foxglove.Log",
                te,
                &fg::log(te, level, "simulator", &text),
            );
        }
        self.events_3d_seen = events.len();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::read::Recording;

    #[test]
    fn the_3d_part_of_a_run_is_recorded_with_its_terrain_and_heights() {
        let s = crate::assemble::scattered_fleet(2, 0, 5);
        let mut rec = Recorder::new(&s);
        let terrain = Terrain {
            platforms: vec![puzzlebot_params::terrain::Platform::rect(
                "table",
                [-2.0, -2.0],
                [2.0, 2.0],
                0.1,
            )],
        };
        let s3 = puzzlebot_sim::Scenario {
            terrain: terrain.clone(),
            ..s.clone()
        };
        let mut w = World3d::new(&s3, puzzlebot_sim::physics3d::Config3d::default()).unwrap();
        rec.enter_3d(&terrain);
        for k in 0..5 {
            rec.sample_3d(10.0 + 0.1 * f64::from(k), &w);
            w.run_for(100_000);
        }
        let dir = std::env::temp_dir().join(format!("pb-rec3d-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("run.mcap");
        rec.write(&path).unwrap();
        let read = Recording::read(&path).unwrap();
        assert_eq!(read.info.terrain, terrain);
        let poses: Vec<_> = read
            .messages
            .iter()
            .filter(|m| m.topic == "/robot_1/pose/true")
            .collect();
        assert_eq!(poses.len(), 5);
        // On the 0.1 m table, not on the floor.
        let z = poses[4].data["pose"]["position"]["z"].as_f64().unwrap();
        assert!(z > 0.09, "{z}");
        assert!((poses[0].t - 10.0).abs() < 1e-6);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
