//! The subcommands of the `ember` binary, one module each, and the flag parsers they
//! share.

pub mod bench;
pub mod misc;
pub mod render;

use glam::Vec3;

/// A positive number of seconds (checkpoint intervals).
pub fn parse_seconds(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number of seconds"))?;
    if v > 0.0 && v <= 1e9 {
        Ok(v)
    } else {
        Err(format!("{v} is not a positive number of seconds"))
    }
}

/// `X,Y,Z`: three finite numbers.
pub fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [x, y, z] = parts.as_slice() else {
        return Err(format!("expected three numbers X,Y,Z, got {s:?}"));
    };
    let num = |t: &str| -> Result<f32, String> {
        t.parse::<f32>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("{t:?} is not a finite number"))
    };
    Ok(Vec3::new(num(x)?, num(y)?, num(z)?))
}

/// A vertical field of view in degrees, strictly between 0 and 180.
pub fn parse_fov(s: &str) -> Result<f32, String> {
    let v: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if v > 0.0 && v < 180.0 {
        Ok(v)
    } else {
        Err(format!("{v} is not between 0 and 180 degrees (exclusive)"))
    }
}
