//! Argument value parsers shared by the commands: one syntax for every vector.

use glam::DVec3;

/// Comma-separated numbers (spaces allowed after commas); `what` names them in the error.
fn numbers(s: &str, what: &str) -> Result<Vec<f64>, String> {
    s.split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("expected {what}, got `{s}`"))
}

/// A vector `x,y,z` (finite numbers; spaces allowed after commas; a leading `-` is a number, not
/// an option, when the argument is declared with `allow_hyphen_values`).
pub fn parse_vec3(s: &str) -> Result<DVec3, String> {
    let v = numbers(s, "three numbers x,y,z")?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(DVec3::new(*x, *y, *z)),
        _ => Err(format!("expected three finite numbers x,y,z, got `{s}`")),
    }
}

/// `NEAR,FAR` distances (m): two finite numbers with `0 < NEAR < FAR`.
pub fn parse_range(s: &str) -> Result<(f64, f64), String> {
    let v = numbers(s, "two distances NEAR,FAR in metres")?;
    match v.as_slice() {
        [near, far] if *near > 0.0 && far > near && far.is_finite() => Ok((*near, *far)),
        _ => Err(format!("expected NEAR,FAR in metres with 0 < NEAR < FAR, got `{s}`")),
    }
}

/// `--known-distance X,Y,METRES`: a pixel of the colour image and its distance along the ray.
pub fn parse_known_distance(s: &str) -> Result<pomc::prepare::KnownDistance, String> {
    let v = numbers(s, "X,Y,METRES (a colour pixel and its distance)")?;
    match v.as_slice() {
        [x, y, m]
            if *x >= 0.0 && *y >= 0.0 && x.is_finite() && y.is_finite() && *m > 0.0 && m.is_finite() =>
        {
            Ok(pomc::prepare::KnownDistance { x: *x, y: *y, metres: *m })
        }
        _ => Err(format!("expected X,Y,METRES with X, Y ≥ 0 (pixels) and METRES > 0, got `{s}`")),
    }
}

/// The domain of a number option: `lo < x` (or `lo <= x` when `lo_closed`), `x < hi` (or `<=`).
/// NaN and infinities are never in a domain.
#[derive(Clone, Copy, Debug)]
pub struct Range {
    pub lo: f64,
    pub lo_closed: bool,
    pub hi: f64,
    pub hi_closed: bool,
}

impl Range {
    /// Any finite number.
    pub const FINITE: Range = Range { lo: f64::MIN, lo_closed: true, hi: f64::MAX, hi_closed: true };
    /// A finite number above 0.
    pub const POSITIVE: Range = Range { lo: 0.0, lo_closed: false, hi: f64::MAX, hi_closed: true };
    /// A finite number 0 or above.
    pub const NON_NEGATIVE: Range = Range { lo: 0.0, lo_closed: true, hi: f64::MAX, hi_closed: true };
    /// A fraction in (0, 1].
    pub const FRACTION: Range = Range { lo: 0.0, lo_closed: false, hi: 1.0, hi_closed: true };
    /// An angle in (0, 180] degrees.
    pub const ANGLE: Range = Range { lo: 0.0, lo_closed: false, hi: 180.0, hi_closed: true };
    /// An angle in [0, 180] degrees, where 0 turns a test off.
    pub const ANGLE_OR_OFF: Range = Range { lo: 0.0, lo_closed: true, hi: 180.0, hi_closed: true };
    /// An angle in (0, 180) degrees (a field of view, a feature angle).
    pub const OPEN_ANGLE: Range = Range { lo: 0.0, lo_closed: false, hi: 180.0, hi_closed: false };

    fn contains(&self, x: f64) -> bool {
        x.is_finite()
            && (if self.lo_closed { x >= self.lo } else { x > self.lo })
            && (if self.hi_closed { x <= self.hi } else { x < self.hi })
    }

    fn describe(&self) -> String {
        match (self.lo == f64::MIN, self.hi == f64::MAX) {
            (true, true) => "a finite number".into(),
            (false, true) => {
                format!("a finite number {} {}", if self.lo_closed { ">=" } else { ">" }, self.lo)
            }
            _ => format!(
                "a number in {}{}, {}{}",
                if self.lo_closed { "[" } else { "(" },
                self.lo,
                self.hi,
                if self.hi_closed { "]" } else { ")" }
            ),
        }
    }

    /// A clap value parser for this domain (the message names the range).
    pub fn parser(self) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
        move |s: &str| match s.trim().parse::<f64>() {
            Ok(x) if self.contains(x) => Ok(x),
            _ => Err(format!("`{s}` is not {}", self.describe())),
        }
    }

    /// The same for `f32` options (the value must stay in the domain as an `f32`: no overflow to
    /// infinity, no underflow to 0).
    pub fn parser_f32(self) -> impl Fn(&str) -> Result<f32, String> + Clone + Send + Sync + 'static {
        let p = self.parser();
        move |s: &str| {
            let y = p(s)? as f32;
            if self.contains(f64::from(y)) {
                Ok(y)
            } else {
                Err(format!("`{s}` is not {} in single precision", self.describe()))
            }
        }
    }
}

/// One command's arguments parsed alone, `argv[0]` being the program name (tests of defaults).
#[cfg(test)]
pub fn parse<A: clap::Args>(argv: &[&str]) -> A {
    #[derive(clap::Parser)]
    struct One<A: clap::Args> {
        #[command(flatten)]
        args: A,
    }
    <One<A> as clap::Parser>::try_parse_from(argv).unwrap().args
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

    #[test]
    fn ranges_refuse_nan_infinity_and_out_of_domain() {
        let p = Range::POSITIVE.parser();
        assert_eq!(p("0.5"), Ok(0.5));
        for bad in ["0", "-1", "nan", "NaN", "inf", "-inf", "1e400", "x"] {
            let e = p(bad).unwrap_err();
            assert!(e.contains("> 0"), "{bad}: {e}");
        }
        assert!(Range::FRACTION.parser()("1").is_ok() && Range::FRACTION.parser()("1.5").is_err());
        assert!(Range::NON_NEGATIVE.parser()("0").is_ok());
        assert!(Range::OPEN_ANGLE.parser()("180").is_err() && Range::ANGLE.parser()("180").is_ok());
        assert!(Range::FINITE.parser()("-3").is_ok() && Range::FINITE.parser()("nan").is_err());
        assert!(Range::ANGLE.parser()("0").unwrap_err().contains("(0, 180]"));
    }
}
