//! GPU context (placeholder).
