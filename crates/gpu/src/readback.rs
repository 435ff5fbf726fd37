//! Copies of textures and buffers back to the CPU (tests, image output, bake).

use crate::{GpuContext, GpuError};

/// Bytes per row padded to wgpu's 256-byte copy alignment.
pub fn padded_bytes_per_row(unpadded: u32) -> u32 {
    let a = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    unpadded.div_ceil(a) * a
}

/// Reads a whole buffer (must have `COPY_SRC` usage).
pub fn read_buffer(ctx: &GpuContext, buffer: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
    let size = buffer.size();
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    enc.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
    ctx.queue.submit([enc.finish()]);
    map_and_read(&ctx.device, &staging)
}

fn map_and_read(device: &wgpu::Device, staging: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
    let slice = staging.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| GpuError::Operation(format!("device poll: {e}")))?;
    rx.recv()
        .map_err(|e| GpuError::Operation(format!("map callback lost: {e}")))?
        .map_err(|e| GpuError::Operation(format!("buffer map: {e}")))?;
    let data = slice
        .get_mapped_range()
        .map_err(|e| GpuError::Operation(format!("mapped range: {e:?}")))?
        .to_vec();
    staging.unmap();
    Ok(data)
}

/// Reads one layer (mip 0) of a 2D texture as tightly packed rows of
/// `bytes_per_texel` bytes each.
pub fn read_texture(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
    layer: u32,
    bytes_per_texel: u32,
) -> Result<Vec<u8>, GpuError> {
    read_texture_on(&ctx.device, &ctx.queue, texture, layer, bytes_per_texel)
}

/// [`read_texture`] on any device and queue (a game's own).
pub fn read_texture_on(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    layer: u32,
    bytes_per_texel: u32,
) -> Result<Vec<u8>, GpuError> {
    let (w, h) = (texture.width(), texture.height());
    let unpadded = w * bytes_per_texel;
    let padded = padded_bytes_per_row(unpadded);
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("texture readback"),
        size: padded as u64 * h as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut enc = device.create_command_encoder(&Default::default());
    enc.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d {
                x: 0,
                y: 0,
                z: layer,
            },
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(h),
            },
        },
        wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
    );
    queue.submit([enc.finish()]);
    let data = map_and_read(device, &staging)?;
    let mut out = Vec::with_capacity((unpadded * h) as usize);
    for row in data.chunks_exact(padded as usize) {
        out.extend_from_slice(&row[..unpadded as usize]);
    }
    Ok(out)
}

/// Reads an `R32Float`/`Rgba32Float`-style texture layer as f32 values.
pub fn read_texture_f32(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
    layer: u32,
    channels: u32,
) -> Result<Vec<f32>, GpuError> {
    let bytes = read_texture(ctx, texture, layer, 4 * channels)?;
    Ok(bytemuck::pod_collect_to_vec(&bytes))
}

/// [`read_texture_f32`] on any device and queue (a game's own).
pub fn read_texture_f32_on(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    layer: u32,
    channels: u32,
) -> Result<Vec<f32>, GpuError> {
    let bytes = read_texture_on(device, queue, texture, layer, 4 * channels)?;
    Ok(bytemuck::pod_collect_to_vec(&bytes))
}
