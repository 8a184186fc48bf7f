//! Colours: IfcStyledItem on a representation item (IfcSurfaceStyle ->
//! IfcSurfaceStyleRendering/Shading colour and transparency), else the
//! product's material's styled representation, else a default per class;
//! all as linear RGBA.

use std::collections::HashMap;

use crate::step::{StepFile, Value};

/// sRGB (what IFC colours are, 0..1) to linear, as glTF's base colour.
pub fn linear(c: [f64; 3]) -> [f32; 3] {
    c.map(|v| {
        let v = v.clamp(0.0, 1.0);
        (if v <= 0.04045 {
            v / 12.92
        } else {
            ((v + 0.055) / 1.055).powf(2.4)
        }) as f32
    })
}

/// Styles read once per file.
#[derive(Default)]
pub struct Styles {
    /// Representation item -> its styled colour.
    pub item: HashMap<u32, [f32; 4]>,
    /// Product -> its material's colour.
    pub product: HashMap<u32, [f32; 4]>,
}

impl Styles {
    pub fn new(step: &StepFile) -> Styles {
        let mut s = Styles::default();
        for id in step.ids_of_type("IFCSTYLEDITEM") {
            let Ok(e) = step.get(id) else { continue };
            let (Some(item), Some(c)) = (e.opt_ref(0), styles_colour(step, e.arg(1), 0)) else {
                continue;
            };
            s.item.insert(item, c);
        }
        // Material -> colour, from its styled representation.
        let mut material: HashMap<u32, [f32; 4]> = HashMap::new();
        for id in step.ids_of_type("IFCMATERIALDEFINITIONREPRESENTATION") {
            let Ok(e) = step.get(id) else { continue };
            let Some(m) = e.opt_ref(3) else { continue };
            for r in e.refs(2).unwrap_or_default() {
                let Ok(rep) = step.get(r) else { continue };
                for item in rep.refs(3).unwrap_or_default() {
                    let Ok(si) = step.get(item) else { continue };
                    if si.ty != "IFCSTYLEDITEM" {
                        continue;
                    }
                    if let Some(c) = styles_colour(step, si.arg(1), 0) {
                        material.entry(m).or_insert(c);
                    }
                }
            }
        }
        if material.is_empty() {
            return s;
        }
        for id in step.ids_of_type("IFCRELASSOCIATESMATERIAL") {
            let Ok(e) = step.get(id) else { continue };
            let Some(m) = e.opt_ref(5).and_then(|m| first_material(step, m, 0)) else {
                continue;
            };
            let Some(&c) = material.get(&m) else { continue };
            for p in e.refs(4).unwrap_or_default() {
                s.product.entry(p).or_insert(c);
            }
        }
        s
    }
}

/// The first IfcMaterial of a material select (layer sets, lists,
/// constituents, profiles, and their usages).
fn first_material(step: &StepFile, id: u32, depth: usize) -> Option<u32> {
    if depth > 8 {
        return None;
    }
    let e = step.get(id).ok()?;
    let next = match e.ty {
        "IFCMATERIAL" => return Some(id),
        "IFCMATERIALLAYERSETUSAGE" | "IFCMATERIALPROFILESETUSAGE" => e.opt_ref(0)?,
        "IFCMATERIALLAYERSET" | "IFCMATERIALLIST" => *e.refs(0).ok()?.first()?,
        "IFCMATERIALLAYER" => e.opt_ref(0)?,
        "IFCMATERIALCONSTITUENTSET" | "IFCMATERIALPROFILESET" => *e.refs(2).ok()?.first()?,
        "IFCMATERIALCONSTITUENT" | "IFCMATERIALPROFILE" => e.opt_ref(2)?,
        _ => return None,
    };
    first_material(step, next, depth + 1)
}

/// The surface colour a list of styles (or one style) gives.
fn styles_colour(step: &StepFile, v: &Value, depth: usize) -> Option<[f32; 4]> {
    if depth > 8 {
        return None;
    }
    match v {
        Value::List(l) => l.iter().find_map(|s| styles_colour(step, s, depth + 1)),
        Value::Ref(r) => {
            let e = step.get(*r).ok()?;
            match e.ty {
                "IFCPRESENTATIONSTYLEASSIGNMENT" => styles_colour(step, e.arg(0), depth + 1),
                "IFCSURFACESTYLE" => styles_colour(step, e.arg(2), depth + 1),
                "IFCSURFACESTYLERENDERING" | "IFCSURFACESTYLESHADING" => {
                    let rgb = colour_rgb(step, e.opt_ref(0)?)?;
                    let t = e.opt_real(1).unwrap_or(0.0).clamp(0.0, 1.0) as f32;
                    let [r, g, b] = linear(rgb);
                    Some([r, g, b, 1.0 - t])
                }
                _ => None,
            }
        }
        _ => None,
    }
}

/// An IfcColourRgb's components.
pub fn colour_rgb(step: &StepFile, id: u32) -> Option<[f64; 3]> {
    let e = step.get(id).ok()?;
    if e.ty != "IFCCOLOURRGB" {
        return None;
    }
    Some([e.opt_real(1)?, e.opt_real(2)?, e.opt_real(3)?])
}

/// A product's colour when neither its items nor its material have one
/// (sRGB, as a viewer shows classes apart: grey walls, light slabs,
/// blue-ish translucent windows).
pub fn class_default(ty: &str) -> [f32; 4] {
    let (rgb, a) = match ty {
        "IFCWINDOW" | "IFCWINDOWSTANDARDCASE" | "IFCPLATE" | "IFCCURTAINWALL" => {
            ([0.55, 0.7, 0.85], 0.4)
        }
        "IFCSLAB" | "IFCSLABSTANDARDCASE" | "IFCCOVERING" | "IFCROOF" => ([0.85, 0.84, 0.8], 1.0),
        "IFCDOOR" | "IFCDOORSTANDARDCASE" | "IFCFURNISHINGELEMENT" | "IFCFURNITURE" => {
            ([0.6, 0.45, 0.3], 1.0)
        }
        "IFCBEAM" | "IFCCOLUMN" | "IFCMEMBER" | "IFCRAILING" | "IFCSTAIR" | "IFCSTAIRFLIGHT" => {
            ([0.55, 0.55, 0.6], 1.0)
        }
        "IFCSITE" => ([0.45, 0.6, 0.35], 1.0),
        t if t.starts_with("IFCFLOW") || t.contains("SEGMENT") || t.contains("FITTING") => {
            ([0.3, 0.5, 0.7], 1.0)
        }
        _ => ([0.7, 0.7, 0.7], 1.0),
    };
    let [r, g, b] = linear(rgb);
    [r, g, b, a]
}
