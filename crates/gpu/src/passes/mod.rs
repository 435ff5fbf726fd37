//! GPU passes shared by the bake and the runtime (one struct per pass, each
//! owning its pipeline, bind groups and uniforms; its WGSL sits beside it).

pub mod hemi_raster;
pub mod light_maps;
pub mod shadow;
