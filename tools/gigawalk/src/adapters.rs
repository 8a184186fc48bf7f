//! `gigawalk info --adapters`: every GPU adapter wgpu sees on every backend,
//! whether it can run gigawalk and why not, and which one a run would use.

use gigawalk_runtime::{AdapterReport, Optional};

/// Prints the adapters as text, or as JSON with `json`; `adapter` is
/// `--adapter`'s name filter, for "would use".
pub fn print(json: bool, adapter: Option<&str>) -> anyhow::Result<()> {
    let reports = gigawalk_runtime::list_adapters();
    let chosen = gigawalk_runtime::chosen_adapter(adapter);
    if json {
        let list: Vec<serde_json::Value> = reports
            .iter()
            .map(|r| {
                serde_json::json!({
                    "name": r.info.name,
                    "backend": format!("{:?}", r.info.backend),
                    "type": format!("{:?}", r.info.device_type),
                    "driver": r.info.driver,
                    "driver_info": r.info.driver_info,
                    "usable": r.qualifies(),
                    "missing": r.missing,
                    "optional_missing": r.optional_missing.iter().map(|o| o.describe()).collect::<Vec<_>>(),
                    "query_counts": r.query_counts.map(|q| format!("{q:?}")),
                    "would_use": chosen.as_ref().is_ok_and(|c| *c == r.info),
                })
            })
            .collect();
        let v = serde_json::json!({
            "wgpu_backend": std::env::var("WGPU_BACKEND").ok(),
            "adapters": list,
            "error": chosen.as_ref().err().map(|e| e.to_string()),
        });
        out!("{}", serde_json::to_string_pretty(&v)?)?;
        return Ok(());
    }
    match std::env::var("WGPU_BACKEND") {
        Ok(b) => out!("backends    WGPU_BACKEND={b}")?,
        Err(_) => out!(
            "backends    all listed; a run tries Vulkan, Metal and DX12 first, GL when they have no usable adapter (WGPU_BACKEND=vulkan|gl|metal|dx12 picks)"
        )?,
    }
    if reports.is_empty() {
        out!("adapters    none")?;
    }
    for r in &reports {
        print_one(r, chosen.as_ref().is_ok_and(|c| *c == r.info))?;
    }
    match chosen {
        Ok(c) => out!("would use   {} ({:?})", c.name, c.backend)?,
        Err(e) => out!("would use   none: {e}")?,
    }
    Ok(())
}

fn print_one(r: &AdapterReport, chosen: bool) -> anyhow::Result<()> {
    let i = &r.info;
    out!(
        "adapter     {}{}",
        r.name(),
        if chosen { "  <- a run uses this" } else { "" }
    )?;
    let driver = [i.driver.as_str(), i.driver_info.as_str()]
        .iter()
        .filter(|s| !s.is_empty())
        .copied()
        .collect::<Vec<_>>()
        .join(", ");
    if !driver.is_empty() {
        out!("  driver    {driver}")?;
    }
    if r.qualifies() {
        out!("  usable    yes")?;
    } else {
        out!("  usable    no: lacks {}", r.missing.join("; "))?;
    }
    match r.query_counts {
        Some(gigawalk_runtime::QueryCounts::Exact) => {
            out!("  queries   occlusion queries count samples")?
        }
        Some(gigawalk_runtime::QueryCounts::Boolean) => out!(
            "  queries   occlusion queries say only zero or not (oq runs; --oq-adaptive refuses)"
        )?,
        None => {}
    }
    for o in &r.optional_missing {
        out!("  note      {}{}", o.describe(), consequence(*o))?;
    }
    Ok(())
}

/// What an optional capability's absence means for the user.
fn consequence(o: Optional) -> &'static str {
    match o {
        Optional::DepthCopies => " (same images, one extra pass a read-back)",
        Optional::Wireframe => " (the viewer's --wireframe refuses, T draws shaded)",
        Optional::IndexRange => " (a scene with a larger LOD is refused when loaded)",
        Optional::ClipDistances => " (same images)",
        Optional::ComputePyramid => " (same HZB, more passes)",
        Optional::MultiDraw => " (same images, more CPU a draw)",
        Optional::BaseVertex => " (same images, a vertex-buffer bind a draw)",
        Optional::SharedBuffers => " (the streaming pool split half and half)",
    }
}
