//! `--section` and `--section-box`, shared by `replay`, `view` and
//! `pick`.

use std::sync::Arc;

use gigawalk_scene::section::{Section, SectionSpec};
use gigawalk_scene::Aabb;

#[derive(clap::Args, Clone, Debug, Default)]
pub struct SectionArgs {
    /// Cut the model by a plane "NX NY NZ D": keeps the points p with
    /// n·p + D >= 0, so the normal points into what is kept (e.g.
    /// "0 0 -1 5" keeps z <= 5); repeatable, up to 6. What is cut away is
    /// neither drawn nor hides anything, and cut solids show their cut face
    #[arg(
        long = "section",
        value_name = "\"NX NY NZ D\"",
        allow_hyphen_values = true
    )]
    pub planes: Vec<String>,
    /// Keep only what lies inside the box "X0 Y0 Z0 X1 Y1 Z1" (its min and
    /// max corners, model units), with any --section planes
    #[arg(long, value_name = "\"X0 Y0 Z0 X1 Y1 Z1\"", allow_hyphen_values = true)]
    pub section_box: Option<String>,
}

impl SectionArgs {
    /// The section these flags give on their own, or none when neither
    /// flag is given. The viewer takes this one, since it weighs a saved
    /// view's section (and warns about one that keeps nothing) itself.
    pub fn given(&self) -> anyhow::Result<Option<Section>> {
        if self.planes.is_empty() && self.section_box.is_none() {
            return Ok(None);
        }
        Ok(Some(Section::parse(
            &self.planes,
            self.section_box.as_deref(),
        )?))
    }

    /// The section these flags give, else the saved view's, else none. A
    /// section that keeps nothing of `bounds` (the scene's) is allowed,
    /// with a warning: every frame is then empty.
    pub fn section(
        &self,
        view: Option<&SectionSpec>,
        bounds: &Aabb,
    ) -> anyhow::Result<Option<Arc<Section>>> {
        let section = if let Some(given) = self.given()? {
            given
        } else if let Some(spec) = view {
            Section::new(spec.clone())
                .map_err(|e| anyhow::anyhow!("the saved view's section: {e}"))?
        } else {
            return Ok(None);
        };
        if section.is_empty() {
            return Ok(None);
        }
        if !section.keeps_any_of(bounds) {
            eprintln!(
                "warning: the section ({}) keeps nothing of the model, whose bounds are \
                 {:.6?} .. {:.6?}: every frame is empty",
                section.describe(),
                bounds.min.to_array(),
                bounds.max.to_array()
            );
        }
        Ok(Some(Arc::new(section)))
    }
}
