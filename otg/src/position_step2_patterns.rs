//! Step 2 profiles without a cruise phase (filled in below).

use crate::frame::Frame;
use crate::position_step2::Step2;

/// Try the no-cruise profile families in turn; true once one is accepted.
pub(crate) fn try_all(_f: &Frame, _t_total: f64, _s2: &mut Step2) -> bool {
    false
}
