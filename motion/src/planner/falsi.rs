//! Regula falsi with the Illinois modification, for the step searches (`step::max_feasible`,
//! `branch::greedy_step`): a bracket whose lower end is acceptable and whose upper end is not,
//! narrowed by the root of the secant through both ends' values. Where one end is kept twice
//! in a row, its value's weight is halved, so the secant cannot stall against it. The values
//! themselves stay true (a caller may test them), only the secant sees the weights.

/// Illinois weights of a bracket's two ends and which end moved last.
#[derive(Debug, Clone, Copy)]
pub(super) struct Illinois {
    w_lo: f64,
    w_hi: f64,
    /// +1: the lower end moved last; −1: the upper one; 0: neither yet.
    side: i8,
}

impl Default for Illinois {
    fn default() -> Self {
        Illinois { w_lo: 1.0, w_hi: 1.0, side: 0 }
    }
}

impl Illinois {
    /// The next point inside (x_lo, x_hi): the root of the secant through the weighted values,
    /// kept `margin` (a share of the bracket) away from either end, or the midpoint where the
    /// upper end's value is unknown or not above the lower end's.
    pub(super) fn next(&self, (x_lo, f_lo): (f64, f64), (x_hi, f_hi): (f64, Option<f64>), margin: f64) -> f64 {
        let f_lo = self.w_lo * f_lo;
        match f_hi.map(|f| self.w_hi * f) {
            Some(f_hi) if f_hi > f_lo => x_lo + (-f_lo / (f_hi - f_lo)).clamp(margin, 1.0 - margin) * (x_hi - x_lo),
            _ => 0.5 * (x_lo + x_hi),
        }
    }

    /// The lower end moved to the last point.
    pub(super) fn lower_moved(&mut self) {
        self.w_lo = 1.0;
        if self.side == 1 {
            self.w_hi *= 0.5;
        }
        self.side = 1;
    }

    /// The upper end moved to the last point.
    pub(super) fn upper_moved(&mut self) {
        self.w_hi = 1.0;
        if self.side == -1 {
            self.w_lo *= 0.5;
        }
        self.side = -1;
    }

    /// The upper end moved to the last point, where no value exists (the next point bisects).
    pub(super) fn upper_moved_unvalued(&mut self) {
        self.side = -1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A value kept twice is halved, cumulatively, and reset when its end moves.
    #[test]
    fn the_end_kept_twice_weighs_half() {
        let mut b = Illinois::default();
        // f(0) = −1, f(1) = 3: the secant root is 0.25.
        assert_eq!(b.next((0.0, -1.0), (1.0, Some(3.0)), 0.0), 0.25);
        b.lower_moved();
        assert_eq!(b.next((0.0, -1.0), (1.0, Some(3.0)), 0.0), 0.25);
        b.lower_moved();
        assert_eq!(b.next((0.0, -1.0), (1.0, Some(3.0)), 0.0), 1.0 / 2.5);
        b.lower_moved();
        assert_eq!(b.next((0.0, -1.0), (1.0, Some(3.0)), 0.0), 1.0 / 1.75);
        b.upper_moved();
        assert_eq!(b.next((0.0, -1.0), (1.0, Some(3.0)), 0.0), 0.25);
        assert_eq!(b.next((0.0, -1.0), (1.0, None), 0.0), 0.5);
        assert_eq!(b.next((0.0, -1.0), (1.0, Some(3.0)), 0.3), 0.3);
    }
}
