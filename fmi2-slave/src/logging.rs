//! Logging through the master's callback, filtered by the log categories the model declares in
//! its modelDescription (`Slave::LOG_CATEGORIES`).
//!
//! Two kinds of category: the status categories (`logStatusWarning`, `logStatusDiscard`,
//! `logStatusError`, `logStatusFatal`: every non-OK status is explained in one of them) are
//! reported unless the master switches them off by name; all others (debug categories such as
//! `logEvents`) follow the `loggingOn` of fmi2Instantiate and fmi2SetDebugLogging. A status
//! category the model does not declare is always reported, a debug one never.

use crate::{ComponentEnvironment, LoggerFn, Status};
use std::ffi::CString;
use std::os::raw::c_char;

/// Category names recommended by the FMI 2.0 standard (section 2.1.5).
pub const LOG_EVENTS: &str = "logEvents";
pub const LOG_STATUS_WARNING: &str = "logStatusWarning";
pub const LOG_STATUS_DISCARD: &str = "logStatusDiscard";
pub const LOG_STATUS_ERROR: &str = "logStatusError";
pub const LOG_STATUS_FATAL: &str = "logStatusFatal";

/// The category that explains a status.
pub fn status_category(s: Status) -> &'static str {
    match s {
        Status::Warning => LOG_STATUS_WARNING,
        Status::Discard => LOG_STATUS_DISCARD,
        Status::Fatal => LOG_STATUS_FATAL,
        _ => LOG_STATUS_ERROR,
    }
}

fn is_status_category(name: &str) -> bool {
    name.starts_with("logStatus")
}

/// fmi3LogMessageCallback: (instanceEnvironment, status, category, message), not printf-style.
pub type Fmi3LogFn =
    unsafe extern "C" fn(ComponentEnvironment, Status, *const c_char, *const c_char);

/// The master's logging callback, of either FMI version.
#[derive(Clone, Copy)]
enum Callback {
    Fmi2(LoggerFn),
    Fmi3(Fmi3LogFn),
}

pub struct Logger {
    callback: Option<Callback>,
    env: ComponentEnvironment,
    instance_name: CString,
    categories: &'static [&'static str],
    /// Switch of each of `categories`.
    enabled: Vec<bool>,
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
        categories: &'static [&'static str],
        debug: bool,
    ) -> Logger {
        let mut l = Logger {
            callback: callback.map(Callback::Fmi2),
            env,
            instance_name: c_text(instance_name),
            categories,
            enabled: vec![false; categories.len()],
        };
        l.set_all(debug);
        l
    }

    /// A logger for an FMI 3.0 instance (its callback has no instance name).
    pub fn new_fmi3(
        callback: Option<Fmi3LogFn>,
        env: ComponentEnvironment,
        categories: &'static [&'static str],
        debug: bool,
    ) -> Logger {
        let mut l = Logger::new(None, env, "", categories, debug);
        l.callback = callback.map(Callback::Fmi3);
        l
    }

    /// The categories of the model, as in its modelDescription.
    pub fn categories(&self) -> &'static [&'static str] {
        self.categories
    }

    /// Debug categories follow `on`; status categories (warnings, discards, errors) are always
    /// reported unless switched off by name.
    pub fn set_all(&mut self, on: bool) {
        for (e, name) in self.enabled.iter_mut().zip(self.categories) {
            *e = on || is_status_category(name);
        }
    }

    /// Switches one category by name; false if the model declares no such category.
    pub fn set(&mut self, name: &str, on: bool) -> bool {
        match self.categories.iter().position(|c| *c == name) {
            Some(i) => {
                self.enabled[i] = on;
                true
            }
            None => false,
        }
    }

    pub fn enabled(&self, category: &str) -> bool {
        self.callback.is_some()
            && match self.categories.iter().position(|c| *c == category) {
                Some(i) => self.enabled[i],
                None => is_status_category(category),
            }
    }

    pub fn log(&self, status: Status, category: &str, message: &str) {
        if !self.enabled(category) {
            return;
        }
        match self.callback {
            Some(Callback::Fmi2(cb)) => {
                let category = c_text(category);
                let text = c_text(message);
                // SAFETY: the master gave this callback for exactly these arguments; every
                // string is NUL-terminated and outlives the call, and the message has no
                // unescaped %.
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
            Some(Callback::Fmi3(cb)) => {
                let plain = |s: &str| CString::new(s.replace('\0', " ")).expect("NULs replaced");
                let (category, text) = (plain(category), plain(message));
                // SAFETY: as above; FMI 3.0 messages are not formatted by the master.
                unsafe { cb(self.env, status, category.as_ptr(), text.as_ptr()) };
            }
            None => {}
        }
    }

    /// Explains a non-OK status in its status category.
    pub fn log_status(&self, status: Status, message: &str) {
        self.log(status, status_category(status), message);
    }
}
