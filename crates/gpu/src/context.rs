//! Headless wgpu device creation with deterministic adapter choice.
//!
//! Adapters are enumerated on the backends allowed by `WGPU_BACKEND` (all by
//! default) and ordered: discrete GPU, integrated GPU, virtual GPU, other, CPU
//! (lavapipe); ties broken by name. `GIBAKE_ADAPTER` (or
//! [`GpuOptions::adapter`]) picks the first adapter whose name contains the
//! given text, case-insensitively. The chosen adapter's name, backend and
//! driver are kept in [`AdapterRecord`] for provenance.

use std::fmt;

/// Where the device came from: recorded in baked assets and stats.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct AdapterRecord {
    /// Adapter name, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
    pub name: String,
    /// Backend, e.g. "vulkan".
    pub backend: String,
    /// Driver name, e.g. "llvmpipe".
    pub driver: String,
    /// Driver version info, e.g. "Mesa 22.3.6 (LLVM 15.0.6)".
    pub driver_info: String,
    /// Device type: "DiscreteGpu", "Cpu", ...
    pub device_type: String,
}

impl fmt::Display for AdapterRecord {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} ({}, {} {}, {})",
            self.name, self.backend, self.driver, self.driver_info, self.device_type
        )
    }
}

/// Options for [`GpuContext::new`].
#[derive(Clone, Debug, Default)]
pub struct GpuOptions {
    /// Substring of the adapter name to pick; falls back to `GIBAKE_ADAPTER`.
    pub adapter: Option<String>,
}

/// Why no device could be created.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter at all.
    #[error(
        "no GPU adapter found (backends: {backends}). Install a Vulkan driver: on Debian/Ubuntu \
         `apt-get install mesa-vulkan-drivers` gives the lavapipe software GPU; on a machine with a \
         GPU install its vendor driver"
    )]
    NoAdapter {
        /// Backends that were searched.
        backends: String,
    },
    /// `--adapter`/`GIBAKE_ADAPTER` matched nothing.
    #[error("no GPU adapter matches {wanted:?}; available: {available}")]
    NoMatchingAdapter {
        /// The requested name.
        wanted: String,
        /// The names found.
        available: String,
    },
    /// The adapter refused to create a device.
    #[error("cannot create a device on {adapter}: {source}")]
    RequestDevice {
        /// Adapter name.
        adapter: String,
        /// wgpu's error.
        #[source]
        source: wgpu::RequestDeviceError,
    },
    /// Waiting for the GPU or mapping a buffer failed.
    #[error("GPU operation failed: {0}")]
    Operation(String),
}

/// A headless device and queue, plus what it can do.
pub struct GpuContext {
    /// The wgpu instance.
    pub instance: wgpu::Instance,
    /// The chosen adapter.
    pub adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// Provenance of the adapter.
    pub record: AdapterRecord,
    /// Whether GPU timestamp queries are enabled on this device.
    pub timestamps: bool,
}

fn type_rank(t: wgpu::DeviceType) -> u8 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

impl GpuContext {
    /// Creates a device on the preferred adapter (see the module docs).
    pub fn new(options: &GpuOptions) -> Result<GpuContext, GpuError> {
        pollster::block_on(Self::new_async(options))
    }

    /// The record of the adapter [`GpuContext::new`] would pick, without
    /// creating a device (cheap: for up-to-date checks that compare the
    /// adapter an asset was baked on).
    pub fn adapter_record(options: &GpuOptions) -> Result<AdapterRecord, GpuError> {
        pollster::block_on(Self::pick_adapter(options)).map(|(_, _, record)| record)
    }

    /// The preferred adapter (see the module docs) and its record.
    async fn pick_adapter(
        options: &GpuOptions,
    ) -> Result<(wgpu::Instance, wgpu::Adapter, AdapterRecord), GpuError> {
        let desc = wgpu::InstanceDescriptor::new_without_display_handle().with_env();
        let backends = desc.backends;
        let instance = wgpu::Instance::new(desc);
        let mut adapters = instance.enumerate_adapters(backends).await;
        adapters.sort_by(|a, b| {
            let (ia, ib) = (a.get_info(), b.get_info());
            (
                type_rank(ia.device_type),
                ia.name.clone(),
                format!("{:?}", ia.backend),
            )
                .cmp(&(
                    type_rank(ib.device_type),
                    ib.name.clone(),
                    format!("{:?}", ib.backend),
                ))
        });
        if adapters.is_empty() {
            return Err(GpuError::NoAdapter {
                backends: backends
                    .iter_names()
                    .map(|(n, _)| n.to_lowercase())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
        let wanted = options
            .adapter
            .clone()
            .or_else(|| std::env::var("GIBAKE_ADAPTER").ok());
        let adapter = match wanted {
            Some(w) => {
                let lw = w.to_lowercase();
                let pos = adapters
                    .iter()
                    .position(|a| a.get_info().name.to_lowercase().contains(&lw));
                match pos {
                    Some(i) => adapters.swap_remove(i),
                    None => {
                        let available = adapters
                            .iter()
                            .map(|a| format!("{:?}", a.get_info().name))
                            .collect::<Vec<_>>()
                            .join(", ");
                        return Err(GpuError::NoMatchingAdapter {
                            wanted: w,
                            available,
                        });
                    }
                }
            }
            None => adapters.swap_remove(0),
        };
        let info = adapter.get_info();
        let record = AdapterRecord {
            name: info.name.clone(),
            backend: format!("{:?}", info.backend).to_lowercase(),
            driver: info.driver.clone(),
            driver_info: info.driver_info.clone(),
            device_type: format!("{:?}", info.device_type),
        };
        Ok((instance, adapter, record))
    }

    async fn new_async(options: &GpuOptions) -> Result<GpuContext, GpuError> {
        let (instance, adapter, record) = Self::pick_adapter(options).await?;
        let info = adapter.get_info();
        let available = adapter.features();
        let mut features = wgpu::Features::empty();
        let timestamps = available.contains(wgpu::Features::TIMESTAMP_QUERY);
        if timestamps {
            features |= wgpu::Features::TIMESTAMP_QUERY;
        }
        if available.contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS) {
            features |= wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS;
        }
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("gibake"),
                required_features: features,
                required_limits: adapter.limits(),
                experimental_features: wgpu::ExperimentalFeatures::disabled(),
                memory_hints: wgpu::MemoryHints::Performance,
                trace: wgpu::Trace::Off,
            })
            .await
            .map_err(|source| GpuError::RequestDevice {
                adapter: info.name.clone(),
                source,
            })?;
        tracing::info!("GPU adapter: {record}");
        Ok(GpuContext {
            instance,
            adapter,
            device,
            queue,
            record,
            timestamps,
        })
    }

    /// Blocks until all submitted work is done.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| GpuError::Operation(format!("device poll: {e}")))
    }
}
