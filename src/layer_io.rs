//! Layer file I/O. STUB.

#[derive(Debug, thiserror::Error)]
pub enum LayerIoError {
    #[error("unreadable")]
    Unreadable,
}
impl LayerIoError {
    pub fn code(&self) -> &'static str {
        "LAYER_UNREADABLE"
    }
}
