//! Typed, documented parameters shared by techniques and built-in scenes.
//!
//! A technique or scene declares a list of [`ParamSpec`]s; user input arrives as `key=value` strings and
//! is validated against the specs into [`ParamValues`]. `rtgi list` prints the specs.

use std::collections::BTreeMap;
use std::fmt;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ParamKind {
    Int {
        min: i64,
        max: i64,
    },
    Float {
        min: f64,
        max: f64,
    },
    Bool,
    /// One of a fixed set of words.
    Choice(&'static [&'static str]),
    /// `WxH`, both in `1..=max`.
    Size2 {
        max: u32,
    },
    /// A 3-D grid's counts: `N` along its longest axis (the others follow the shape it covers) or
    /// `XxYxZ` exactly; every count in `min..=max`.
    GridCounts {
        min: u32,
        max: u32,
    },
}

/// The value of a [`ParamKind::GridCounts`] parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GridCounts {
    AlongLongest(u32),
    Exact([u32; 3]),
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamSpec {
    pub name: &'static str,
    pub kind: ParamKind,
    pub default: &'static str,
    pub doc: &'static str,
}

#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    Int(i64),
    Float(f64),
    Bool(bool),
    Choice(String),
    Size2(u32, u32),
    GridCounts(GridCounts),
}

impl fmt::Display for ParamValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamValue::Int(v) => write!(f, "{v}"),
            ParamValue::Float(v) => write!(f, "{v}"),
            ParamValue::Bool(v) => write!(f, "{v}"),
            ParamValue::Choice(v) => write!(f, "{v}"),
            ParamValue::Size2(w, h) => write!(f, "{w}x{h}"),
            ParamValue::GridCounts(GridCounts::AlongLongest(n)) => write!(f, "{n}"),
            ParamValue::GridCounts(GridCounts::Exact([x, y, z])) => write!(f, "{x}x{y}x{z}"),
        }
    }
}

impl fmt::Display for ParamKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamKind::Int { min, max } => write!(f, "int {min}..={max}"),
            ParamKind::Float { min, max } => write!(f, "float {min}..={max}"),
            ParamKind::Bool => write!(f, "bool"),
            ParamKind::Choice(c) => write!(f, "one of {}", c.join("|")),
            ParamKind::Size2 { max } => write!(f, "WxH up to {max}"),
            ParamKind::GridCounts { min, max } => write!(f, "N or XxYxZ, each {min}..={max}"),
        }
    }
}

/// Parses `WxH` (e.g. `256x256`), both sides positive.
pub fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let (w, h) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{text}' is not a size; expected WxH, e.g. 256x256"))?;
    let w: u32 = w.trim().parse().map_err(|_| format!("'{text}': width '{w}' is not a whole number"))?;
    let h: u32 = h.trim().parse().map_err(|_| format!("'{text}': height '{h}' is not a whole number"))?;
    if w == 0 || h == 0 {
        return Err(format!("'{text}' is empty; width and height must be at least 1"));
    }
    Ok((w, h))
}

impl ParamSpec {
    pub fn parse(&self, text: &str) -> Result<ParamValue, String> {
        let text = text.trim();
        let name = self.name;
        match self.kind {
            ParamKind::Int { min, max } => {
                let v: i64 = text.parse().map_err(|_| format!("{name}: '{text}' is not an integer"))?;
                if v < min || v > max {
                    return Err(format!("{name}: {v} is outside {min}..={max}"));
                }
                Ok(ParamValue::Int(v))
            }
            ParamKind::Float { min, max } => {
                let v: f64 = text.parse().map_err(|_| format!("{name}: '{text}' is not a number"))?;
                if !v.is_finite() || v < min || v > max {
                    return Err(format!("{name}: {v} is outside {min}..={max}"));
                }
                Ok(ParamValue::Float(v))
            }
            ParamKind::Bool => match text {
                "true" | "1" | "on" | "yes" => Ok(ParamValue::Bool(true)),
                "false" | "0" | "off" | "no" => Ok(ParamValue::Bool(false)),
                _ => Err(format!("{name}: '{text}' is not a boolean (true|false)")),
            },
            ParamKind::Choice(options) => {
                if options.contains(&text) {
                    Ok(ParamValue::Choice(text.to_string()))
                } else {
                    Err(format!("{name}: '{text}' is not one of {}", options.join(", ")))
                }
            }
            ParamKind::Size2 { max } => {
                let (w, h) = parse_size(text).map_err(|e| format!("{name}: {e}"))?;
                if w > max || h > max {
                    return Err(format!("{name}: {w}x{h} exceeds {max}x{max}"));
                }
                Ok(ParamValue::Size2(w, h))
            }
            ParamKind::GridCounts { min, max } => {
                let parts: Vec<&str> = text.split(['x', 'X']).map(str::trim).collect();
                let mut counts = Vec::with_capacity(3);
                for part in &parts {
                    let n: u32 = part
                        .parse()
                        .map_err(|_| format!("{name}: '{text}': '{part}' is not a whole number"))?;
                    if n < min || n > max {
                        return Err(format!("{name}: {n} in '{text}' is outside {min}..={max}"));
                    }
                    counts.push(n);
                }
                match counts[..] {
                    [n] => Ok(ParamValue::GridCounts(GridCounts::AlongLongest(n))),
                    [x, y, z] => Ok(ParamValue::GridCounts(GridCounts::Exact([x, y, z]))),
                    _ => Err(format!(
                        "{name}: '{text}' is neither a count (e.g. 8) nor three counts XxYxZ (e.g. 32x8x32)"
                    )),
                }
            }
        }
    }
}

/// Validated parameter values: every declared parameter has a value (its default unless set).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ParamValues {
    values: BTreeMap<&'static str, ParamValue>,
}

impl ParamValues {
    /// Validates `settings` (`(key, value)` pairs) against `specs`. `owner` names the technique or scene
    /// in error messages.
    pub fn from_settings(
        owner: &str,
        specs: &[ParamSpec],
        settings: &[(String, String)],
    ) -> Result<Self, String> {
        let mut values = BTreeMap::new();
        for spec in specs {
            let v = spec
                .parse(spec.default)
                .map_err(|e| format!("internal: bad default for {owner}.{}: {e}", spec.name))?;
            values.insert(spec.name, v);
        }
        for (key, text) in settings {
            let spec = specs.iter().find(|s| s.name == key).ok_or_else(|| {
                let known: Vec<&str> = specs.iter().map(|s| s.name).collect();
                if known.is_empty() {
                    format!("'{owner}' has no parameters, but '{key}' was set")
                } else {
                    format!("'{owner}' has no parameter '{key}'; its parameters are: {}", known.join(", "))
                }
            })?;
            values.insert(spec.name, spec.parse(text).map_err(|e| format!("{owner}: {e}"))?);
        }
        Ok(ParamValues { values })
    }

    /// Defaults only.
    pub fn defaults(owner: &str, specs: &[ParamSpec]) -> Result<Self, String> {
        Self::from_settings(owner, specs, &[])
    }

    pub fn get(&self, name: &str) -> Option<&ParamValue> {
        self.values.get(name)
    }

    // The typed getters below panic only on a programming error (asking for an undeclared parameter or
    // the wrong type); user input has been validated by `from_settings`.
    pub fn int(&self, name: &str) -> i64 {
        match self.values.get(name) {
            Some(ParamValue::Int(v)) => *v,
            other => panic!("parameter '{name}' is not a declared int (found {other:?})"),
        }
    }

    pub fn float(&self, name: &str) -> f64 {
        match self.values.get(name) {
            Some(ParamValue::Float(v)) => *v,
            Some(ParamValue::Int(v)) => *v as f64,
            other => panic!("parameter '{name}' is not a declared float (found {other:?})"),
        }
    }

    pub fn bool(&self, name: &str) -> bool {
        match self.values.get(name) {
            Some(ParamValue::Bool(v)) => *v,
            other => panic!("parameter '{name}' is not a declared bool (found {other:?})"),
        }
    }

    pub fn choice(&self, name: &str) -> &str {
        match self.values.get(name) {
            Some(ParamValue::Choice(v)) => v,
            other => panic!("parameter '{name}' is not a declared choice (found {other:?})"),
        }
    }

    pub fn size2(&self, name: &str) -> (u32, u32) {
        match self.values.get(name) {
            Some(ParamValue::Size2(w, h)) => (*w, *h),
            other => panic!("parameter '{name}' is not a declared size (found {other:?})"),
        }
    }

    pub fn grid_counts(&self, name: &str) -> GridCounts {
        match self.values.get(name) {
            Some(ParamValue::GridCounts(c)) => *c,
            other => panic!("parameter '{name}' is not declared grid counts (found {other:?})"),
        }
    }

    /// All values as strings, in name order (for stats and cache keys).
    pub fn to_map(&self) -> BTreeMap<String, String> {
        self.values.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect()
    }
}

/// Splits `key=value` into its two halves.
pub fn parse_setting(text: &str) -> Result<(String, String), String> {
    let (k, v) = text.split_once('=').ok_or_else(|| format!("'{text}' is not key=value"))?;
    if k.trim().is_empty() {
        return Err(format!("'{text}' has an empty key"));
    }
    Ok((k.trim().to_string(), v.trim().to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    const SPECS: &[ParamSpec] = &[
        ParamSpec { name: "n", kind: ParamKind::Int { min: 1, max: 8 }, default: "2", doc: "" },
        ParamSpec { name: "x", kind: ParamKind::Float { min: 0.0, max: 1.0 }, default: "0.5", doc: "" },
        ParamSpec { name: "mode", kind: ParamKind::Choice(&["a", "b"]), default: "a", doc: "" },
        ParamSpec { name: "cells", kind: ParamKind::Size2 { max: 16 }, default: "4x4", doc: "" },
        ParamSpec { name: "grid", kind: ParamKind::GridCounts { min: 2, max: 64 }, default: "8", doc: "" },
    ];

    #[test]
    fn defaults_and_overrides() {
        let v = ParamValues::from_settings("t", SPECS, &[("n".into(), "5".into())]).unwrap();
        assert_eq!(v.int("n"), 5);
        assert_eq!(v.float("x"), 0.5);
        assert_eq!(v.choice("mode"), "a");
        assert_eq!(v.size2("cells"), (4, 4));
        assert_eq!(v.grid_counts("grid"), GridCounts::AlongLongest(8));
        let v = ParamValues::from_settings("t", SPECS, &[("grid".into(), "32x8X32".into())]).unwrap();
        assert_eq!(v.grid_counts("grid"), GridCounts::Exact([32, 8, 32]));
        assert_eq!(v.to_map()["grid"], "32x8x32");
    }

    #[test]
    fn rejects_bad_input_with_names() {
        let e = ParamValues::from_settings("t", SPECS, &[("n".into(), "9".into())]).unwrap_err();
        assert!(e.contains("n") && e.contains("1..=8"), "{e}");
        let e = ParamValues::from_settings("t", SPECS, &[("zz".into(), "1".into())]).unwrap_err();
        assert!(e.contains("zz") && e.contains("n, x, mode, cells, grid"), "{e}");
        for bad in ["1", "65", "8x8", "2x2x2x2", "8xx8", "ax8x8", "8x1x8"] {
            let e = ParamValues::from_settings("t", SPECS, &[("grid".into(), bad.into())]).unwrap_err();
            assert!(e.contains("grid") && e.contains(bad), "{bad}: {e}");
        }
        let e = ParamValues::from_settings("t", SPECS, &[("mode".into(), "c".into())]).unwrap_err();
        assert!(e.contains("a, b"), "{e}");
        assert!(parse_size("0x0").is_err());
        assert!(parse_size("12").is_err());
        assert_eq!(parse_size("64x32"), Ok((64, 32)));
        assert!(parse_setting("novalue").is_err());
    }
}
