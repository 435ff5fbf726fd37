//! The adapter and device: chosen in `gibake_gpu`'s order (discrete,
//! integrated, virtual, other, CPU; `--adapter` / `GIBAKE_ADAPTER` pick by
//! name), keeping only adapters that can present to the window's surface;
//! and `--gpu-report`, which needs no window.

use std::fmt::Write as _;

use gibake_gpu::{AdapterRecord, GpuError};
use gibake_runtime::Requirements;

use crate::ViewerError;

fn rank(t: wgpu::DeviceType) -> u8 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

/// The record of `adapter` (as `gibake_gpu` writes it).
pub fn record(adapter: &wgpu::Adapter) -> AdapterRecord {
    let info = adapter.get_info();
    AdapterRecord {
        name: info.name.clone(),
        backend: format!("{:?}", info.backend).to_lowercase(),
        driver: info.driver.clone(),
        driver_info: info.driver_info.clone(),
        device_type: format!("{:?}", info.device_type),
    }
}

/// The preferred adapter of `instance` that passes `usable` (the window's
/// surface), honouring `wanted` (else `GIBAKE_ADAPTER`).
pub fn pick(
    instance: &wgpu::Instance,
    wanted: Option<&str>,
    usable: impl Fn(&wgpu::Adapter) -> bool,
) -> Result<wgpu::Adapter, ViewerError> {
    let backends = wgpu::InstanceDescriptor::new_without_display_handle()
        .with_env()
        .backends;
    let mut adapters = pollster::block_on(instance.enumerate_adapters(backends));
    if adapters.is_empty() {
        return Err(GpuError::NoAdapter {
            backends: backends
                .iter_names()
                .map(|(n, _)| n.to_lowercase())
                .collect::<Vec<_>>()
                .join(", "),
        }
        .into());
    }
    adapters.sort_by_key(|a| {
        let i = a.get_info();
        (
            rank(i.device_type),
            i.name.clone(),
            format!("{:?}", i.backend),
        )
    });
    let names = |v: &[wgpu::Adapter]| {
        v.iter()
            .map(|a| format!("{:?}", a.get_info().name))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let wanted = wanted
        .map(str::to_owned)
        .or_else(|| std::env::var("GIBAKE_ADAPTER").ok());
    if let Some(w) = &wanted {
        let lw = w.to_lowercase();
        let (matching, others): (Vec<_>, Vec<_>) = adapters
            .into_iter()
            .partition(|a| a.get_info().name.to_lowercase().contains(&lw));
        if matching.is_empty() {
            return Err(GpuError::NoMatchingAdapter {
                wanted: w.clone(),
                available: names(&others),
            }
            .into());
        }
        adapters = matching;
    }
    let all = names(&adapters);
    adapters
        .into_iter()
        .find(|a| usable(a))
        .ok_or(ViewerError::NoPresentAdapter(all))
}

/// A device on `adapter` with every limit it has and timestamp queries
/// when it has them (per-pass times in the title).
pub fn device(adapter: &wgpu::Adapter) -> Result<(wgpu::Device, wgpu::Queue), ViewerError> {
    let available = adapter.features();
    let features = available
        & (wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS);
    pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("gibake view"),
        required_features: features,
        required_limits: adapter.limits(),
        experimental_features: wgpu::ExperimentalFeatures::disabled(),
        memory_hints: wgpu::MemoryHints::Performance,
        trace: wgpu::Trace::Off,
    }))
    .map_err(|source| ViewerError::Device {
        adapter: adapter.get_info().name,
        source,
    })
}

/// What `--gpu-report` prints, and whether the adapter can run the level.
#[derive(Debug)]
pub struct GpuReport {
    /// The text (adapter, backend, limits needed against the adapter's,
    /// GPU memory).
    pub text: String,
    /// `Some(reason)` when the adapter cannot run the level.
    pub refused: Option<String>,
}

/// Mebibytes, one decimal.
fn mib(b: u64) -> String {
    format!("{:.1} MiB", b as f64 / (1u64 << 20) as f64)
}

/// The report for `needs` on the adapter the viewer would pick (without
/// a window: any adapter counts).
pub fn report(needs: &Requirements, wanted: Option<&str>) -> Result<GpuReport, ViewerError> {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle().with_env());
    let adapter = pick(&instance, wanted, |_| true)?;
    let have = adapter.limits();
    let rec = record(&adapter);
    let mut t = String::new();
    let _ = writeln!(t, "adapter: {}", rec.name);
    let _ = writeln!(t, "backend: {}", rec.backend);
    let _ = writeln!(t, "driver: {} {}", rec.driver, rec.driver_info);
    let _ = writeln!(t, "device type: {}", rec.device_type);
    let _ = writeln!(t, "limits (the level needs / the adapter has):");
    let rows: [(&str, u64, u64); 10] = [
        (
            "max_texture_dimension_2d",
            needs.limits.max_texture_dimension_2d.into(),
            have.max_texture_dimension_2d.into(),
        ),
        (
            "max_texture_array_layers",
            needs.limits.max_texture_array_layers.into(),
            have.max_texture_array_layers.into(),
        ),
        (
            "max_storage_buffers_per_shader_stage",
            needs.limits.max_storage_buffers_per_shader_stage.into(),
            have.max_storage_buffers_per_shader_stage.into(),
        ),
        (
            "max_storage_textures_per_shader_stage",
            needs.limits.max_storage_textures_per_shader_stage.into(),
            have.max_storage_textures_per_shader_stage.into(),
        ),
        (
            "max_sampled_textures_per_shader_stage",
            needs.limits.max_sampled_textures_per_shader_stage.into(),
            have.max_sampled_textures_per_shader_stage.into(),
        ),
        (
            "max_bind_groups",
            needs.limits.max_bind_groups.into(),
            have.max_bind_groups.into(),
        ),
        (
            "max_storage_buffer_binding_size",
            needs.limits.max_storage_buffer_binding_size,
            have.max_storage_buffer_binding_size,
        ),
        (
            "max_buffer_size",
            needs.limits.max_buffer_size,
            have.max_buffer_size,
        ),
        (
            "max_compute_workgroup_storage_size",
            needs.limits.max_compute_workgroup_storage_size.into(),
            have.max_compute_workgroup_storage_size.into(),
        ),
        (
            "max_compute_invocations_per_workgroup",
            needs.limits.max_compute_invocations_per_workgroup.into(),
            have.max_compute_invocations_per_workgroup.into(),
        ),
    ];
    for (name, need, has) in rows {
        let mark = if has >= need { "ok" } else { "TOO LOW" };
        let _ = writeln!(t, "  {name}: {need} / {has}  {mark}");
    }
    let _ = writeln!(
        t,
        "GPU memory: {} in all ({} the asset's upload)",
        mib(needs.gpu_bytes),
        mib(needs.asset_bytes)
    );
    let refused = needs.check(&have).err().map(|e| e.to_string());
    match &refused {
        None => {
            let _ = write!(t, "verdict: {} can run this level", rec.name);
        }
        Some(r) => {
            let _ = write!(t, "verdict: {} cannot run this level: {r}", rec.name);
        }
    }
    Ok(GpuReport { text: t, refused })
}
