//! Independent CPU path tracer (placeholder, being written).
