//! The later bounces' VPLs under moving objects that cover the lights
//! (`later_occlusion.wgsl`): after the frame's occlusion passes, each later
//! VPL (format 4.6) gets the first bounce's occluded shares where its light
//! came from — its source groups' (format 4.8, `gibake_asset::
//! LaterSources`: each group's mean weighted by the light its VPLs pass
//! on, by the VPL's weights)
//! and the level's flux-weighted mean for the rest (all of it for an
//! asset of 4.6 or 4.7) — so that a light a moving object covers darkens
//! the later bounces where that light went. Only built when the asset has
//! later VPLs and the scene has the occlusion pass.

use gibake_gpu::shaders;
use wgpu::util::DeviceExt;

/// The pass's WGSL.
pub(crate) const LATER_OCCLUSION_WGSL: &str = include_str!("later_occlusion.wgsl");

/// `LaterParams` in `later_occlusion.wgsl` (must match).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuLaterParams {
    first_later: u32,
    n_static: u32,
    /// Source groups (0: none, the level's mean for every later VPL).
    groups: u32,
    _pad: u32,
}

/// `Weighted` in `later_occlusion.wgsl` (must match): an index and its
/// weight — in the sources list one of a later VPL's
/// `gibake_asset::SOURCES_PER_LATER_VPL` source groups, in the members list
/// a first-bounce VPL of a group and its weight in the group's mean.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuWeighted {
    index: u32,
    weight: f32,
}

/// The pass: its pipeline and its one bind group.
pub(crate) struct LaterOcclusionPass {
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    _weight: wgpu::Buffer,
    _params: wgpu::Buffer,
    _offsets: wgpu::Buffer,
    _members: wgpu::Buffer,
    _sources: wgpu::Buffer,
}

/// The source groups' members for `first` (each first-bounce VPL's group
/// and weight, `gibake_asset::LaterSources::first`) in `groups` groups:
/// `groups + 1` offsets (group `g`'s members are `members[offsets[g] ..
/// offsets[g + 1]]`) and the members, group by group, each VPL's index and
/// weight; a VPL of weight 0 or out of range is left
/// out.
fn group_members(first: &[(u32, f32)], groups: u32) -> (Vec<u32>, Vec<GpuWeighted>) {
    let g = groups as usize;
    let counted = |(k, w): &(u32, f32)| (*k as usize) < g && *w > 0.0 && w.is_finite();
    let mut offsets = vec![0u32; g + 1];
    for f in first.iter().filter(|f| counted(f)) {
        offsets[f.0 as usize + 1] += 1;
    }
    for k in 1..=g {
        offsets[k] += offsets[k - 1];
    }
    let mut at = offsets.clone();
    let mut members = vec![
        GpuWeighted {
            index: 0,
            weight: 0.0
        };
        offsets[g] as usize
    ];
    for (i, f) in first.iter().enumerate().filter(|(_, f)| counted(f)) {
        members[at[f.0 as usize] as usize] = GpuWeighted {
            index: i as u32,
            weight: f.1,
        };
        at[f.0 as usize] += 1;
    }
    (offsets, members)
}

impl LaterOcclusionPass {
    /// For static VPLs of flux `fluxes` (linear RGB, every static VPL in
    /// order, the last `later` the later bounces'), where their light came
    /// from (`sources`; `None`: the level's mean for all) and the occluded
    /// sums `occluded`; `None` without later VPLs or without a first bounce.
    pub(crate) fn new(
        device: &wgpu::Device,
        fluxes: &[[f32; 3]],
        later: u32,
        sources: Option<&gibake_asset::LaterSources>,
        occluded: &wgpu::Buffer,
    ) -> Option<LaterOcclusionPass> {
        let n = fluxes.len() as u32;
        let first_later = n.checked_sub(later)?;
        if later == 0 || first_later == 0 {
            return None;
        }
        let weight: Vec<f32> = fluxes[..first_later as usize]
            .iter()
            .map(|f| (0.2126 * f[0] + 0.7152 * f[1] + 0.0722 * f[2]).max(0.0))
            .collect();
        let weight_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("later occlusion weights"),
            contents: bytemuck::cast_slice(&weight),
            usage: wgpu::BufferUsages::STORAGE,
        });
        // The asset's validation holds the lengths and the groups' range;
        // anything else is the level's mean for all.
        let sources = sources.filter(|s| {
            s.first.len() == first_later as usize
                && s.weights.len() == (later as usize) * gibake_asset::SOURCES_PER_LATER_VPL
        });
        let groups = sources.map_or(0, |s| {
            s.first
                .iter()
                .chain(&s.weights)
                .map(|(g, _)| g)
                .max()
                .map_or(0, |g| g + 1)
                .min(gibake_asset::MAX_SOURCE_GROUPS)
        });
        let (offsets, mut members) = match sources {
            Some(s) if groups > 0 => group_members(&s.first, groups),
            _ => (vec![0], Vec::new()),
        };
        if members.is_empty() {
            members.push(GpuWeighted {
                index: 0,
                weight: 0.0,
            });
        }
        let list: Vec<GpuWeighted> = match sources {
            Some(s) if groups > 0 => s
                .weights
                .iter()
                .map(|&(group, weight)| GpuWeighted {
                    index: group.min(groups - 1),
                    weight,
                })
                .collect(),
            _ => vec![GpuWeighted {
                index: 0,
                weight: 0.0,
            }],
        };
        let offsets_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("later occlusion source groups"),
            contents: bytemuck::cast_slice(&offsets),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let members_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("later occlusion source group members"),
            contents: bytemuck::cast_slice(&members),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let sources_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("later occlusion sources"),
            contents: bytemuck::cast_slice(&list),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("later occlusion params"),
            contents: bytemuck::bytes_of(&GpuLaterParams {
                first_later,
                n_static: n,
                groups,
                _pad: 0,
            }),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let module = shaders::module(device, "later_occlusion.wgsl", LATER_OCCLUSION_WGSL);
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("later occlusion"),
            layout: None,
            module: &module,
            entry_point: Some("cs_main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("later occlusion"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: weight_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: occluded.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: offsets_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: members_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: sources_buf.as_entire_binding(),
                },
            ],
        });
        Some(LaterOcclusionPass {
            pipeline,
            group,
            _weight: weight_buf,
            _params: params,
            _offsets: offsets_buf,
            _members: members_buf,
            _sources: sources_buf,
        })
    }

    /// Records the pass (after every occlusion pass of the frame, before
    /// shading): one workgroup.
    pub(crate) fn encode(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("later occlusion"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Offsets, then each group's VPLs in order with their weights; a
    /// group out of range or a weight of 0 is left out.
    #[test]
    fn members_list_each_groups_vpls() {
        let (o, m) = group_members(
            &[(1, 1.0), (0, 2.0), (1, 3.0), (2, 4.0), (9, 1.0), (2, 0.0)],
            3,
        );
        assert_eq!(o, vec![0, 1, 3, 4]);
        let m: Vec<(u32, f32)> = m.iter().map(|s| (s.index, s.weight)).collect();
        assert_eq!(m, vec![(1, 2.0), (0, 1.0), (2, 3.0), (3, 4.0)]);
    }
}
