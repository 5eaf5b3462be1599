//! Numeric attribute values. Lists are separated by any run of XML whitespace and/or commas;
//! leading and trailing separators are allowed (the thesis writes `vector='-1 1 1 '`).

/// Why a value was refused; the caller turns it into a code and a message.
#[derive(Clone, Debug, PartialEq)]
pub enum NumberError {
    /// Not a number at all (the offending token).
    Garbage(String),
    /// Parses, but is NaN or infinite (or overflows the type).
    NotFinite(String),
    /// The wrong number of components (expected, found; found is capped at expected + 1).
    Count(usize, usize),
}

impl NumberError {
    /// A message naming the fix, for the attribute `attr`.
    pub fn message(&self, attr: &str) -> String {
        match self {
            NumberError::Garbage(t) => {
                format!("`{attr}`: `{t}` is not a number; write a decimal number such as 1.5")
            }
            NumberError::NotFinite(t) => {
                format!("`{attr}`: `{t}` is not a finite number; write a finite value")
            }
            NumberError::Count(1, _) => format!("`{attr}` takes one number"),
            NumberError::Count(n, found) => {
                let found = if found > n { format!("more than {n}") } else { found.to_string() };
                format!("`{attr}` takes {n} numbers separated by spaces or commas, found {found}")
            }
        }
    }
}

fn is_separator(c: char) -> bool {
    matches!(c, ' ' | '\t' | '\n' | '\r' | ',')
}

/// The tokens of a list value (never allocates more than it reads).
fn tokens(s: &str) -> impl Iterator<Item = &str> {
    s.split(is_separator).filter(|t| !t.is_empty())
}

fn finite_f64(t: &str) -> Result<f64, NumberError> {
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(NumberError::NotFinite(t.to_string())),
        Err(_) => Err(NumberError::Garbage(t.to_string())),
    }
}

fn finite_f32(t: &str) -> Result<f32, NumberError> {
    match t.parse::<f32>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(NumberError::NotFinite(t.to_string())),
        Err(_) => Err(NumberError::Garbage(t.to_string())),
    }
}

/// Exactly `N` finite numbers.
pub fn floats<const N: usize>(s: &str) -> Result<[f64; N], NumberError> {
    exactly(s, finite_f64)
}

/// Exactly `N` finite single-precision numbers (depth ranges are stored as `f32`, so they are
/// parsed as `f32` directly: writing them back with the shortest `f32` form round-trips).
pub fn floats32<const N: usize>(s: &str) -> Result<[f32; N], NumberError> {
    exactly(s, finite_f32)
}

/// Exactly `N` numbers of `s`, each read by `one`.
fn exactly<T: Copy + Default, const N: usize>(
    s: &str,
    one: impl Fn(&str) -> Result<T, NumberError>,
) -> Result<[T; N], NumberError> {
    let mut out = [T::default(); N];
    let mut found = 0;
    for t in tokens(s).take(N + 1) {
        if found == N {
            return Err(NumberError::Count(N, N + 1));
        }
        out[found] = one(t)?;
        found += 1;
    }
    if found == N {
        Ok(out)
    } else {
        Err(NumberError::Count(N, found))
    }
}

/// One finite number.
pub fn float(s: &str) -> Result<f64, NumberError> {
    floats::<1>(s).map(|[v]| v)
}

/// A non-negative decimal integer that fits in 32 bits: digits only, no sign, exponent or
/// surrounding spaces (spec 2.2).
pub fn uint(s: &str) -> Result<u32, NumberError> {
    if s.is_empty() || !s.bytes().all(|b| b.is_ascii_digit()) {
        return Err(NumberError::Garbage(s.to_string()));
    }
    s.parse::<u32>().map_err(|_| NumberError::NotFinite(s.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_accept_spaces_commas_and_trailing_separators() {
        assert_eq!(floats::<3>("-1 1 1 "), Ok([-1.0, 1.0, 1.0]));
        assert_eq!(floats::<3>("1,2, 3"), Ok([1.0, 2.0, 3.0]));
        assert_eq!(floats::<3>("\t0\n0 1.15"), Ok([0.0, 0.0, 1.15]));
    }

    #[test]
    fn lists_refuse_bad_counts_and_values() {
        assert_eq!(floats::<3>("1 2"), Err(NumberError::Count(3, 2)));
        assert_eq!(floats::<3>("1 2 3 4 5"), Err(NumberError::Count(3, 4)));
        assert_eq!(floats::<3>("1 NaN 3"), Err(NumberError::NotFinite("NaN".into())));
        assert_eq!(floats::<3>("1 inf 3"), Err(NumberError::NotFinite("inf".into())));
        assert_eq!(floats::<3>("1 x 3"), Err(NumberError::Garbage("x".into())));
        assert_eq!(float("1e400"), Err(NumberError::NotFinite("1e400".into())));
        assert_eq!(floats32::<2>("1 1e39"), Err(NumberError::NotFinite("1e39".into())));
    }

    #[test]
    fn integers_are_plain_decimal() {
        assert_eq!(uint("2048"), Ok(2048));
        assert!(uint(" 512 ").is_err());
        assert!(uint("-1").is_err());
        assert!(uint("+1").is_err());
        assert!(uint("1.0").is_err());
        assert!(uint("4294967296").is_err());
        assert!(uint("").is_err());
    }
}
