//! Discrete heat model (in progress).
