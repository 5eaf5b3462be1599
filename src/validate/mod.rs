//! The validator. STUB.
