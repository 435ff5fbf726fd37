//! gibake-bevy's tests, one binary (one link of Bevy): the conventions
//! where Bevy and gibake meet (`conventions`, no GPU), and Bevy rendering
//! the example's level headless on lavapipe (`headless`): the light the
//! plugin adds against `gibake render`, Bevy's G-buffer against gibake's,
//! Bevy's sun against gibake's, and a re-bake reaching the running app.

mod common;
mod conventions;
mod headless;
