//! The project's units (IfcUnitAssignment): metres per length unit (SI
//! prefixes, conversion-based units such as inch and foot) and radians
//! per plane angle unit.

use crate::step::{Entity, StepFile};

/// Metres per length unit and radians per plane angle unit of `project`
/// (an IfcProject); metres and radians where the file says nothing.
pub fn units(step: &StepFile, project: &Entity) -> (f64, f64) {
    let mut length = 1.0;
    let mut angle = 1.0;
    let Some(assignment) = project.opt_ref(8).and_then(|u| step.get(u).ok()) else {
        return (length, angle);
    };
    for u in assignment.refs(0).unwrap_or_default() {
        let Ok(e) = step.get(u) else { continue };
        let kind = match e.ty {
            "IFCSIUNIT" => e.arg(1).as_enum(),
            "IFCCONVERSIONBASEDUNIT" | "IFCCONVERSIONBASEDUNITWITHOFFSET" => e.arg(1).as_enum(),
            _ => None,
        };
        let factor = unit_factor(step, &e, 0);
        match (kind, factor) {
            (Some("LENGTHUNIT"), Some(f)) => length = f,
            (Some("PLANEANGLEUNIT"), Some(f)) => angle = f,
            _ => {}
        }
    }
    (length, angle)
}

/// SI base units per this unit.
fn unit_factor(step: &StepFile, e: &Entity, depth: usize) -> Option<f64> {
    if depth > 8 {
        return None;
    }
    match e.ty {
        // IfcSIUnit(Dimensions, UnitType, Prefix, Name)
        "IFCSIUNIT" => Some(prefix(e.arg(2).as_enum())),
        // IfcConversionBasedUnit(Dimensions, UnitType, Name,
        // ConversionFactor: IfcMeasureWithUnit(ValueComponent, UnitComponent))
        "IFCCONVERSIONBASEDUNIT" | "IFCCONVERSIONBASEDUNITWITHOFFSET" => {
            let m = step.get(e.opt_ref(3)?).ok()?;
            let value = m.arg(0).as_f64()?;
            let base = step.get(m.opt_ref(1)?).ok()?;
            let f = value * unit_factor(step, &base, depth + 1)?;
            (f.is_finite() && f > 0.0).then_some(f)
        }
        _ => None,
    }
}

fn prefix(p: Option<&str>) -> f64 {
    match p {
        Some("EXA") => 1e18,
        Some("PETA") => 1e15,
        Some("TERA") => 1e12,
        Some("GIGA") => 1e9,
        Some("MEGA") => 1e6,
        Some("KILO") => 1e3,
        Some("HECTO") => 1e2,
        Some("DECA") => 1e1,
        Some("DECI") => 1e-1,
        Some("CENTI") => 1e-2,
        Some("MILLI") => 1e-3,
        Some("MICRO") => 1e-6,
        Some("NANO") => 1e-9,
        Some("PICO") => 1e-12,
        Some("FEMTO") => 1e-15,
        Some("ATTO") => 1e-18,
        _ => 1.0,
    }
}
