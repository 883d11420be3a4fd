//! The rest of a geometry element from a point inside it on. The daemon replans from where the
//! machine stands or where a hand-over ends (after a hold, an underrun or a feed override
//! change), which is in general inside an element: planning the rest of the path needs the
//! element's remainder as an element of its own.

use super::{AxisDerivs, Geometry};

/// `inner` seen from local path position `offset_mm` on: s ∈ [0, length] maps to
/// `inner` at `offset_mm + s`.
#[derive(Debug, Clone, PartialEq)]
pub struct Suffix {
    inner: Geometry,
    offset_mm: f64,
    length_mm: f64,
}

impl Suffix {
    /// The part of `inner` after `offset_mm` (clamped to the element). A suffix of a suffix
    /// refers to the original element, so repeated restarts do not nest.
    pub(crate) fn new(inner: Geometry, offset_mm: f64) -> Self {
        match inner {
            Geometry::Suffix(s) => {
                let Suffix { inner, offset_mm: base, length_mm } = *s;
                let offset = offset_mm.clamp(0.0, length_mm);
                Suffix { inner, offset_mm: base + offset, length_mm: length_mm - offset }
            }
            inner => {
                let total = inner.length_mm();
                let offset = offset_mm.clamp(0.0, total);
                Suffix { inner, offset_mm: offset, length_mm: total - offset }
            }
        }
    }

    pub(crate) fn length_mm(&self) -> f64 {
        self.length_mm
    }

    pub(crate) fn eval(&self, s_mm: f64, out: &mut AxisDerivs) {
        self.inner.eval(self.offset_mm + s_mm, out);
    }

    /// Where the suffix starts on `inner`, mm.
    pub(crate) fn offset_mm(&self) -> f64 {
        self.offset_mm
    }

    /// The element kind it was cut from.
    pub(crate) fn inner(&self) -> &Geometry {
        &self.inner
    }
}
