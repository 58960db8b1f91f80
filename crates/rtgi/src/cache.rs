//! A content-addressed cache on disk for precomputed data (e.g. `prt`'s transfer vectors): an entry is a
//! file named by its kind and key, where the key hashes everything the data depends on, so a stale
//! entry is never found rather than needing to be invalidated. Entries are written whole (to a
//! temporary file, then renamed) and carry their key and length, so a torn or foreign file reads as a
//! miss.

use std::path::{Path, PathBuf};

pub use crate::stable_hash::StableHasher;

/// Where precomputed data is cached: `$RTGI_CACHE_DIR/precomputed`, else
/// `$XDG_CACHE_HOME/rtgi/precomputed`, else `~/.cache/rtgi/precomputed`, else `./.rtgi-cache/precomputed`
/// (beside the path-traced references, which `RTGI_CACHE_DIR` also moves).
pub fn precomputed_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("RTGI_CACHE_DIR") {
        return PathBuf::from(d).join("precomputed");
    }
    if let Some(d) = std::env::var_os("XDG_CACHE_HOME") {
        return PathBuf::from(d).join("rtgi").join("precomputed");
    }
    if let Some(home) = std::env::var_os("HOME") {
        return PathBuf::from(home).join(".cache").join("rtgi").join("precomputed");
    }
    PathBuf::from(".rtgi-cache").join("precomputed")
}

/// The first bytes of every entry.
const MAGIC: &[u8; 8] = b"RTGIPRE1";

/// Entries of one kind in one directory.
#[derive(Clone, Debug)]
pub struct DiskCache {
    pub dir: PathBuf,
    pub kind: &'static str,
}

impl DiskCache {
    pub fn new(dir: PathBuf, kind: &'static str) -> Self {
        DiskCache { dir, kind }
    }

    /// The file of the entry `key`.
    pub fn path(&self, key: u64) -> PathBuf {
        self.dir.join(format!("{}-{key:016x}.bin", self.kind))
    }

    /// The entry `key` if it exists and holds exactly `len` bytes of data; anything else is a miss.
    pub fn load(&self, key: u64, len: usize) -> Option<Vec<u8>> {
        let bytes = std::fs::read(self.path(key)).ok()?;
        let header = MAGIC.len() + 16;
        let (head, data) = bytes.split_at_checked(header)?;
        let stored_key = u64::from_le_bytes(head[8..16].try_into().ok()?);
        let stored_len = u64::from_le_bytes(head[16..24].try_into().ok()?);
        (head[..8] == MAGIC[..] && stored_key == key && stored_len == len as u64 && data.len() == len)
            .then(|| data.to_vec())
    }

    /// Writes the entry `key`; an error names the file and the problem.
    pub fn store(&self, key: u64, data: &[u8]) -> Result<PathBuf, String> {
        let path = self.path(key);
        let fail =
            |p: &Path, e: std::io::Error| format!("{}: cannot write the cache entry: {e}", p.display());
        std::fs::create_dir_all(&self.dir).map_err(|e| fail(&self.dir, e))?;
        let mut bytes = Vec::with_capacity(MAGIC.len() + 16 + data.len());
        bytes.extend_from_slice(MAGIC);
        bytes.extend_from_slice(&key.to_le_bytes());
        bytes.extend_from_slice(&(data.len() as u64).to_le_bytes());
        bytes.extend_from_slice(data);
        // Unique per process and entry, so concurrent writers of one entry do not mix their bytes.
        let temporary = self.dir.join(format!(".{}-{key:016x}.{}.tmp", self.kind, std::process::id()));
        std::fs::write(&temporary, &bytes).map_err(|e| fail(&temporary, e))?;
        std::fs::rename(&temporary, &path).map_err(|e| {
            let _ = std::fs::remove_file(&temporary);
            fail(&path, e)
        })?;
        Ok(path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_round_trip_and_anything_else_is_a_miss() {
        let dir = tempfile::tempdir().expect("temp dir");
        let cache = DiskCache::new(dir.path().join("nested"), "test");
        let data: Vec<u8> = (0..1000u32).map(|i| (i * 7) as u8).collect();
        assert_eq!(cache.load(42, data.len()), None, "empty cache");
        let path = cache.store(42, &data).expect("store");
        assert_eq!(path, cache.path(42));
        assert_eq!(cache.load(42, data.len()), Some(data.clone()));
        assert_eq!(cache.load(43, data.len()), None, "another key");
        assert_eq!(cache.load(42, data.len() - 1), None, "another length");
        // A torn file (the data cut short) and a file of another key under this name are misses.
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 1]).unwrap();
        assert_eq!(cache.load(42, data.len()), None, "torn");
        std::fs::write(cache.path(43), &bytes).unwrap();
        assert_eq!(cache.load(43, data.len()), None, "foreign key");
        // No temporary files are left behind.
        let names: Vec<String> = std::fs::read_dir(&cache.dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert!(names.iter().all(|n| !n.ends_with(".tmp")), "{names:?}");
    }

    #[test]
    fn an_unwritable_directory_is_an_error_naming_it() {
        let dir = tempfile::tempdir().expect("temp dir");
        let file = dir.path().join("a-file");
        std::fs::write(&file, b"x").unwrap();
        let cache = DiskCache::new(file.join("below"), "test");
        let error = cache.store(1, b"data").expect_err("a file is not a directory");
        assert!(error.contains("a-file") && error.contains("cannot write"), "{error}");
    }
}
