// TEMPORARY STUB (replaced by helper's module)
pub struct SteadyProblem<'a> {
    pub n_cells: usize,
    pub pairs: &'a [(u32, u32, f64)],
    pub dirichlet: &'a [(u32, f64, f64)],
    pub sources: &'a [(u32, f64)],
}
pub struct SteadySolution {
    pub pressure: Vec<f64>,
    pub dirichlet_flow: Vec<f64>,
    pub residual: f64,
}
#[derive(Debug, thiserror::Error)]
pub enum SteadyError {
    #[error("stub")]
    Stub,
}
#[derive(Default)]
pub struct SteadySolver;
impl SteadySolver {
    pub fn new() -> Self {
        SteadySolver
    }
    pub fn solve(&mut self, _p: &SteadyProblem) -> Result<SteadySolution, SteadyError> {
        Err(SteadyError::Stub)
    }
    pub fn symbolic_count(&self) -> usize {
        0
    }
}
pub fn solve_steady(_p: &SteadyProblem) -> Result<SteadySolution, SteadyError> {
    Err(SteadyError::Stub)
}
