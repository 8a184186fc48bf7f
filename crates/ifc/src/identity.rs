//! Who a product is: its place in the spatial structure (IfcRelAggregates,
//! IfcRelContainedInSpatialStructure), its property sets and quantities
//! (IfcRelDefinesByProperties, its type's through IfcRelDefinesByType),
//! as a name, a path and compact JSON.

use std::collections::HashMap;

use serde_json::{Map, Value as J};

use crate::classes::camel;
use crate::step::{Entity, StepFile};

/// Relationships read once per file.
#[derive(Default)]
pub struct Relations {
    /// Object -> what aggregates or contains it.
    pub parent: HashMap<u32, u32>,
    /// Object -> its property definitions (sets and quantities).
    pub properties: HashMap<u32, Vec<u32>>,
    /// Object -> its type object.
    pub type_of: HashMap<u32, u32>,
    /// Element -> its openings (IfcRelVoidsElement).
    pub voids: HashMap<u32, Vec<u32>>,
}

impl Relations {
    pub fn new(step: &StepFile) -> Relations {
        let mut r = Relations::default();
        let rel = |ty: &str, f: &mut dyn FnMut(Entity)| {
            for id in step.ids_of_type(ty) {
                if let Ok(e) = step.get(id) {
                    f(e);
                }
            }
        };
        rel("IFCRELAGGREGATES", &mut |e| {
            // IFC4 also has IfcRelNests for parts; aggregation is the tree.
            if let Some(p) = e.opt_ref(4) {
                for c in e.refs(5).unwrap_or_default() {
                    r.parent.entry(c).or_insert(p);
                }
            }
        });
        rel("IFCRELCONTAINEDINSPATIALSTRUCTURE", &mut |e| {
            if let Some(p) = e.opt_ref(5) {
                for c in e.refs(4).unwrap_or_default() {
                    r.parent.entry(c).or_insert(p);
                }
            }
        });
        rel("IFCRELDEFINESBYPROPERTIES", &mut |e| {
            if let Some(p) = e.opt_ref(5) {
                for c in e.refs(4).unwrap_or_default() {
                    r.properties.entry(c).or_default().push(p);
                }
            }
        });
        rel("IFCRELDEFINESBYTYPE", &mut |e| {
            if let Some(t) = e.opt_ref(5) {
                for c in e.refs(4).unwrap_or_default() {
                    r.type_of.insert(c, t);
                }
            }
        });
        rel("IFCRELVOIDSELEMENT", &mut |e| {
            if let (Some(w), Some(o)) = (e.opt_ref(4), e.opt_ref(5)) {
                r.voids.entry(w).or_default().push(o);
            }
        });
        r
    }
}

/// A product's identity fields.
pub struct Who {
    pub name: String,
    pub path: String,
    pub class: String,
    pub global_id: String,
    pub storey: Option<String>,
    pub extras: String,
}

/// The name of an object (Name, else LongName for spatial elements) or
/// its class and GlobalId.
fn label(e: &Entity) -> String {
    match e.opt_str(2).filter(|s| !s.trim().is_empty()) {
        Some(n) => n.to_string(),
        None => format!("{} {}", camel(e.ty), e.opt_str(0).unwrap_or_default()),
    }
}

/// Product `e`'s identity.
pub fn who(step: &StepFile, rel: &Relations, e: &Entity) -> Who {
    let class = camel(e.ty);
    let global_id = e.opt_str(0).unwrap_or_default().to_string();
    let name = label(e);
    let mut chain = Vec::new();
    let mut storey = None;
    let mut at = rel.parent.get(&e.id).copied();
    while let Some(p) = at {
        if chain.len() > 64 {
            break;
        }
        let Ok(pe) = step.get(p) else { break };
        if pe.ty == "IFCBUILDINGSTOREY" && storey.is_none() {
            storey = Some(label(&pe));
        }
        chain.push(label(&pe));
        at = rel.parent.get(&p).copied();
    }
    chain.reverse();
    // The class and GlobalId end the path, so `find` matches either.
    chain.push(format!("{class} {global_id}"));
    let path = chain.join("/");

    let mut psets = Map::new();
    let mut quantities = Map::new();
    let mut type_name = None;
    if let Some(&t) = rel.type_of.get(&e.id) {
        if let Ok(te) = step.get(t) {
            type_name = Some(format!("{} {}", camel(te.ty), label(&te)));
            for p in te.refs(5).unwrap_or_default() {
                read_definition(step, p, &mut psets, &mut quantities);
            }
        }
    }
    for &p in rel.properties.get(&e.id).into_iter().flatten() {
        read_definition(step, p, &mut psets, &mut quantities);
    }
    let mut extras = Map::new();
    extras.insert("ifc_class".into(), J::String(class.clone()));
    extras.insert("GlobalId".into(), J::String(global_id.clone()));
    extras.insert("entity".into(), J::String(format!("#{}", e.id)));
    extras.insert("storey".into(), storey.clone().map_or(J::Null, J::String));
    if let Some(t) = type_name {
        extras.insert("type".into(), J::String(t));
    }
    if let Some(o) = e.opt_str(4).filter(|s| !s.is_empty()) {
        extras.insert("ObjectType".into(), J::String(o.into()));
    }
    extras.insert("psets".into(), J::Object(psets));
    extras.insert("quantities".into(), J::Object(quantities));
    Who {
        name,
        path,
        class,
        global_id,
        storey,
        extras: J::Object(extras).to_string(),
    }
}

/// Adds an IfcPropertySet's single and enumerated values, or an
/// IfcElementQuantity's quantities, under the set's name.
fn read_definition(step: &StepFile, id: u32, psets: &mut Map<String, J>, qs: &mut Map<String, J>) {
    let Ok(e) = step.get(id) else { return };
    let set_name = e.opt_str(2).unwrap_or("(unnamed)").to_string();
    match e.ty {
        "IFCPROPERTYSET" => {
            let mut props = Map::new();
            for p in e.refs(4).unwrap_or_default() {
                let Ok(pe) = step.get(p) else { continue };
                let Some(name) = pe.opt_str(0) else { continue };
                let v = match pe.ty {
                    "IFCPROPERTYSINGLEVALUE" => pe.arg(2).to_json(),
                    "IFCPROPERTYENUMERATEDVALUE" | "IFCPROPERTYLISTVALUE" => pe.arg(2).to_json(),
                    _ => continue,
                };
                props.insert(name.to_string(), v);
            }
            let entry = psets
                .entry(set_name)
                .or_insert_with(|| J::Object(Map::new()));
            if let J::Object(m) = entry {
                m.extend(props);
            }
        }
        "IFCELEMENTQUANTITY" => {
            let mut props = Map::new();
            for q in e.refs(5).unwrap_or_default() {
                let Ok(qe) = step.get(q) else { continue };
                let Some(name) = qe.opt_str(0) else { continue };
                if qe.ty.starts_with("IFCQUANTITY") {
                    props.insert(name.to_string(), qe.arg(3).to_json());
                }
            }
            let entry = qs.entry(set_name).or_insert_with(|| J::Object(Map::new()));
            if let J::Object(m) = entry {
                m.extend(props);
            }
        }
        _ => {}
    }
}
