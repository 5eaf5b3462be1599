//! A panorama directory. STUB.

#[derive(Debug, thiserror::Error)]
pub enum PanoramaError {
    #[error("not a panorama")]
    NotAPanorama,
}
impl PanoramaError {
    pub fn code(&self) -> &'static str {
        "PANORAMA_NOT_FOUND"
    }
}
