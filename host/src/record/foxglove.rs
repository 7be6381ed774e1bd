//! Foxglove's well-known message schemas (`foxglove.PoseInFrame`, `foxglove.SceneUpdate`,
//! `foxglove.Log`) as JSON Schema, and builders for their JSON messages, so that Foxglove
//! opens a recording without set-up. The schemas list the fields these builders write, with
//! Foxglove's names and types.

use serde_json::{json, Value};

/// JSON Schema of a Foxglove `time` (seconds and nanoseconds).
fn time_schema() -> Value {
    json!({
        "type": "object", "title": "time",
        "properties": {
            "sec": {"type": "integer", "minimum": 0},
            "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999}
        }
    })
}

fn vector3_schema() -> Value {
    json!({
        "title": "foxglove.Vector3", "type": "object",
        "properties": {"x": {"type": "number"}, "y": {"type": "number"}, "z": {"type": "number"}},
        "required": ["x", "y", "z"]
    })
}

fn pose_schema() -> Value {
    json!({
        "title": "foxglove.Pose", "type": "object",
        "properties": {
            "position": vector3_schema(),
            "orientation": {
                "title": "foxglove.Quaternion", "type": "object",
                "properties": {
                    "x": {"type": "number"}, "y": {"type": "number"},
                    "z": {"type": "number"}, "w": {"type": "number"}
                },
                "required": ["x", "y", "z", "w"]
            }
        },
        "required": ["position", "orientation"]
    })
}

fn color_schema() -> Value {
    json!({
        "title": "foxglove.Color", "type": "object",
        "properties": {
            "r": {"type": "number"}, "g": {"type": "number"},
            "b": {"type": "number"}, "a": {"type": "number"}
        },
        "required": ["r", "g", "b", "a"]
    })
}

/// `foxglove.PoseInFrame`: a timestamped pose in a named frame.
pub fn pose_in_frame_schema() -> Value {
    json!({
        "title": "foxglove.PoseInFrame",
        "description": "A timestamped pose for an object or reference frame in 3D space",
        "type": "object",
        "properties": {"timestamp": time_schema(), "frame_id": {"type": "string"}, "pose": pose_schema()},
        "required": ["timestamp", "frame_id", "pose"]
    })
}

/// `foxglove.Log`: a log message with a level (1 debug … 5 fatal).
pub fn log_schema() -> Value {
    json!({
        "title": "foxglove.Log",
        "description": "A log message",
        "type": "object",
        "properties": {
            "timestamp": time_schema(),
            "level": {"title": "foxglove.LogLevel", "type": "integer", "minimum": 0, "maximum": 5},
            "message": {"type": "string"},
            "name": {"type": "string"},
            "file": {"type": "string"},
            "line": {"type": "integer", "minimum": 0}
        },
        "required": ["timestamp", "level", "message", "name", "file", "line"]
    })
}

/// `foxglove.SceneUpdate`: deletions, then entities made of cubes, spheres, lines and texts.
pub fn scene_update_schema() -> Value {
    let prim = |extra: Value| {
        let mut props = json!({"pose": pose_schema(), "color": color_schema()});
        if let (Some(p), Some(e)) = (props.as_object_mut(), extra.as_object()) {
            p.extend(e.clone());
        }
        json!({"type": "object", "properties": props})
    };
    let array = |items: Value| json!({"type": "array", "items": items});
    let entity = json!({
        "title": "foxglove.SceneEntity", "type": "object",
        "properties": {
            "timestamp": time_schema(),
            "frame_id": {"type": "string"},
            "id": {"type": "string"},
            "lifetime": {"type": "object", "title": "duration", "properties": {
                "sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
            "frame_locked": {"type": "boolean"},
            "metadata": array(json!({"type": "object", "properties": {
                "key": {"type": "string"}, "value": {"type": "string"}}})),
            "arrows": array(json!({"type": "object"})),
            "cubes": array(prim(json!({"size": vector3_schema()}))),
            "spheres": array(prim(json!({"size": vector3_schema()}))),
            "cylinders": array(json!({"type": "object"})),
            "lines": array(prim(json!({
                "type": {"type": "integer", "description": "0 line strip, 1 line loop, 2 line list"},
                "thickness": {"type": "number"},
                "scale_invariant": {"type": "boolean"},
                "points": array(vector3_schema()),
                "colors": array(color_schema()),
                "indices": array(json!({"type": "integer"}))
            }))),
            "triangles": array(json!({"type": "object"})),
            "texts": array(prim(json!({
                "billboard": {"type": "boolean"},
                "font_size": {"type": "number"},
                "scale_invariant": {"type": "boolean"},
                "text": {"type": "string"}
            }))),
            "models": array(json!({"type": "object"}))
        }
    });
    json!({
        "title": "foxglove.SceneUpdate",
        "description": "An update to the entities displayed in a 3D scene",
        "type": "object",
        "properties": {
            "deletions": array(json!({
                "title": "foxglove.SceneEntityDeletion", "type": "object",
                "properties": {
                    "timestamp": time_schema(),
                    "type": {"type": "integer", "description": "0 matching id, 1 all"},
                    "id": {"type": "string"}
                }
            })),
            "entities": array(entity)
        },
        "required": ["deletions", "entities"]
    })
}

/// A Foxglove `time` of `t` seconds (negative times clamp to 0).
pub fn time(t: f64) -> Value {
    let ns = nanos(t);
    json!({"sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000})
}

/// `t` seconds as whole nanoseconds (negative times clamp to 0).
pub fn nanos(t: f64) -> u64 {
    (t.max(0.0) * 1e9).round() as u64
}

/// A planar pose (x, y, yaw) at height `z` as a Foxglove `Pose`.
pub fn pose(x: f64, y: f64, z: f64, yaw: f64) -> Value {
    let (s, c) = (0.5 * yaw).sin_cos();
    json!({"position": {"x": x, "y": y, "z": z}, "orientation": {"x": 0.0, "y": 0.0, "z": s, "w": c}})
}

/// The yaw of a Foxglove `Pose` written by [`pose`] (rotation about z only).
pub fn yaw_of(pose: &Value) -> Option<f64> {
    let o = &pose["orientation"];
    Some(2.0 * o["z"].as_f64()?.atan2(o["w"].as_f64()?))
}

/// An RGBA colour (components 0–1) as a Foxglove `Color`.
pub fn color(rgba: [f64; 4]) -> Value {
    json!({"r": rgba[0], "g": rgba[1], "b": rgba[2], "a": rgba[3]})
}

/// A `foxglove.PoseInFrame` message in frame `world`.
pub fn pose_in_frame(t: f64, x: f64, y: f64, z: f64, yaw: f64) -> Value {
    json!({"timestamp": time(t), "frame_id": "world", "pose": pose(x, y, z, yaw)})
}

/// A `foxglove.Log` message from `name` at `level` (1 debug, 2 info, 3 warning, 4 error).
pub fn log(t: f64, level: u8, name: &str, message: &str) -> Value {
    json!({"timestamp": time(t), "level": level, "message": message, "name": name,
           "file": "", "line": 0})
}

/// An empty `foxglove.SceneEntity` with `id` in frame `world`, to be filled with primitives.
pub fn entity(t: f64, id: &str) -> Value {
    json!({
        "timestamp": time(t), "frame_id": "world", "id": id,
        "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": false, "metadata": [],
        "arrows": [], "cubes": [], "spheres": [], "cylinders": [], "lines": [],
        "triangles": [], "texts": [], "models": []
    })
}

/// A `foxglove.SceneUpdate` that replaces every entity of its topic with `entities`.
pub fn scene_update(t: f64, entities: Vec<Value>) -> Value {
    json!({"deletions": [{"timestamp": time(t), "type": 1, "id": ""}], "entities": entities})
}

/// Append a primitive to the list `kind` (`cubes`, `spheres`, `lines`, `texts`) of `entity`.
pub fn push(entity: &mut Value, kind: &str, primitive: Value) {
    if let Some(list) = entity[kind].as_array_mut() {
        list.push(primitive);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pose_keeps_its_yaw_and_times_split_into_seconds_and_nanoseconds() {
        for yaw in [-3.0, -1.0, 0.0, 0.5, 3.1] {
            let got = yaw_of(&pose(0.1, 0.2, 0.0, yaw)).unwrap();
            assert!((got - yaw).abs() < 1e-9, "{yaw} -> {got}");
        }
        assert_eq!(time(12.25), json!({"sec": 12, "nsec": 250_000_000}));
        assert_eq!(nanos(-1.0), 0);
    }
}
