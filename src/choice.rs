//! Options that take one of a few named values (`--refine auto|on|off`): each value's name and
//! documentation declared once, with its enum, by `choices!`. Front ends list and parse them
//! through [`Choice`]; the library needs no argument parser.

/// An enum whose values have names, as the command line and Python take them.
pub trait Choice: Copy + PartialEq + Sized + 'static {
    /// Each value with its name and its documentation's lines (first paragraph: the one-line help).
    const VALUES: &'static [(Self, &'static str, &'static [&'static str])];

    /// The value's name.
    fn name(self) -> &'static str {
        Self::VALUES.iter().find(|v| v.0 == self).map_or("", |v| v.1)
    }

    /// The value of a name (exact, case-sensitive).
    fn from_name(name: &str) -> Option<Self> {
        Self::VALUES.iter().find(|v| v.1 == name).map(|v| v.0)
    }

    /// The value's one-line help, as clap's derive makes it of a doc comment: the first paragraph
    /// on one line, without a closing full stop (empty without documentation).
    fn help(self) -> String {
        let doc = Self::VALUES.iter().find(|v| v.0 == self).map_or(&[][..], |v| v.2);
        let first: Vec<&str> = doc
            .iter()
            .flat_map(|l| l.split('\n'))
            .map(str::trim)
            .skip_while(|l| l.is_empty())
            .take_while(|l| !l.is_empty())
            .collect();
        let mut line = first.join(" ");
        if line.ends_with('.') && !line.ends_with("..") {
            line.pop();
        }
        line
    }
}

/// Declares an enum of named values and its [`Choice`] table: `pub enum E (default V) { /// doc
/// V = "name", … }` (the `(default V)` is optional and writes `Default`).
macro_rules! choices {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident $((default $default:ident))? {
            $( $(#[doc = $doc:literal])* $variant:ident = $text:literal, )*
        }
    ) => {
        $(#[$meta])*
        $vis enum $name { $( $(#[doc = $doc])* $variant, )* }
        $(
            impl Default for $name {
                fn default() -> Self {
                    $name::$default
                }
            }
        )?
        impl $crate::choice::Choice for $name {
            const VALUES: &'static [(Self, &'static str, &'static [&'static str])] =
                &[$( ($name::$variant, $text, &[$($doc),*]) ),*];
        }
    };
}
pub(crate) use choices;

#[cfg(test)]
mod tests {
    use super::Choice;
    use crate::prepare::{DepthKind, Refine};

    #[test]
    fn names_round_trip_and_help_is_the_first_paragraph() {
        for (v, name, _) in Refine::VALUES {
            assert_eq!(Refine::from_name(name), Some(*v));
            assert_eq!(v.name(), *name);
        }
        assert_eq!(Refine::from_name("Auto"), None);
        assert_eq!(Refine::default(), Refine::Auto);
        assert_eq!(Refine::On.help(), "Also snap soft edges onto colour edges (experimental)");
        assert!(DepthKind::Inverse.help().ends_with("(MiDaS, Depth Anything)"));
    }
}
