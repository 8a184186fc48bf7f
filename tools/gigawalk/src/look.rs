//! `--aa`, `--edges`, `--ao`, `--sky`, `--edge-angle` and `--ao-radius`,
//! shared by `view` and `replay`: what the shown image adds to the
//! geometry drawn. Accuracy never sees it (it reads the frame as drawn);
//! replay runs its passes every frame, so the frame times show its cost.

use gigawalk_gpu::{Antialias, LookChoice};

/// On or off.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Switch {
    On,
    Off,
}

impl Switch {
    fn on(self) -> bool {
        self == Switch::On
    }
}

/// How the shown image is anti-aliased.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Aa {
    Off,
    /// A post-process over the finished image (FXAA)
    Fxaa,
}

#[derive(clap::Args, Clone, Debug, Default)]
pub struct LookArgs {
    /// Anti-aliasing of the shown image: fxaa (edges blended along their direction, after the frame is drawn) or off [default: view: fxaa on GPUs, off on CPU rasterizers such as lavapipe, where it costs more than it shows; replay: off]
    #[arg(long, value_enum)]
    aa: Option<Aa>,
    /// Edges: creases (surfaces meeting at more than --edge-angle) and silhouettes, drawn dark [default: view: on; replay: off]
    #[arg(long, value_enum)]
    edges: Option<Switch>,
    /// Screen-space ambient occlusion: corners and gaps darkened [default: view: on on GPUs, off on CPU rasterizers such as lavapipe, where it costs more than it shows; replay: off]
    #[arg(long, value_enum)]
    ao: Option<Switch>,
    /// A sky and ground gradient behind the model instead of a flat colour [default: view: on; replay: off]
    #[arg(long, value_enum)]
    sky: Option<Switch>,
    /// Edges: the angle between two surfaces, in degrees, above which their meeting is drawn as a crease
    #[arg(long, value_name = "DEGREES", default_value_t = 30.0)]
    edge_angle: f64,
    /// Ambient occlusion: how far a surface darkens its neighbours, in metres, and at most a tenth of the viewing distance (view: by --units; replay takes the model to be in metres)
    #[arg(long, value_name = "METRES", default_value_t = 0.5)]
    ao_radius: f64,
}

impl LookArgs {
    /// The look asked for, `metres` per model unit (for `--ao-radius`);
    /// what is not given is left to the command's default.
    pub fn choice(&self, metres: f64) -> anyhow::Result<LookChoice> {
        if !(self.edge_angle > 0.0 && self.edge_angle < 180.0) {
            anyhow::bail!(
                "--edge-angle {}: must be a number of degrees above 0 and below 180",
                self.edge_angle
            );
        }
        let radius = self.ao_radius / metres;
        if !(self.ao_radius > 0.0 && radius.is_finite() && radius < f32::MAX as f64) {
            anyhow::bail!(
                "--ao-radius {}: must be a finite number of metres above 0",
                self.ao_radius
            );
        }
        Ok(LookChoice {
            aa: self.aa.map(|a| match a {
                Aa::Off => Antialias::Off,
                Aa::Fxaa => Antialias::Fxaa,
            }),
            edges: self.edges.map(Switch::on),
            ao: self.ao.map(Switch::on),
            sky: self.sky.map(Switch::on),
            crease_degrees: Some(self.edge_angle as f32),
            ao_radius: Some(radius as f32),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gigawalk_gpu::Look;

    fn args(a: &[&str]) -> Result<LookArgs, clap::Error> {
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            look: LookArgs,
        }
        use clap::Parser;
        Cli::try_parse_from(std::iter::once("x").chain(a.iter().copied())).map(|c| c.look)
    }

    #[test]
    fn what_is_not_given_is_the_default_look() {
        let c = args(&[]).unwrap().choice(1.0).unwrap();
        assert_eq!(c.over(Look::PLAIN), Look::PLAIN);
        assert_eq!(c.over(Look::auto(false)), Look::auto(false));
        let c = args(&["--edges", "off", "--aa", "fxaa", "--ao", "on"])
            .unwrap()
            .choice(1.0)
            .unwrap();
        let l = c.over(Look::auto(true));
        assert!(!l.edges && l.ao && l.aa == Antialias::Fxaa && l.sky);
        let l = c.over(Look::PLAIN);
        assert!(!l.edges && l.ao && l.aa == Antialias::Fxaa && !l.sky);
    }

    #[test]
    fn the_radius_is_in_metres_and_the_angle_in_degrees() {
        let c = args(&["--ao-radius", "0.25", "--edge-angle", "45"])
            .unwrap()
            .choice(1e-3)
            .unwrap();
        let l = c.over(Look::PLAIN);
        assert!((l.ao_radius - 250.0).abs() < 1e-3);
        assert_eq!(l.crease_degrees, 45.0);
    }

    #[test]
    fn bad_values_name_the_flag() {
        for (flag, value) in [
            ("--edge-angle", "0"),
            ("--edge-angle", "180"),
            ("--edge-angle", "nan"),
            ("--ao-radius", "0"),
            ("--ao-radius", "-1"),
            ("--ao-radius", "inf"),
        ] {
            let e = args(&[&format!("{flag}={value}")])
                .unwrap()
                .choice(1.0)
                .unwrap_err();
            assert!(e.to_string().contains(flag), "{flag} {value}: {e}");
        }
        for (flag, value) in [("--aa", "msaa"), ("--edges", "yes"), ("--ao", "2")] {
            let e = args(&[flag, value]).expect_err("refused");
            assert!(e.to_string().contains(value), "{flag} {value}: {e}");
        }
    }
}
