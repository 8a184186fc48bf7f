//! Model units, for measurements reported in metres too: glTF models are
//! in metres by the specification, CAD exports often in millimetres or
//! inches, and OBJ says nothing.

/// A length unit of the model's coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Units {
    /// Its symbol as given (`m`, `mm`, `in`, ...).
    pub name: &'static str,
    /// Metres per model unit.
    pub metres: f64,
}

/// The units `--units` takes.
pub const UNITS: [Units; 8] = [
    Units {
        name: "m",
        metres: 1.0,
    },
    Units {
        name: "mm",
        metres: 1e-3,
    },
    Units {
        name: "cm",
        metres: 1e-2,
    },
    Units {
        name: "km",
        metres: 1e3,
    },
    Units {
        name: "um",
        metres: 1e-6,
    },
    Units {
        name: "in",
        metres: 0.0254,
    },
    Units {
        name: "ft",
        metres: 0.3048,
    },
    Units {
        name: "yd",
        metres: 0.9144,
    },
];

impl Default for Units {
    /// Metres, glTF's unit.
    fn default() -> Self {
        UNITS[0]
    }
}

impl std::str::FromStr for Units {
    type Err = String;

    fn from_str(s: &str) -> Result<Units, String> {
        let t = s.trim().to_ascii_lowercase();
        let t = match t.as_str() {
            "metre" | "metres" | "meter" | "meters" => "m",
            "millimetre" | "millimetres" | "millimeter" | "millimeters" => "mm",
            "centimetre" | "centimetres" | "centimeter" | "centimeters" => "cm",
            "inch" | "inches" => "in",
            "foot" | "feet" => "ft",
            "µm" | "micrometre" | "micrometer" => "um",
            other => other,
        };
        UNITS.iter().find(|u| u.name == t).copied().ok_or_else(|| {
            let names: Vec<&str> = UNITS.iter().map(|u| u.name).collect();
            format!("unknown unit {s:?}: use one of {}", names.join(", "))
        })
    }
}

impl Units {
    /// A length in model units, as "1234.5 mm (1.2345 m)" (metres
    /// alone when the model is in metres).
    pub fn format(&self, length: f64) -> String {
        if self.metres == 1.0 {
            format!("{} m", significant(length))
        } else {
            format!(
                "{} {} ({} m)",
                significant(length),
                self.name,
                significant(length * self.metres)
            )
        }
    }
}

/// Six significant digits, without trailing zeros.
fn significant(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (6 - 1 - v.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_parse_and_format() {
        let mm: Units = "mm".parse().unwrap();
        assert_eq!(mm.metres, 1e-3);
        assert_eq!(mm.format(1234.5), "1234.5 mm (1.2345 m)");
        assert_eq!("Inches".parse::<Units>().unwrap().name, "in");
        assert_eq!(Units::default().format(2.5), "2.5 m");
        assert_eq!(Units::default().format(0.000123456789), "0.000123457 m");
        let e = "parsec".parse::<Units>().unwrap_err();
        assert!(e.contains("unknown unit \"parsec\"") && e.contains("mm"));
    }
}
