//! Online trajectory generation (OTG): time-optimal, jerk-limited state-to-state motion.
