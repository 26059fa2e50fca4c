//! A job store on a disk that can fill up: an in-memory redb backend whose writes fail with
//! ENOSPC ("No space left on device") while it is set full. Its bytes outlive the databases
//! opened on it, as a file's would, so a test can close, reopen and "restart" the store.
//! For tests of the store's recovery ([`crate::store::Store::with_opener`]).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use redb::backends::InMemoryBackend;
use redb::{Database, StorageBackend};

/// Cloning shares the bytes and the full flag.
#[derive(Debug, Clone, Default)]
pub struct FillableDisk {
    bytes: Arc<InMemoryBackend>,
    full: Arc<AtomicBool>,
}

impl FillableDisk {
    /// Makes every later write fail (`true`) or succeed again (`false`).
    pub fn set_full(&self, full: bool) {
        self.full.store(full, Ordering::SeqCst);
    }

    /// Opens (or creates) a database on this disk.
    ///
    /// # Errors
    /// redb's, e.g. when the disk is full while the database is created.
    pub fn open(&self) -> Result<Database, redb::DatabaseError> {
        Database::builder().create_with_backend(self.clone())
    }

    fn check(&self) -> Result<(), std::io::Error> {
        if self.full.load(Ordering::SeqCst) {
            return Err(std::io::Error::from_raw_os_error(28));
        }
        Ok(())
    }
}

impl StorageBackend for FillableDisk {
    fn len(&self) -> Result<u64, std::io::Error> {
        self.bytes.len()
    }

    fn read(&self, offset: u64, out: &mut [u8]) -> Result<(), std::io::Error> {
        self.bytes.read(offset, out)
    }

    fn set_len(&self, len: u64) -> Result<(), std::io::Error> {
        self.check()?;
        self.bytes.set_len(len)
    }

    fn sync_data(&self) -> Result<(), std::io::Error> {
        self.check()?;
        self.bytes.sync_data()
    }

    fn write(&self, offset: u64, data: &[u8]) -> Result<(), std::io::Error> {
        self.check()?;
        self.bytes.write(offset, data)
    }
}
