//! Per-pass GPU timing with timestamp queries (when the adapter has them).
//! Timestamps are resolved into a buffer at the end of the frame and read
//! only when stats are asked for, never inside the frame. The passes a
//! frame times are planned while preparing it ([`Timer::plan`]); recording
//! only looks their queries up.

/// Named GPU timestamps of one frame.
pub struct Timer {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    capacity: u32,
    names: Vec<&'static str>,
    period_ns: f32,
}

impl Timer {
    /// A timer for up to `passes` passes, or `None` without timestamp support.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, passes: u32) -> Option<Timer> {
        if !device.features().contains(wgpu::Features::TIMESTAMP_QUERY) {
            return None;
        }
        let capacity = passes * 2;
        let set = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("pass timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: capacity,
        });
        let size = capacity as u64 * 8;
        let resolve = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamp resolve"),
            size,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamp readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Some(Timer {
            set,
            resolve,
            readback,
            capacity,
            names: Vec::new(),
            period_ns: queue.get_timestamp_period(),
        })
    }

    /// Starts a frame.
    pub fn reset(&mut self) {
        self.names.clear();
    }

    /// Plans a pass named `name` for this frame (ignored past the capacity
    /// or when already planned).
    pub fn plan(&mut self, name: &'static str) {
        if (self.names.len() as u32 + 1) * 2 <= self.capacity && !self.names.contains(&name) {
            self.names.push(name);
        }
    }

    fn index(&self, name: &'static str) -> Option<u32> {
        self.names
            .iter()
            .position(|n| *n == name)
            .map(|k| k as u32 * 2)
    }

    /// Timestamp writes for the planned render pass named `name`.
    pub fn render(&self, name: &'static str) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        let i = self.index(name)?;
        Some(wgpu::RenderPassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(i),
            end_of_pass_write_index: Some(i + 1),
        })
    }

    /// Timestamp writes for the planned compute pass named `name`.
    pub fn compute(&self, name: &'static str) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        let i = self.index(name)?;
        Some(wgpu::ComputePassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(i),
            end_of_pass_write_index: Some(i + 1),
        })
    }

    /// Resolves this frame's timestamps (end of the frame's encoder).
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        let n = self.names.len() as u32 * 2;
        if n == 0 {
            return;
        }
        encoder.resolve_query_set(&self.set, 0..n, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, n as u64 * 8);
    }

    /// Reads the last resolved frame: `(pass, milliseconds)`. Waits for the GPU.
    pub fn read(&self, device: &wgpu::Device) -> Vec<(&'static str, f64)> {
        let n = self.names.len() as u64 * 2;
        if n == 0 {
            return Vec::new();
        }
        let slice = self.readback.slice(..n * 8);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        if device.poll(wgpu::PollType::wait_indefinitely()).is_err()
            || !matches!(rx.recv(), Ok(Ok(())))
        {
            return Vec::new();
        }
        let out = match slice.get_mapped_range() {
            Ok(data) => {
                let t: &[u64] = bytemuck::cast_slice(&data);
                self.names
                    .iter()
                    .enumerate()
                    .map(|(k, name)| {
                        let dt = t[2 * k + 1].saturating_sub(t[2 * k]);
                        (*name, dt as f64 * self.period_ns as f64 * 1e-6)
                    })
                    .collect()
            }
            Err(_) => Vec::new(),
        };
        self.readback.unmap();
        out
    }
}
