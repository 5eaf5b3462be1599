//! Patch-packed compression. STUB.

#[derive(Debug, thiserror::Error)]
pub enum PackError {
    #[error("bad patch table")]
    BadTable,
}
impl PackError {
    pub fn code(&self) -> &'static str {
        "PATCH_TABLE_INVALID"
    }
}
