//! Checkpoints: each vehicle's complete state (filter, particles and RNG included, the reorder window,
//! the counters) in one file `DIR/<vehicle>.ckpt`, written atomically (a temporary file, fsync,
//! rename, fsync of the directory), so a crash leaves either the previous or the new checkpoint.
//!
//! File layout: the magic `ATTCKPT\0`, the format version (u32 LE), the payload length (u64 LE), the
//! payload's CRC-32 (u32 LE), then the payload ([`format`]: checkpoint structs of their own, converted
//! from and to the core's plain-data states). A file that is short, has another magic or version,
//! fails its CRC or holds a state the core refuses is reported (an error log line naming the file and
//! the reason) and skipped (`checkpoints.skipped`): its vehicle starts afresh.

mod format;

use crate::vehicle::VehicleState;
use bincode::Options;
use format::{CheckpointV5, Saved};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use thiserror::Error;

const MAGIC: &[u8; 8] = b"ATTCKPT\0";
/// 2: a vehicle holds its sensor models' state (`sensors::model::SensorState`).
/// 3: observations have an `aspect`; a vehicle holds its raw-IMU pipeline (`crate::ahrs::Ahrs`), its
/// gyro feed and a third stream; filters their gyro error model (`filters::GyroErrors`).
/// 4: the payload is [`format`]'s own structs, no longer the in-memory object graph (1–3 were bincode
/// of the core types themselves, which cannot be read without them: refused).
/// 5: a filter may be the SGHQF (a new variant of the filter state) and every filter configuration
/// holds its sparse-grid level (4 cannot say either: refused).
/// 6: the raw-IMU pipeline holds the gyro channel (saturation, gaps), the datasheet, the measured
/// noise and the field reference's confirmation; a vehicle's configuration its datasheet (5 cannot
/// say them: refused).
/// 7: the raw-IMU pipeline holds what it recognises of a driver's repeats and a converter's filled
/// holes (`crate::ahrs::repeats`: the last samples' changes, a slower magnetometer's last new reading
/// and its frame; 6 cannot say them: refused).
/// 8: a datasheet states its output stage (`crate::ahrs::Output`: interval means, the gyro's own
/// increments, or values at the time stamp; 7 cannot say it: refused).
/// 9: the rest detector holds its deviations' own low-pass (`crate::ahrs::rest`; 8 cannot say it:
/// refused).
/// 10: the raw-IMU pipeline holds north's variance while the field is unconfirmed, which its
/// published estimates carry, and a datasheet states what a calibration left of the hard-iron offset
/// (`crate::ahrs`; 9 cannot say either: refused).
pub const VERSION: u32 = 10;
const HEADER: usize = 8 + 4 + 8 + 4;
pub const EXTENSION: &str = "ckpt";

/// A vehicle's counters as `P/@/vehicles` reports them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SavedCounters {
    pub received: u64,
    pub processed: u64,
    pub rejected: u64,
    pub rejected_by_code: BTreeMap<String, u64>,
}

/// A checkpoint read back.
pub struct Checkpoint {
    pub state: VehicleState,
    pub counters: SavedCounters,
}

#[derive(Debug, Error)]
pub enum CheckpointError {
    #[error("{path}: {message}")]
    Io { path: String, message: String },
    #[error("{path}: not a checkpoint ({message})")]
    Corrupt { path: String, message: String },
}

/// The checkpoint file of `vehicle` in `dir` (vehicle ids are file-name safe by the contract).
pub fn path_of(dir: &Path, vehicle: &str) -> PathBuf {
    dir.join(format!("{vehicle}.{EXTENSION}"))
}

/// Serialises a vehicle's state and counters into a checkpoint file's bytes.
pub fn encode(state: &VehicleState, counters: &SavedCounters) -> Result<Vec<u8>, String> {
    let payload = bincode::DefaultOptions::new()
        .with_fixint_encoding()
        .serialize(&CheckpointV5 {
            vehicle: state.snapshot().save(),
            counters: counters.save(),
        })
        .map_err(|e| e.to_string())?;
    let mut out = Vec::with_capacity(HEADER + payload.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(&payload).to_le_bytes());
    out.extend_from_slice(&payload);
    Ok(out)
}

/// Reads a checkpoint file's bytes back; `Err` says what is wrong with them.
pub fn decode(bytes: &[u8]) -> Result<Checkpoint, String> {
    if bytes.len() < HEADER {
        return Err(format!("{} bytes, shorter than the header", bytes.len()));
    }
    if &bytes[..8] != MAGIC {
        return Err("wrong magic".into());
    }
    let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().expect("4 bytes"));
    let version = u32_at(8);
    if version < VERSION {
        return Err(format!(
            "format version {version}, written by an earlier build: this build reads format \
             {VERSION} only, the vehicle starts afresh (its next checkpoint replaces this file)"
        ));
    }
    if version != VERSION {
        return Err(format!(
            "format version {version}, this service reads {VERSION}"
        ));
    }
    let len = u64::from_le_bytes(bytes[12..20].try_into().expect("8 bytes")) as usize;
    let payload = &bytes[HEADER..];
    if payload.len() != len {
        return Err(format!(
            "payload of {} bytes, the header says {len} (a partial write?)",
            payload.len()
        ));
    }
    if crc32fast::hash(payload) != u32_at(20) {
        return Err("CRC mismatch".into());
    }
    // The limit keeps a damaged length field from asking for more memory than the file holds.
    let c: CheckpointV5 = bincode::DefaultOptions::new()
        .with_fixint_encoding()
        .with_limit(len as u64)
        .deserialize(payload)
        .map_err(|e| e.to_string())?;
    let snapshot = crate::vehicle::VehicleSnapshot::load(c.vehicle)?;
    Ok(Checkpoint {
        state: VehicleState::restore(snapshot)?,
        counters: SavedCounters::load(c.counters)?,
    })
}

/// Writes `bytes` as `vehicle`'s checkpoint, atomically.
pub fn write_atomic(dir: &Path, vehicle: &str, bytes: &[u8]) -> Result<(), CheckpointError> {
    let path = path_of(dir, vehicle);
    let tmp = dir.join(format!(".{vehicle}.{EXTENSION}.tmp"));
    let io = |p: &Path, e: std::io::Error| CheckpointError::Io {
        path: p.display().to_string(),
        message: e.to_string(),
    };
    {
        let mut f = std::fs::File::create(&tmp).map_err(|e| io(&tmp, e))?;
        f.write_all(bytes).map_err(|e| io(&tmp, e))?;
        f.sync_all().map_err(|e| io(&tmp, e))?;
    }
    std::fs::rename(&tmp, &path).map_err(|e| io(&path, e))?;
    // The rename is durable once the directory is synced.
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// Every checkpoint in `dir`: the good ones, and what was wrong with the others (skipped).
pub fn load_dir(dir: &Path) -> Result<(Vec<Checkpoint>, Vec<CheckpointError>), CheckpointError> {
    let entries = std::fs::read_dir(dir).map_err(|e| CheckpointError::Io {
        path: dir.display().to_string(),
        message: e.to_string(),
    })?;
    let mut paths: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension().is_some_and(|x| x == EXTENSION)
                && !p
                    .file_name()
                    .is_some_and(|n| n.to_string_lossy().starts_with('.'))
        })
        .collect();
    paths.sort();
    let mut good = Vec::new();
    let mut bad = Vec::new();
    for p in paths {
        let corrupt = |message: String| CheckpointError::Corrupt {
            path: p.display().to_string(),
            message,
        };
        match std::fs::read(&p) {
            Err(e) => bad.push(CheckpointError::Io {
                path: p.display().to_string(),
                message: e.to_string(),
            }),
            Ok(bytes) => match decode(&bytes) {
                Ok(c) => {
                    let expected = p.file_stem().map(|s| s.to_string_lossy().to_string());
                    if expected.as_deref() == Some(c.state.id()) {
                        good.push(c);
                    } else {
                        bad.push(corrupt(format!(
                            "holds vehicle '{}', not the one its name says",
                            c.state.id()
                        )));
                    }
                }
                Err(m) => bad.push(corrupt(m)),
            },
        }
    }
    Ok((good, bad))
}
