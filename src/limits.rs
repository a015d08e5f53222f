//! How much memory the machine can give ember, so that work which cannot fit is refused
//! up front with a message naming the sizes, instead of dying half-way in the allocator.

use std::sync::Mutex;
use std::time::{Duration, Instant};

/// The largest image side `ember render` accepts (`--width`, `--height`), and so the
/// largest a shard or checkpoint may claim.
pub const MAX_IMAGE_SIDE: u32 = 16384;
/// The most samples per pixel `ember render --spp` accepts.
pub const MAX_SPP: u32 = 1_000_000;
/// The most shards a render may be split into (`--shard I/N`).
pub const MAX_SHARDS: u32 = 1_000_000;

/// Environment variable that overrides the available memory, in bytes. For tests (and
/// for users who want ember to stay under a budget smaller than the machine's).
pub const MEMORY_LIMIT_ENV: &str = "EMBER_MEMORY_LIMIT";

/// Bytes of memory available to ember: `EMBER_MEMORY_LIMIT` if set, otherwise the
/// smaller of `MemAvailable` from `/proc/meminfo` and what the memory cgroups this
/// process runs in still allow (containers and CI runners limit memory there, and the
/// machine-wide figure does not see it). `None` where nothing is known (non-Linux), in
/// which case no up-front check is made.
pub fn available_memory() -> Option<u64> {
    if let Some(limit) = std::env::var(MEMORY_LIMIT_ENV)
        .ok()
        .and_then(|v| v.trim().parse::<u64>().ok())
    {
        return Some(limit);
    }
    // Loaders check before each large allocation, hundreds of times in a scene of many
    // meshes: the files are read again only when the last reading is a moment old.
    static LAST: Mutex<Option<(Instant, Option<u64>)>> = Mutex::new(None);
    let mut last = LAST.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    match *last {
        Some((read, available)) if read.elapsed() < Duration::from_millis(50) => available,
        _ => {
            let available = machine_and_cgroup_memory();
            *last = Some((Instant::now(), available));
            available
        }
    }
}

/// The smaller of `MemAvailable` and the memory cgroups' headroom, read now.
fn machine_and_cgroup_memory() -> Option<u64> {
    let machine = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|meminfo| parse_meminfo_available(&meminfo));
    let cgroup = std::fs::read_to_string("/proc/self/cgroup")
        .ok()
        .and_then(|groups| cgroup_headroom(&groups, std::path::Path::new("/sys/fs/cgroup")));
    match (machine, cgroup) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// The least `limit - used` over the memory cgroup of `/proc/self/cgroup` text and its
/// ancestors (a parent's limit binds its children too), under the cgroup mount `root`:
/// cgroup v2's `memory.max`, or v1's `memory.limit_in_bytes`. `used` is the anonymous
/// memory of `memory.stat` (v2's `anon`, v1's `total_rss`), not the whole usage: that
/// counts the page cache too, which after a build can fill the limit and is given back
/// on demand. `None` when no level sets a limit.
pub fn cgroup_headroom(proc_cgroup: &str, root: &std::path::Path) -> Option<u64> {
    let (dir, limit_file, used_key) = proc_cgroup.lines().find_map(|line| {
        let mut fields = line.splitn(3, ':');
        let (_, controllers, path) = (fields.next()?, fields.next()?, fields.next()?);
        let path = path.trim_start_matches('/');
        match controllers {
            "" => Some((root.join(path), "memory.max", "anon ")),
            c if c.split(',').any(|c| c == "memory") => Some((
                root.join("memory").join(path),
                "memory.limit_in_bytes",
                "total_rss ",
            )),
            _ => None,
        }
    })?;
    let read = |level: &std::path::Path, file: &str| std::fs::read_to_string(level.join(file));
    // `max` (v2) does not parse and the v1 "unlimited" is near 2^63: neither is a limit.
    dir.ancestors()
        .take_while(|level| level.starts_with(root))
        .filter_map(|level| {
            let limit: u64 = read(level, limit_file).ok()?.trim().parse().ok()?;
            let stat = read(level, "memory.stat").unwrap_or_default();
            let used = proc_field(&stat, used_key).map_or(0, |(bytes, _)| bytes);
            (limit < 1 << 60).then(|| limit.saturating_sub(used))
        })
        .min()
}

/// The `MemAvailable:` line of `/proc/meminfo` text, in bytes.
pub fn parse_meminfo_available(meminfo: &str) -> Option<u64> {
    let (value, unit) = proc_field(meminfo, "MemAvailable:")?;
    let unit = match unit {
        Some("kB") => 1024,
        None => 1,
        Some(_) => return None,
    };
    value.checked_mul(unit)
}

/// The number and the unit word (if any) of the line `key value [unit]` of a
/// `/proc` text such as `meminfo` or `status`.
fn proc_field<'a>(text: &'a str, key: &str) -> Option<(u64, Option<&'a str>)> {
    let line = text.lines().find(|l| l.starts_with(key))?;
    let mut words = line.split_whitespace().skip(1);
    let value = words.next()?.parse().ok()?;
    Some((value, words.next()))
}

/// The most resident memory this process has held so far (`VmHWM` of
/// `/proc/self/status`), in bytes; `None` off Linux.
pub fn peak_resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    parse_status_peak(&status)
}

/// The resident memory of this process now (`VmRSS`), in bytes; `None` off Linux.
pub fn resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let (kib, unit) = proc_field(&status, "VmRSS:")?;
    (unit == Some("kB")).then(|| kib.checked_mul(1024))?
}

/// Starts [`peak_resident_bytes`] again from the resident memory of now (Linux's
/// `/proc/self/clear_refs`), so that the peak of one stage of work can be measured.
/// Whether it could.
pub fn reset_peak_resident() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// The `VmHWM:` line of `/proc/self/status` text, in bytes.
pub fn parse_status_peak(status: &str) -> Option<u64> {
    let (kib, unit) = proc_field(status, "VmHWM:")?;
    (unit == Some("kB")).then(|| kib.checked_mul(1024))?
}

/// `bytes` for people: "512 B", "3.2 MiB", "17.0 GiB".
pub fn human_bytes(bytes: u64) -> String {
    const UNITS: [&str; 6] = ["B", "KiB", "MiB", "GiB", "TiB", "PiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} B")
    } else {
        format!("{value:.1} {}", UNITS[unit])
    }
}

/// Refuses `what` needing `needed` bytes when the machine has less available.
pub fn check_fits(what: &str, needed: u64) -> Result<(), String> {
    match available_memory() {
        Some(available) if needed > available => Err(format!(
            "{what} needs {} of memory, but only {} is available",
            human_bytes(needed),
            human_bytes(available)
        )),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meminfo_available_is_read_in_bytes() {
        let text = "MemTotal:       24684084 kB\nMemFree:  100 kB\nMemAvailable:   23843344 kB\n";
        assert_eq!(parse_meminfo_available(text), Some(23_843_344 * 1024));
        assert_eq!(parse_meminfo_available("MemTotal: 5 kB\n"), None);
        assert_eq!(parse_meminfo_available("MemAvailable: x kB\n"), None);
    }

    #[test]
    fn peak_resident_memory_is_read_in_bytes() {
        let text = "VmPeak:  900 kB\nVmHWM:\t   502484 kB\nVmRSS: 1 kB\n";
        assert_eq!(parse_status_peak(text), Some(502_484 * 1024));
        assert_eq!(parse_status_peak("VmRSS: 1 kB\n"), None);
        assert!(peak_resident_bytes().is_some_and(|b| b > 0));
    }

    #[test]
    fn cgroup_limits_bind_at_every_level() {
        let root = std::env::temp_dir().join(format!("ember-cgroup-{}", std::process::id()));
        let write = |dir: &std::path::Path, file: &str, text: &str| {
            std::fs::create_dir_all(dir).unwrap();
            std::fs::write(dir.join(file), text).unwrap();
        };
        // v2: the parent's 1000-byte limit (100 anonymous, 800 of page cache) binds the
        // unlimited child.
        let (parent, child) = (root.join("ci"), root.join("ci/job"));
        write(&parent, "memory.max", "1000\n");
        write(&parent, "memory.stat", "anon 100\nfile 800\nanon_thp 0\n");
        write(&child, "memory.max", "max\n");
        write(&child, "memory.stat", "anon 50\nfile 10\n");
        assert_eq!(cgroup_headroom("0::/ci/job\n", &root), Some(900));
        assert_eq!(cgroup_headroom("0::/elsewhere\n", &root), None);
        // v1: the memory controller's own hierarchy; the "unlimited" value is no limit.
        let v1 = root.join("memory/runner");
        write(&v1, "memory.limit_in_bytes", "4096");
        let stat = "cache 3000\nrss 1000\nrss_huge 0\ntotal_cache 3000\ntotal_rss 1024\n";
        write(&v1, "memory.stat", stat);
        write(
            &root.join("memory"),
            "memory.limit_in_bytes",
            "9223372036854771712",
        );
        let groups = "5:cpu,cpuacct:/runner\n4:memory:/runner\n0::/\n";
        assert_eq!(cgroup_headroom(groups, &root), Some(3072));
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn sizes_are_printed_in_binary_units() {
        assert_eq!(human_bytes(512), "512 B");
        assert_eq!(human_bytes(1536), "1.5 KiB");
        assert_eq!(human_bytes(3 << 30), "3.0 GiB");
        assert_eq!(human_bytes(u64::MAX), "16384.0 PiB");
    }
}
