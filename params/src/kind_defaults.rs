//! Reading a robot's parameters over its own kind's defaults. A field left out of a pilot's
//! table (`[pilot.plant]`, a calibrated pilot's file) keeps the pilot's default: four wheels,
//! its mass, its drive mapping. The derived `serde(default)` would fill it from
//! `RobotParams::default()`, the non-pilot's, and silently turn the pilot into one.

use crate::{rates::Rates, FleetParams, RobotKind, RobotParams};
use serde::de::Error as _;
use serde::{Deserialize, Deserializer};

/// `table` laid over the defaults of a robot of `kind`, table by table. The error names the
/// table of the field that is wrong (`coupling: unknown field ...`).
pub fn robot_over_defaults(kind: RobotKind, table: toml::Table) -> Result<RobotParams, String> {
    let over = |t: toml::Table| -> Result<RobotParams, String> {
        let mut base =
            toml::Value::try_from(RobotParams::for_kind(kind)).map_err(|e| e.to_string())?;
        overlay(&mut base, toml::Value::Table(t));
        base.try_into()
            .map_err(|e: toml::de::Error| e.message().trim().to_string())
    };
    over(table.clone()).map_err(|e| {
        // The first entry that fails alone names where.
        table
            .iter()
            .find_map(|(k, v)| {
                let one = toml::Table::from_iter([(k.clone(), v.clone())]);
                over(one).err().map(|e| format!("{k}: {e}"))
            })
            .unwrap_or(e)
    })
}

/// Lay `top` over `base`: tables merge key by key, anything else replaces.
fn overlay(base: &mut toml::Value, top: toml::Value) {
    match (base, top) {
        (toml::Value::Table(b), toml::Value::Table(t)) => {
            for (k, v) in t {
                match b.get_mut(&k) {
                    Some(slot) => overlay(slot, v),
                    None => {
                        b.insert(k, v);
                    }
                }
            }
        }
        (slot, v) => *slot = v,
    }
}

/// The fields of a fleet parameter file as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Written {
    #[serde(default)]
    pilot: Option<toml::Table>,
    #[serde(default)]
    non_pilot: Option<toml::Table>,
    #[serde(default)]
    rates: Rates,
}

impl<'de> Deserialize<'de> for FleetParams {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let w = Written::deserialize(d)?;
        let robot = |name: &str, kind: RobotKind, t: Option<toml::Table>| match t {
            None => Ok(RobotParams::for_kind(kind)),
            Some(t) => {
                robot_over_defaults(kind, t).map_err(|e| D::Error::custom(format!("{name}: {e}")))
            }
        };
        Ok(FleetParams {
            pilot: robot("pilot", RobotKind::Pilot, w.pilot)?,
            non_pilot: robot("non_pilot", RobotKind::NonPilot, w.non_pilot)?,
            rates: w.rates,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_partial_pilot_table_keeps_the_pilot_defaults() {
        let p: FleetParams =
            toml::from_str("[pilot.coupling]\nknob_hold_force = 6.4\n[pilot.plant]\n").unwrap();
        let pilot = RobotParams::for_kind(RobotKind::Pilot);
        assert_eq!(p.pilot.coupling.knob_hold_force, 6.4);
        assert_eq!(p.pilot.plant, pilot.plant);
        assert!(p.pilot.plant.four_wheels);
        assert_eq!(p.pilot.mass, pilot.mass);
        assert_eq!(p.pilot.drive, pilot.drive);
        assert_eq!(p.non_pilot, FleetParams::default().non_pilot);
    }

    #[test]
    fn a_robot_file_lies_over_its_kinds_defaults() {
        let t: toml::Table = toml::from_str("[drive]\nk_v = 0.003\n").unwrap();
        let p = robot_over_defaults(RobotKind::Pilot, t).unwrap();
        assert_eq!(p.drive.k_v, 0.003);
        assert!(p.plant.four_wheels);
        let t: toml::Table = toml::from_str("[coupling]\nknob_hold = 1.0\n").unwrap();
        let e = robot_over_defaults(RobotKind::Pilot, t).unwrap_err();
        assert!(e.starts_with("coupling: unknown field `knob_hold`"), "{e}");
    }

    #[test]
    fn fleet_parameters_survive_a_round_trip_through_toml() {
        let mut p = FleetParams::default();
        p.pilot.coupling.knob_hold_force = 5.0;
        let back: FleetParams = toml::from_str(&toml::to_string(&p).unwrap()).unwrap();
        assert_eq!(back, p);
    }
}
