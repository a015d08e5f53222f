//! Finds the installed Embree, generates Rust bindings from *its own* headers with
//! bindgen, links the matching library and tells the crate which major version it got
//! (`cfg(embree3)` or `cfg(embree4)`).
//!
//! Search order (first hit wins):
//! 1. `EMBREE_DIR` — a prefix with `include/embree{4,3}/rtcore.h` and `lib/` (or `lib64/`);
//! 2. pkg-config `embree4`;
//! 3. `/usr/include/embree4` (Debian 13+ `libembree-dev`);
//! 4. `/usr/include/embree3` (Debian 12 `libembree-dev`).
//!
//! With the `denoise` feature it also finds Intel Open Image Denoise, which the `oidn`
//! crate links, and records its folder as an rpath so that ember, its tests and benches
//! run without LD_LIBRARY_PATH: `OIDN_DIR/lib` (the user's, or the repository's `.oidn`
//! from `.cargo/config.toml`, filled by scripts/setup.sh), else pkg-config's
//! `OpenImageDenoise`, else the system's library folders.

use std::env;
use std::path::{Path, PathBuf};
use std::process::exit;

/// Where one Embree installation lives.
struct Embree {
    major: u32,
    /// Directory that contains `embree{major}/rtcore.h`.
    include_dir: PathBuf,
    /// Directory that contains `libembree{major}.so`, when not on the default search path.
    lib_dir: Option<PathBuf>,
}

fn main() {
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo::rustc-check-cfg=cfg(embree3)");
    println!("cargo::rustc-check-cfg=cfg(embree4)");

    if env::var_os("CARGO_FEATURE_DENOISE").is_some() {
        link_oidn();
    }

    let embree = find_embree().unwrap_or_else(|| {
        eprintln!(
            "error: Intel Embree was not found: run `bash scripts/setup.sh` (on Debian it installs \
             libembree-dev, libclang-dev and pkg-config), or install Embree 3 or 4 and point EMBREE_DIR \
             at a prefix holding include/ and lib/"
        );
        exit(1);
    });

    let major = embree.major;
    println!("cargo:rustc-cfg=embree{major}");
    println!(
        "cargo:rustc-env=EMBER_EMBREE_INCLUDE={}",
        embree.include_dir.display()
    );
    if let Some(lib_dir) = &embree.lib_dir {
        println!("cargo:rustc-link-search=native={}", lib_dir.display());
        // A private SDK is not on the loader's path: record it in every binary we link
        // (ember, tests, benches) so they run without LD_LIBRARY_PATH.
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib_dir.display());
    }
    println!("cargo:rustc-link-lib=dylib=embree{major}");

    let header = embree.include_dir.join(format!("embree{major}/rtcore.h"));
    println!("cargo:rerun-if-changed={}", header.display());
    let bindings = bindgen::Builder::default()
        .header(header.to_string_lossy())
        .clang_arg(format!("-I{}", embree.include_dir.display()))
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC_.*")
        .default_enum_style(bindgen::EnumVariation::Consts)
        .prepend_enum_name(false)
        .layout_tests(true)
        .generate_comments(false)
        .generate()
        .unwrap_or_else(|e| {
            eprintln!(
                "error: bindgen could not read the Embree {major} headers in {}: {e} (is libclang-dev installed?)",
                embree.include_dir.display()
            );
            exit(1);
        });
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    bindings
        .write_to_file(out.join("embree_bindings.rs"))
        .expect("OUT_DIR is writable");
}

fn find_embree() -> Option<Embree> {
    if let Some(dir) = env::var_os("EMBREE_DIR").filter(|d| !d.is_empty()) {
        let dir = PathBuf::from(dir);
        let include_dir = dir.join("include");
        let Some(major) = major_in(&include_dir) else {
            eprintln!(
                "error: EMBREE_DIR={} has no include/embree4/rtcore.h or include/embree3/rtcore.h",
                dir.display()
            );
            exit(1);
        };
        let lib_dir = ["lib", "lib64"]
            .iter()
            .map(|l| dir.join(l))
            .find(|l| l.is_dir());
        return Some(Embree {
            major,
            include_dir,
            lib_dir,
        });
    }
    if let Ok(lib) = pkg_config::Config::new()
        .cargo_metadata(false)
        .probe("embree4")
    {
        if let Some(include_dir) = lib
            .include_paths
            .iter()
            .find(|p| p.join("embree4/rtcore.h").is_file())
        {
            return Some(Embree {
                major: 4,
                include_dir: include_dir.clone(),
                lib_dir: lib.link_paths.first().cloned(),
            });
        }
    }
    let system = Path::new("/usr/include");
    major_in(system).map(|major| Embree {
        major,
        include_dir: system.to_path_buf(),
        lib_dir: None,
    })
}

/// The newest Embree major version whose headers sit in `include_dir`.
fn major_in(include_dir: &Path) -> Option<u32> {
    [4, 3]
        .into_iter()
        .find(|m| include_dir.join(format!("embree{m}/rtcore.h")).is_file())
}

/// The folder holding `libOpenImageDenoise.so`, added to the link search and recorded as
/// an rpath; stops the build with how to get the library when there is none.
fn link_oidn() {
    println!("cargo:rerun-if-env-changed=OIDN_DIR");
    const LIB: &str = "libOpenImageDenoise.so";
    let from_env = env::var_os("OIDN_DIR")
        .filter(|d| !d.is_empty())
        .map(|d| PathBuf::from(d).join("lib"));
    if let Some(lib_dir) = &from_env {
        // Rerun once scripts/setup.sh has filled the folder (or someone emptied it).
        println!("cargo:rerun-if-changed={}", lib_dir.join(LIB).display());
    }
    let pkg_config = || {
        pkg_config::Config::new()
            .cargo_metadata(false)
            .probe("OpenImageDenoise")
            .ok()
            .and_then(|lib| lib.link_paths.into_iter().find(|p| p.join(LIB).exists()))
    };
    let system = || {
        [
            "/usr/lib/x86_64-linux-gnu",
            "/usr/lib64",
            "/usr/lib",
            "/usr/local/lib",
        ]
        .into_iter()
        .map(PathBuf::from)
        .find(|p| p.join(LIB).exists())
    };
    let Some(lib_dir) = from_env
        .filter(|d| d.join(LIB).exists())
        .or_else(pkg_config)
        .or_else(system)
    else {
        eprintln!(
            "error: Intel Open Image Denoise was not found (OIDN_DIR={}): run scripts/setup.sh, \
             which fetches it into .oidn/, or point OIDN_DIR at a folder holding lib/{LIB}, \
             or build without denoising: cargo build --no-default-features",
            env::var("OIDN_DIR").unwrap_or_default()
        );
        exit(1);
    };
    println!("cargo:rustc-link-search=native={}", lib_dir.display());
    println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib_dir.display());
    // `ember info` names the library file linked (its name ends in the version: the
    // symbolic links of an installation lead to libOpenImageDenoise.so.MAJOR.MINOR.PATCH).
    let library = lib_dir.join(LIB);
    let library = library.canonicalize().unwrap_or(library);
    println!("cargo:rustc-env=EMBER_OIDN_LIBRARY={}", library.display());
}
