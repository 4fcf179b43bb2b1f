// TEMPORARY STUB (replaced by helper's module)
pub struct Series { pub label: String, pub points: Vec<(f64, f64)> }
#[derive(Debug, thiserror::Error)] pub enum PlotError { #[error("x")] X }
pub fn loglog(_p: &std::path::Path, _t: &str, _x: &str, _y: &str, _s: &[Series]) -> Result<(), PlotError> { Ok(()) }
pub fn lines(_p: &std::path::Path, _t: &str, _x: &str, _y: &str, _s: &[Series]) -> Result<(), PlotError> { Ok(()) }
