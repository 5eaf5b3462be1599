//! The XML manifest. STUB.

#[derive(Debug, thiserror::Error)]
pub enum ManifestError {
    #[error("malformed")]
    Malformed,
}
impl ManifestError {
    pub fn code(&self) -> &'static str {
        "MANIFEST_XML_MALFORMED"
    }
}
