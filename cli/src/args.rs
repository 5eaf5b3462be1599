//! Argument value parsers shared by the commands: the library's (one syntax for every vector,
//! one domain type for every number).

pub use pomc_flags::Range;

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
