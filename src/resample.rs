//! Sphere-aware sampling and mapping conversion. STUB.

#[derive(Debug, thiserror::Error)]
pub enum ResampleError {
    #[error("unsupported")]
    Unsupported,
}
impl ResampleError {
    pub fn code(&self) -> &'static str {
        "RESAMPLE_UNSUPPORTED"
    }
}
