//! The server's variable table: `SET name v` stores, `GET name` answers. One table for the
//! whole listener, shared by every connection (robot programs reopen their socket each
//! cycle and expect the value to survive), bounded in entries and name length.

use std::collections::HashMap;

/// Longest variable name stored (bytes). URScript names are short identifiers.
pub const MAX_NAME_LEN: usize = 128;

pub struct Vars {
    map: HashMap<String, i32>,
    max: usize,
}

pub enum SetOutcome {
    Stored,
    /// The table holds `max` names and this one is new.
    Full(usize),
    /// The name is longer than [`MAX_NAME_LEN`].
    NameTooLong(usize),
}

impl Vars {
    pub fn new(max: usize) -> Self {
        Vars {
            map: HashMap::new(),
            max,
        }
    }

    pub fn set(&mut self, name: &str, value: i32) -> SetOutcome {
        if name.len() > MAX_NAME_LEN {
            return SetOutcome::NameTooLong(name.len());
        }
        if let Some(v) = self.map.get_mut(name) {
            *v = value;
            return SetOutcome::Stored;
        }
        if self.map.len() >= self.max {
            return SetOutcome::Full(self.max);
        }
        self.map.insert(name.to_string(), value);
        SetOutcome::Stored
    }

    pub fn get(&self, name: &str) -> Option<i32> {
        self.map.get(name).copied()
    }

    pub fn len(&self) -> usize {
        self.map.len()
    }
}
