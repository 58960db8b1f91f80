//! Hashes the library sources that shape a path-traced reference (the rule and the hash live in
//! `src/reference/sources.rs`, shared with the library's test of it) into `RTGI_REFERENCE_SOURCES_HASH`,
//! part of every reference's cache key: a change to the path tracer, the BVH build, the sampling
//! tables, the shared WGSL or the renderer then renders references anew instead of reusing stale ones.

#[allow(dead_code)]
mod stable_hash {
    include!("src/stable_hash.rs");
}

#[allow(dead_code)]
mod sources {
    include!("src/reference/sources.rs");
}

fn main() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut dirs = Vec::new();
    let files = match sources::collect_reference_sources(&root, &mut dirs) {
        Ok(files) => files,
        Err(e) => panic!("{}: cannot read the sources to hash for reference keys: {e}", root.display()),
    };
    // Every hashed file, and every folder (cargo scans a folder for changes, so a new file reruns this).
    for dir in &dirs {
        println!("cargo:rerun-if-changed={}", dir.display());
    }
    for (path, _) in &files {
        println!("cargo:rerun-if-changed=src/{path}");
    }
    println!("cargo:rustc-env=RTGI_REFERENCE_SOURCES_HASH={:016x}", sources::hash_sources(&files));
}
