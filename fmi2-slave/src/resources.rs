//! Where an FMU's resources are: FMI 2.0 passes a URI (`file:///C:/x/resources`,
//! `file:/tmp/x/resources`, percent-encoded), FMI 3.0 a native path.

use std::path::PathBuf;

/// The directory a resource location names; None for a location that is empty or not a local
/// file URI (a model that needs its resources refuses to instantiate then).
pub fn directory(location: &str) -> Option<PathBuf> {
    if location.is_empty() {
        return None;
    }
    let Some(rest) = location.strip_prefix("file:") else {
        // FMI 3.0's resourcePath, or a master that passes a path where a URI belongs.
        return (!location.contains("://")).then(|| PathBuf::from(location));
    };
    // file:///p and file://localhost/p name /p; file:/p too (FMPy before 0.3 passed that).
    let path = match rest.strip_prefix("//") {
        Some(r) => r.strip_prefix("localhost").unwrap_or(r),
        None => rest,
    };
    if !path.starts_with('/') {
        return None;
    }
    let decoded = percent_decode(path)?;
    // file:///C:/dir: a Windows drive after the slash.
    let b = decoded.as_bytes();
    let native = if b.len() >= 3 && b[0] == b'/' && b[1].is_ascii_alphabetic() && b[2] == b':' {
        &decoded[1..]
    } else {
        &decoded[..]
    };
    Some(PathBuf::from(native))
}

fn percent_decode(s: &str) -> Option<String> {
    let mut out = Vec::with_capacity(s.len());
    let mut bytes = s.bytes();
    while let Some(c) = bytes.next() {
        if c == b'%' {
            let hex = [bytes.next()?, bytes.next()?];
            out.push(u8::from_str_radix(std::str::from_utf8(&hex).ok()?, 16).ok()?);
        } else {
            out.push(c);
        }
    }
    String::from_utf8(out).ok()
}

#[cfg(test)]
mod tests {
    use super::directory;
    use std::path::PathBuf;

    #[test]
    fn the_forms_masters_pass() {
        let p = |s: &str| Some(PathBuf::from(s));
        assert_eq!(
            directory("file:///tmp/a%20b/resources"),
            p("/tmp/a b/resources")
        );
        assert_eq!(directory("file:/tmp/x/resources/"), p("/tmp/x/resources/"));
        assert_eq!(directory("file://localhost/tmp/x"), p("/tmp/x"));
        assert_eq!(
            directory("file:///C:/Users/x/resources"),
            p("C:/Users/x/resources")
        );
        assert_eq!(directory("/tmp/fmi3/resources/"), p("/tmp/fmi3/resources/"));
        assert_eq!(directory(""), None);
        assert_eq!(directory("http://example.com/r"), None);
        assert_eq!(directory("file://server/share"), None);
        assert_eq!(directory("file:///bad%zz"), None);
    }
}
