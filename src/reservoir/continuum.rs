//! Continuum heat model (in progress).
