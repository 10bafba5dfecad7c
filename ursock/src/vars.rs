//! The server's variable table: `SET name v` stores, `GET name` answers. One table for the
//! whole listener, shared by every connection (robot programs reopen their socket each
//! cycle and expect the value to survive), bounded in entries and name length. One
//! connection may create at most half the table's names, so a connection that floods
//! `SET`s of new names cannot leave no room for the others.

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
    /// The connection has created its share of the names (half the table) already.
    Quota(usize),
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

    /// The most new names one connection may create: half the table (at least one).
    pub fn quota(&self) -> usize {
        (self.max / 2).max(1)
    }

    /// `SET name value` from a connection that has created `created` names so far; a new
    /// name counts toward it when stored.
    pub fn set(&mut self, name: &str, value: i32, created: &mut usize) -> SetOutcome {
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
        if *created >= self.quota() {
            return SetOutcome::Quota(self.quota());
        }
        self.map.insert(name.to_string(), value);
        *created += 1;
        SetOutcome::Stored
    }

    pub fn get(&self, name: &str) -> Option<i32> {
        self.map.get(name).copied()
    }

    pub fn len(&self) -> usize {
        self.map.len()
    }
}
