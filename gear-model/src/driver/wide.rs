//! A fixed-size vector longer than serde's arrays (32): the gear train's event margins.

use super::Vector;
use serde::de::{Error, SeqAccess, Visitor};
use serde::ser::SerializeTuple;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::ops::{Deref, DerefMut, Index, IndexMut};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wide<const N: usize>(pub [f64; N]);

impl<const N: usize> Index<usize> for Wide<N> {
    type Output = f64;
    #[inline(always)]
    fn index(&self, i: usize) -> &f64 {
        &self.0[i]
    }
}

impl<const N: usize> IndexMut<usize> for Wide<N> {
    #[inline(always)]
    fn index_mut(&mut self, i: usize) -> &mut f64 {
        &mut self.0[i]
    }
}

/// A state is read and written by the model as a slice, whatever its capacity.
impl<const N: usize> Deref for Wide<N> {
    type Target = [f64];
    #[inline(always)]
    fn deref(&self) -> &[f64] {
        &self.0
    }
}

impl<const N: usize> DerefMut for Wide<N> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [f64] {
        &mut self.0
    }
}

impl<const N: usize> Wide<N> {
    /// The first M components, the rest 0 (a state moved to another capacity: components past
    /// a model's `dim` are 0).
    pub fn resized<const M: usize>(&self) -> Wide<M> {
        Wide(std::array::from_fn(|i| {
            self.0.get(i).copied().unwrap_or(0.0)
        }))
    }
}

impl<const N: usize> Vector for Wide<N> {
    const LEN: usize = N;
    fn zeros() -> Self {
        Wide([0.0; N])
    }
    fn from_fn(f: impl FnMut(usize) -> f64) -> Self {
        Wide(std::array::from_fn(f))
    }
    fn as_slice(&self) -> &[f64] {
        &self.0
    }
    fn as_mut_slice(&mut self) -> &mut [f64] {
        &mut self.0
    }
}

impl<const N: usize> Serialize for Wide<N> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(N)?;
        for x in &self.0 {
            t.serialize_element(x)?;
        }
        t.end()
    }
}

impl<'de, const N: usize> Deserialize<'de> for Wide<N> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<const N: usize>;
        impl<'de, const N: usize> Visitor<'de> for V<N> {
            type Value = Wide<N>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                write!(f, "{N} reals")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Wide<N>, A::Error> {
                let mut out = [0.0; N];
                for (i, x) in out.iter_mut().enumerate() {
                    *x = seq
                        .next_element()?
                        .ok_or_else(|| A::Error::invalid_length(i, &self))?;
                }
                Ok(Wide(out))
            }
        }
        d.deserialize_tuple(N, V::<N>)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_through_postcard() {
        let w = Wide::<40>(std::array::from_fn(|i| i as f64 * 0.5 - 3.0));
        let bytes = postcard::to_allocvec(&w).unwrap();
        assert_eq!(postcard::from_bytes::<Wide<40>>(&bytes).unwrap(), w);
        assert!(postcard::from_bytes::<Wide<40>>(&bytes[..bytes.len() - 8]).is_err());
    }
}
