//! Where the tileset sits on the Earth: nowhere (local coordinates, the
//! default), at a longitude, latitude and height on the WGS84 ellipsoid,
//! or by a transform the user gives. And the fixed turn from the scene's
//! y-up axes to 3D Tiles' z-up ones.

use glam::{DMat4, DVec3, DVec4};

/// How the model is placed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Georef {
    /// Model units in a local frame: x east, y up, -z north, the model's
    /// own origin at the tileset's origin (for a globe client, the centre
    /// of the Earth).
    Local,
    /// The model's origin at this point of the WGS84 ellipsoid (degrees,
    /// degrees, metres above the ellipsoid), x east, y up, -z north; the
    /// model's units are taken as metres.
    Origin { lon: f64, lat: f64, height: f64 },
    /// This column-major 4x4 matrix maps the model's z-up frame (x, -z, y
    /// of its own axes) to the tileset's (e.g. ECEF).
    Transform([f64; 16]),
}

/// WGS84: semi-major axis (m) and flattening.
const WGS84_A: f64 = 6_378_137.0;
const WGS84_F: f64 = 1.0 / 298.257_223_563;

impl Georef {
    /// `LON,LAT,HEIGHT` in degrees and metres.
    pub fn parse_origin(s: &str) -> Result<Georef, String> {
        let v = numbers(s, 3, "LON,LAT,HEIGHT")?;
        let (lon, lat, height) = (v[0], v[1], v[2]);
        if !(-180.0..=180.0).contains(&lon) {
            return Err(format!("longitude {lon} is outside -180..180 degrees"));
        }
        if !(-90.0..=90.0).contains(&lat) {
            return Err(format!("latitude {lat} is outside -90..90 degrees"));
        }
        Ok(Georef::Origin { lon, lat, height })
    }

    /// 16 numbers, column-major, comma- or space-separated; the last row
    /// must be 0 0 0 1 and the 3x3 part invertible.
    pub fn parse_transform(s: &str) -> Result<Georef, String> {
        let v = numbers(s, 16, "16 numbers of a column-major 4x4 matrix")?;
        let mut m = [0.0; 16];
        m.copy_from_slice(&v);
        if m[3] != 0.0 || m[7] != 0.0 || m[11] != 0.0 || m[15] != 1.0 {
            return Err("the matrix's last row (numbers 4, 8, 12 and 16) must be 0 0 0 1".into());
        }
        let d = DMat4::from_cols_array(&m).determinant();
        if !d.is_finite() || d == 0.0 {
            return Err("the matrix cannot be inverted (determinant 0)".into());
        }
        Ok(Georef::Transform(m))
    }

    /// The frame the z-up model coordinates are placed in.
    pub fn frame(&self) -> DMat4 {
        match *self {
            Georef::Local => DMat4::IDENTITY,
            Georef::Transform(m) => DMat4::from_cols_array(&m),
            Georef::Origin { lon, lat, height } => enu_to_ecef(lon, lat, height),
        }
    }
}

fn numbers(s: &str, n: usize, what: &str) -> Result<Vec<f64>, String> {
    let parts: Vec<&str> = s
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|p| !p.is_empty())
        .collect();
    if parts.len() != n {
        return Err(format!(
            "{s:?}: expected {what}, found {} number(s)",
            parts.len()
        ));
    }
    parts
        .iter()
        .map(|p| match p.parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            _ => Err(format!("{s:?}: {p:?} is not a finite number")),
        })
        .collect()
}

/// The east-north-up frame at a WGS84 point, as a matrix to ECEF
/// (columns: east, north, up, the point).
pub fn enu_to_ecef(lon_deg: f64, lat_deg: f64, height: f64) -> DMat4 {
    let (lon, lat) = (lon_deg.to_radians(), lat_deg.to_radians());
    let e2 = WGS84_F * (2.0 - WGS84_F);
    let n = WGS84_A / (1.0 - e2 * lat.sin().powi(2)).sqrt();
    let p = DVec3::new(
        (n + height) * lat.cos() * lon.cos(),
        (n + height) * lat.cos() * lon.sin(),
        (n * (1.0 - e2) + height) * lat.sin(),
    );
    let east = DVec3::new(-lon.sin(), lon.cos(), 0.0);
    let north = DVec3::new(-lat.sin() * lon.cos(), -lat.sin() * lon.sin(), lat.cos());
    let up = DVec3::new(lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin());
    DMat4::from_cols(
        east.extend(0.0),
        north.extend(0.0),
        up.extend(0.0),
        DVec4::new(p.x, p.y, p.z, 1.0),
    )
}

/// A scene point (y up) in 3D Tiles' z-up axes: glTF content is turned
/// the same way by every client (x, y, z -> x, -z, y).
pub fn z_up(p: DVec3) -> DVec3 {
    DVec3::new(p.x, -p.z, p.y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_equator_at_greenwich_is_on_the_x_axis() {
        let m = enu_to_ecef(0.0, 0.0, 0.0);
        let p = m.transform_point3(DVec3::ZERO);
        assert!((p - DVec3::new(WGS84_A, 0.0, 0.0)).length() < 1e-6);
        // Up is +x there, east +y, north +z.
        assert!((m.transform_vector3(DVec3::Z) - DVec3::X).length() < 1e-12);
        assert!((m.transform_vector3(DVec3::X) - DVec3::Y).length() < 1e-12);
    }

    #[test]
    fn the_pole_is_at_the_semi_minor_axis() {
        let p = enu_to_ecef(0.0, 90.0, 10.0).transform_point3(DVec3::ZERO);
        let b = WGS84_A * (1.0 - WGS84_F);
        assert!((p.z - (b + 10.0)).abs() < 1e-6 && p.x.abs() < 1e-6);
    }

    #[test]
    fn bad_origins_and_transforms_say_what_is_wrong() {
        assert!(Georef::parse_origin("1,2").unwrap_err().contains("found 2"));
        assert!(Georef::parse_origin("1,91,0")
            .unwrap_err()
            .contains("latitude"));
        assert!(Georef::parse_origin("1,x,0")
            .unwrap_err()
            .contains("not a finite"));
        assert!(Georef::parse_origin("200,0,0")
            .unwrap_err()
            .contains("longitude"));
        assert_eq!(
            Georef::parse_origin("7.5, 47, 400").unwrap(),
            Georef::Origin {
                lon: 7.5,
                lat: 47.0,
                height: 400.0
            }
        );
        let id = "1 0 0 0 0 1 0 0 0 0 1 0 5 6 7 1";
        assert!(matches!(
            Georef::parse_transform(id),
            Ok(Georef::Transform(_))
        ));
        assert!(Georef::parse_transform("0 0 0 0 0 1 0 0 0 0 1 0 5 6 7 1")
            .unwrap_err()
            .contains("inverted"));
        assert!(Georef::parse_transform("1 0 0 1 0 1 0 0 0 0 1 0 5 6 7 1")
            .unwrap_err()
            .contains("last row"));
    }
}
