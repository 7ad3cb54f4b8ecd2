//! Serialized FMU states. Format (all integers little-endian):
//! the model's magic bytes (`Slave::STATE_MAGIC`, 8 bytes), format version (u32,
//! `Slave::STATE_FORMAT_VERSION`), GUID length (u32) and bytes, payload length (u64), payload,
//! FNV-1a 64 checksum of the payload (u64). The payload starts with the FMI state (u64, the
//! bits of `FmiState`), followed by what the model's `encode` writes with `Writer`: 64-bit
//! words, or bytes a serializer produced. A state from another format version or another build
//! of the model (GUID), or a truncated or corrupted one, is rejected with a reason.

use crate::instance::{FmiState, Saved};
use crate::Slave;

fn fnv64(data: &[u8]) -> u64 {
    data.iter().fold(0xcbf29ce484222325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x100000001b3)
    })
}

/// Writes a payload: values as little-endian 64-bit words, or bytes as they are.
#[derive(Default)]
pub struct Writer(Vec<u8>);

impl Writer {
    pub fn u(&mut self, x: u64) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    pub fn f(&mut self, x: f64) {
        self.u(x.to_bits());
    }
    pub fn b(&mut self, x: bool) {
        self.u(x as u64);
    }
    pub fn fs(&mut self, xs: &[f64]) {
        xs.iter().for_each(|&x| self.f(x));
    }
    /// Bytes as they are (a payload serialized elsewhere).
    pub fn bytes(&mut self, b: &[u8]) {
        self.0.extend_from_slice(b);
    }
    pub fn into_bytes(self) -> Vec<u8> {
        self.0
    }
    /// An optional real: a flag, then the value (0 if absent).
    pub fn opt(&mut self, x: Option<f64>) {
        self.b(x.is_some());
        self.f(x.unwrap_or(0.0));
    }
}

/// Reads a payload back, failing with a reason at its end or at a malformed value.
pub struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    pub fn new(data: &'a [u8]) -> Reader<'a> {
        Reader { data, pos: 0 }
    }

    pub fn u(&mut self) -> Result<u64, String> {
        let bytes = self
            .data
            .get(self.pos..self.pos + 8)
            .ok_or("payload ends early")?;
        self.pos += 8;
        Ok(u64::from_le_bytes(bytes.try_into().expect("8 bytes")))
    }
    pub fn f(&mut self) -> Result<f64, String> {
        Ok(f64::from_bits(self.u()?))
    }
    pub fn b(&mut self) -> Result<bool, String> {
        match self.u()? {
            0 => Ok(false),
            1 => Ok(true),
            x => Err(format!("a flag reads {x}")),
        }
    }
    pub fn fs<const N: usize>(&mut self) -> Result<[f64; N], String> {
        let mut a = [0.0; N];
        for x in a.iter_mut() {
            *x = self.f()?;
        }
        Ok(a)
    }
    /// All that is left (a payload serialized elsewhere).
    pub fn rest(&mut self) -> &[u8] {
        let rest = &self.data[self.pos..];
        self.pos = self.data.len();
        rest
    }
    pub fn opt(&mut self) -> Result<Option<f64>, String> {
        let present = self.b()?;
        let x = self.f()?;
        Ok(present.then_some(x))
    }
}

/// The payload of an FMU state: the FMI state, then the model.
pub fn encode_payload<S: Slave>(s: &Saved<S>) -> Vec<u8> {
    let mut w = Writer::default();
    w.u(s.state as u64);
    s.slave.encode(&mut w);
    w.0
}

/// Reads a payload; all of it must be used.
pub fn decode_payload<S: Slave>(payload: &[u8], like: &S) -> Result<Saved<S>, String> {
    let mut r = Reader {
        data: payload,
        pos: 0,
    };
    let state = FmiState::from_bits(r.u()?).ok_or("unknown FMI state")?;
    let slave = like.decode_for(&mut r)?;
    if r.pos != payload.len() {
        return Err(format!(
            "{} unread bytes at the end of the payload",
            payload.len() - r.pos
        ));
    }
    Ok(Saved { state, slave })
}

pub fn encode<S: Slave>(s: &Saved<S>) -> Vec<u8> {
    let payload = encode_payload(s);
    let guid = s.slave.instance_guid();
    let mut out = Vec::with_capacity(payload.len() + 80);
    out.extend_from_slice(&S::STATE_MAGIC);
    out.extend_from_slice(&S::STATE_FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&(guid.len() as u32).to_le_bytes());
    out.extend_from_slice(guid.as_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&payload);
    out.extend_from_slice(&fnv64(&payload).to_le_bytes());
    out
}

/// A serialized state of the FMU of `like` (its GUID, and its resources for `decode_for`).
pub fn decode<S: Slave>(bytes: &[u8], like: &S) -> Result<Saved<S>, String> {
    let take = |pos: &mut usize, n: usize| -> Result<&[u8], String> {
        let s = bytes
            .get(*pos..*pos + n)
            .ok_or_else(|| format!("truncated: {} bytes", bytes.len()))?;
        *pos += n;
        Ok(s)
    };
    let mut pos = 0;
    if take(&mut pos, 8)? != S::STATE_MAGIC {
        return Err(format!(
            "not a {} FMU state (bad magic bytes)",
            S::MODEL_NAME
        ));
    }
    let version = u32::from_le_bytes(take(&mut pos, 4)?.try_into().expect("4"));
    if version != S::STATE_FORMAT_VERSION {
        return Err(format!(
            "state format version {version}; this FMU reads version {}",
            S::STATE_FORMAT_VERSION
        ));
    }
    let glen = u32::from_le_bytes(take(&mut pos, 4)?.try_into().expect("4")) as usize;
    let guid = String::from_utf8_lossy(take(&mut pos, glen.min(256))?).into_owned();
    let own = like.instance_guid();
    if guid != own {
        return Err(format!(
            "state of another model build (GUID {guid}, this FMU is {own})"
        ));
    }
    let plen = u64::from_le_bytes(take(&mut pos, 8)?.try_into().expect("8")) as usize;
    if bytes.len() != pos + plen.min(bytes.len()) + 8 || plen > bytes.len() {
        return Err(format!(
            "length mismatch: payload of {plen} bytes in a state of {} bytes",
            bytes.len()
        ));
    }
    let payload = take(&mut pos, plen)?;
    let sum = u64::from_le_bytes(take(&mut pos, 8)?.try_into().expect("8"));
    if sum != fnv64(payload) {
        return Err("checksum mismatch: the state is corrupted".into());
    }
    decode_payload(payload, like)
}
