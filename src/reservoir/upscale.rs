//! Upscaling (in progress).
