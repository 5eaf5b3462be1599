//! Argument value parsers shared by the commands: one syntax for every vector.

use glam::DVec3;

/// A vector `x,y,z` (finite numbers; spaces allowed after commas; a leading `-` is a number, not
/// an option, when the argument is declared with `allow_hyphen_values`).
pub fn parse_vec3(s: &str) -> Result<DVec3, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("expected three numbers x,y,z, got `{s}`"))?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(DVec3::new(*x, *y, *z)),
        _ => Err(format!("expected three finite numbers x,y,z, got `{s}`")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vectors() {
        assert_eq!(parse_vec3("1,2,3"), Ok(DVec3::new(1.0, 2.0, 3.0)));
        assert_eq!(parse_vec3("-1, 2,-3.5"), Ok(DVec3::new(-1.0, 2.0, -3.5)));
        assert!(parse_vec3("1,2").is_err());
        assert!(parse_vec3("1,2,inf").is_err());
        assert!(parse_vec3("a,b,c").is_err());
    }
}
