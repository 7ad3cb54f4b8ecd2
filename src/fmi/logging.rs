//! Logging through the master's callback, filtered by the categories of the modelDescription.

use super::{ComponentEnvironment, LoggerFn, Status};
use crate::variables::LOG_CATEGORIES;
use std::ffi::CString;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Category {
    Events,
    Solver,
    Warning,
    Discard,
    Error,
    Fatal,
}

impl Category {
    fn index(self) -> usize {
        self as usize
    }

    pub fn name(self) -> &'static str {
        LOG_CATEGORIES[self.index()]
    }

    pub fn for_status(s: Status) -> Category {
        match s {
            Status::Warning => Category::Warning,
            Status::Discard => Category::Discard,
            Status::Fatal => Category::Fatal,
            _ => Category::Error,
        }
    }
}

pub struct Logger {
    callback: Option<LoggerFn>,
    env: ComponentEnvironment,
    instance_name: CString,
    enabled: [bool; 6],
}

/// The master's logger formats the message printf-style: a literal % must be doubled.
fn c_text(s: &str) -> CString {
    CString::new(s.replace('%', "%%").replace('\0', " ")).expect("NULs were replaced")
}

impl Logger {
    pub fn new(
        callback: Option<LoggerFn>,
        env: ComponentEnvironment,
        instance_name: &str,
        debug: bool,
    ) -> Logger {
        let mut l = Logger {
            callback,
            env,
            instance_name: c_text(instance_name),
            enabled: [false; 6],
        };
        l.set_all(debug);
        l
    }

    /// Debug categories follow `on`; status categories (warnings, discards, errors) are always
    /// reported unless switched off by name.
    pub fn set_all(&mut self, on: bool) {
        self.enabled = [on, on, true, true, true, true];
    }

    /// Switches one category by name; false if the modelDescription declares no such category.
    pub fn set(&mut self, name: &str, on: bool) -> bool {
        match LOG_CATEGORIES.iter().position(|c| *c == name) {
            Some(i) => {
                self.enabled[i] = on;
                true
            }
            None => false,
        }
    }

    pub fn enabled(&self, c: Category) -> bool {
        self.callback.is_some() && self.enabled[c.index()]
    }

    pub fn log(&self, status: Status, c: Category, message: &str) {
        if let (true, Some(cb)) = (self.enabled(c), self.callback) {
            let category = c_text(c.name());
            let text = c_text(message);
            // SAFETY: the master gave this callback for exactly these arguments; every string is
            // NUL-terminated and outlives the call, and the message has no unescaped %.
            unsafe {
                cb(
                    self.env,
                    self.instance_name.as_ptr(),
                    status,
                    category.as_ptr(),
                    text.as_ptr(),
                )
            };
        }
    }
}
