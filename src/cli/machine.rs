//! What machine ember runs on, for `ember info` and the header of `ember bench`: the
//! processor's model and widest vector instruction set, and what Embree runs on it.

use serde::Serialize;

use ember::embree::DeviceInfo;

/// The processor and the Embree library, as a benchmark reader needs them to compare
/// figures from two machines.
#[derive(Clone, Debug, Serialize)]
pub struct Machine {
    /// `model name` of /proc/cpuinfo, or the architecture where there is none.
    pub cpu: String,
    pub hardware_threads: usize,
    /// The widest vector instruction set the processor offers (`AVX-512`, `AVX2`, ...).
    pub isa: &'static str,
    pub embree_version: String,
    /// The packet width Embree runs natively (4: SSE, 8: AVX/AVX2, 16: AVX-512).
    pub embree_native_packet_width: u32,
    pub embree_tasking: &'static str,
}

impl Machine {
    pub fn of(embree: &DeviceInfo) -> Machine {
        Machine {
            cpu: cpu_model(),
            hardware_threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            isa: cpu_isa(),
            embree_version: embree.version.clone(),
            embree_native_packet_width: embree.native_packet_width,
            embree_tasking: embree.tasking_system,
        }
    }

    /// `Intel(R) Xeon(R) ... (2 hardware threads, AVX-512); Embree 3.13.5 (AVX-512
    /// kernels: 16-wide packets, TBB tasking)`.
    pub fn summary(&self) -> String {
        format!(
            "{} ({} hardware threads, {}); Embree {} ({} kernels: {}-wide packets, {} tasking)",
            self.cpu,
            self.hardware_threads,
            self.isa,
            self.embree_version,
            embree_isa(self.embree_native_packet_width),
            self.embree_native_packet_width,
            self.embree_tasking
        )
    }
}

/// The instruction set Embree's widest native packets mean.
pub fn embree_isa(native_packet_width: u32) -> &'static str {
    match native_packet_width {
        16 => "AVX-512",
        8 => "AVX/AVX2",
        _ => "SSE",
    }
}

/// The processor's model name from /proc/cpuinfo (Linux), else the architecture.
fn cpu_model() -> String {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    cpuinfo
        .lines()
        .find_map(|line| {
            let (key, value) = line.split_once(':')?;
            (key.trim() == "model name").then(|| value.split_whitespace().collect::<Vec<_>>())
        })
        .map(|words| words.join(" "))
        .filter(|model| !model.is_empty())
        .unwrap_or_else(|| std::env::consts::ARCH.to_owned())
}

/// The widest vector instruction set this processor runs.
fn cpu_isa() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            "AVX-512"
        } else if std::arch::is_x86_feature_detected!("avx2") {
            "AVX2"
        } else if std::arch::is_x86_feature_detected!("avx") {
            "AVX"
        } else if std::arch::is_x86_feature_detected!("sse4.2") {
            "SSE4.2"
        } else {
            "SSE2"
        }
    }
    #[cfg(target_arch = "aarch64")]
    {
        "NEON"
    }
    #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
    {
        std::env::consts::ARCH
    }
}
