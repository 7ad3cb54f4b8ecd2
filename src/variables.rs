//! The variable table, generated from `modelDescription/variables.toml` by build.rs: `Var` with
//! its value references, and the structs `Params`, `Inputs`, `Outputs`, `Calculated`.
include!(concat!(env!("OUT_DIR"), "/variables.rs"));

/// The modelDescription.xml generated from the same table (the packaging step writes the same text).
pub const MODEL_DESCRIPTION_XML: &str =
    include_str!(concat!(env!("OUT_DIR"), "/modelDescription.xml"));

impl Range {
    /// Why x lies outside the bounds ("must be > 0"), or None.
    pub fn violation(&self, x: f64) -> Option<String> {
        let below = self
            .min
            .is_some_and(|m| x < m || (self.exclusive_min && x == m));
        let above = self
            .max
            .is_some_and(|m| x > m || (self.exclusive_max && x == m));
        if !(below || above) {
            return None;
        }
        let (lo, hi) = (
            if self.exclusive_min { "(" } else { "[" },
            if self.exclusive_max { ")" } else { "]" },
        );
        Some(match (self.min, self.max) {
            (Some(a), Some(b)) => format!("must lie in {lo}{a}, {b}{hi}"),
            (Some(a), None) => format!(
                "must be {} {a}",
                if self.exclusive_min { ">" } else { ">=" }
            ),
            (None, Some(b)) => format!(
                "must be {} {b}",
                if self.exclusive_max { "<" } else { "<=" }
            ),
            (None, None) => unreachable!("a violation needs a bound"),
        })
    }
}
