//! The arm's recent joint positions, step by step, for
//! `get_actual_joint_positions_history(steps)`: the manual's "actual past angular
//! positions", `steps` controller time steps before the current one, with an exception
//! "if indexing goes beyond the buffer size". The buffer holds [`JOINT_HISTORY_STEPS`]
//! steps.

use std::collections::VecDeque;

/// The steps back the history reaches: 1000, 2 s at the e-Series' 500 Hz (8 s at CB3's
/// 125 Hz). UR does not document its buffer's size; `tool_contact()` counts the steps
/// since a contact began, and a move until contact looks back only that far (a few steps
/// at the speeds contact is sought with).
pub const JOINT_HISTORY_STEPS: u64 = 1000;

/// The joints at each step the arm moved in (a step with no entry: the arm was where the
/// entry before it has it).
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct JointHistory {
    /// (step, joints at the end of that step), oldest first, steps increasing; at most
    /// [`JOINT_HISTORY_STEPS`] + 1 entries.
    entries: VecDeque<(u64, [f64; 6])>,
}

impl JointHistory {
    /// The arm, at `before` until step `step`, is at `q` after step `step`.
    pub(crate) fn record(&mut self, step: u64, before: [f64; 6], q: [f64; 6]) {
        match self.entries.back_mut() {
            Some((s, last)) if *s == step => *last = q,
            back => {
                if back.is_none() || back.is_some_and(|(s, last)| *s + 1 < step && *last != before)
                {
                    // Where it was before it moved (it rested there).
                    self.entries.push_back((step.saturating_sub(1), before));
                }
                self.entries.push_back((step, q));
            }
        }
        let cap = usize::try_from(JOINT_HISTORY_STEPS).unwrap_or(usize::MAX) + 1;
        while self.entries.len() > cap {
            self.entries.pop_front();
        }
    }

    /// The joints `back` steps before step `now`, the arm being at `current` now; an
    /// error past the buffer (or for a negative count).
    pub(crate) fn at(&self, now: u64, back: i64, current: [f64; 6]) -> Result<[f64; 6], String> {
        let Ok(back) = u64::try_from(back) else {
            return Err(format!("steps must be 0 or more, not {back}"));
        };
        if back > JOINT_HISTORY_STEPS {
            return Err(format!(
                "{back} steps back is beyond the history buffer ({JOINT_HISTORY_STEPS} steps)"
            ));
        }
        if back == 0 {
            return Ok(current);
        }
        let target = now.saturating_sub(back);
        Ok(self
            .entries
            .iter()
            .rev()
            .find(|(s, _)| *s <= target)
            .or(self.entries.front())
            .map_or(current, |(_, q)| *q))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn looks_back_to_the_step_asked_for_and_refuses_past_the_buffer() {
        let mut h = JointHistory::default();
        let q = |x: f64| [x, 0.0, 0.0, 0.0, 0.0, 0.0];
        // At rest at 0 until step 10, then 1 mm a step.
        for step in 10..20 {
            h.record(step, q((step - 10) as f64), q((step - 9) as f64));
        }
        assert_eq!(h.at(19, 0, q(10.0)).unwrap(), q(10.0));
        assert_eq!(h.at(19, 1, q(10.0)).unwrap(), q(9.0));
        assert_eq!(h.at(19, 9, q(10.0)).unwrap(), q(1.0));
        assert_eq!(h.at(19, 10, q(10.0)).unwrap(), q(0.0));
        assert_eq!(h.at(19, 15, q(10.0)).unwrap(), q(0.0));
        // Then at rest: the last step it moved in holds.
        assert_eq!(h.at(40, 5, q(10.0)).unwrap(), q(10.0));
        assert!(h.at(40, -1, q(10.0)).is_err());
        assert!(h.at(40, 1001, q(10.0)).is_err());
        // The buffer keeps its bound.
        for step in 20..3000 {
            h.record(step, q(0.0), q(step as f64));
        }
        assert!(h.entries.len() <= 1001);
        assert_eq!(h.at(2999, 1000, q(0.0)).unwrap(), q(1999.0));
    }
}
