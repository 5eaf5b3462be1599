//! `pomc` command line. STUB.
fn main() {
    println!("pomc");
}
