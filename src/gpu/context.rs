//! The wgpu device the kernels run on.
//!
//! The instance reads its options from the environment
//! (`WGPU_BACKEND=vulkan` picks Vulkan, the backend that runs on Mesa's
//! lavapipe where no GPU is present). The device asks for timestamp
//! queries where the adapter has them (the per-variant GPU times of the
//! render report) and for `TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES`,
//! which half-float storage textures need on some adapters, and takes the
//! adapter's own limits: texture-array layers bound the probe count.

/// An open device and queue.
pub struct Context {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// Adapter name and backend, as `report.json` gives them.
    pub adapter: String,
    /// Whether compute passes can write timestamps.
    pub timestamps: bool,
}

impl Context {
    /// Opens the preferred adapter of the backends the environment allows.
    ///
    /// Contract: `Err` carries one line saying why no device could be had
    /// (no adapter, or the device request failed); the caller decides
    /// whether to fall back to the CPU twin.
    pub fn new() -> Result<Context, String> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        }))
        .map_err(|e| format!("no GPU adapter ({e})"))?;
        let info = adapter.get_info();
        let wanted = wgpu::Features::TIMESTAMP_QUERY
            | wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES;
        let features = adapter.features() & wanted;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("probeplace"),
            required_features: features,
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|e| format!("cannot open {} ({e})", info.name))?;
        Ok(Context {
            device,
            queue,
            adapter: format!("{} ({:?})", info.name, info.backend),
            timestamps: features.contains(wgpu::Features::TIMESTAMP_QUERY),
        })
    }
}
