//! Method parameters: each method reads its own TOML table (`[tracker.params.fdb-daf]`,
//! `[fusion.params.fdbsc-ta]`, or `--param key=value` on the command line) into a serde
//! struct with `deny_unknown_fields`, so an unknown or mistyped key is an error naming it.
//! Also the named entries the registries (`local::registry`, `center::registry`) hold.

use serde::de::DeserializeOwned;
use std::collections::BTreeMap;

/// A parameter problem: which key, and why. Every method's parameter check, the TOML
/// parse of a parameter table (unknown or mistyped key) and the config range checks
/// return it; the fusion center and the local tracker wrap it as their `Config` variant.
/// One struct and not an enum: the situations differ only in the key and the reason, and
/// a caller acts on the key (e.g. the CLI maps it to the flag that set it).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{key}: {reason}")]
pub struct ParamError {
    /// The key as written in a scenario, relative to its section (`gate_probability`,
    /// `params.fdbsc-ta.eps`, `process_noise[1]`).
    pub key: String,
    /// Why the value is refused (`-1 must be positive`, `unknown field ...`).
    pub reason: String,
}

impl ParamError {
    /// A new error for `key`.
    pub fn new(key: impl Into<String>, reason: impl Into<String>) -> Self {
        ParamError {
            key: key.into(),
            reason: reason.into(),
        }
    }
}

/// Registering a method under a name the registry already holds (a registry never
/// silently replaces a method).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("a {kind} named {name:?} is already registered")]
pub struct DuplicateName {
    /// What kind of method (`filter`, `associator`, `method`, `rule`, `bias`).
    pub kind: &'static str,
    pub name: String,
}

/// The parameter tables of a config section, by method name.
pub type ParamTables = BTreeMap<String, toml::Table>;

/// One named entry of a registry value.
#[derive(Clone)]
pub struct Entry<C> {
    pub name: String,
    pub summary: String,
    make: C,
}

impl<C> Entry<C> {
    /// An entry (the registries add them with [`register`], which refuses a taken name).
    pub(crate) fn new(name: &str, summary: &str, make: C) -> Self {
        Entry {
            name: name.to_string(),
            summary: summary.to_string(),
            make,
        }
    }

    /// The constructor.
    pub fn constructor(&self) -> &C {
        &self.make
    }
}

/// Add `(name, summary, make)` to `entries` unless `name` is taken.
pub(crate) fn register<C>(
    entries: &mut Vec<Entry<C>>,
    kind: &'static str,
    name: &str,
    summary: &str,
    make: C,
) -> Result<(), DuplicateName> {
    if entries.iter().any(|e| e.name == name) {
        return Err(DuplicateName {
            kind,
            name: name.to_string(),
        });
    }
    entries.push(Entry::new(name, summary, make));
    Ok(())
}

/// Parse method `name`'s table (absent = all defaults) into `P`. Errors name
/// `params.<name>.<key>` (`params.<name>` when no single key is at fault, e.g. a missing
/// required one).
pub fn parse_params<P: DeserializeOwned>(
    tables: &ParamTables,
    name: &str,
) -> Result<P, ParamError> {
    let table = tables.get(name).cloned().unwrap_or_default();
    P::deserialize(toml::Value::Table(table.clone())).map_err(|e| {
        let key = match offending_key::<P>(&table) {
            Some(k) => format!("params.{name}.{k}"),
            None => format!("params.{name}"),
        };
        ParamError::new(key, e.message().to_string())
    })
}

/// The top-level key of `table` that `P` rejects: the table is written out as TOML text
/// and parsed again, and the error's position in that text gives the key (a typed
/// `toml::Value` carries no positions). `None` when the error has no position or it is
/// not on a `key = value` line.
fn offending_key<P: DeserializeOwned>(table: &toml::Table) -> Option<String> {
    let text = toml::to_string(table).ok()?;
    let err = toml::from_str::<P>(&text).err()?;
    let start = err.span()?.start;
    let line_start = text.get(..start)?.rfind('\n').map_or(0, |i| i + 1);
    let line = text.get(line_start..)?.lines().next()?;
    let (key, _) = line.split_once('=')?;
    let key = key.trim().trim_matches('"');
    (!key.is_empty() && !key.starts_with('[')).then(|| key.to_string())
}

/// Require `value` to be finite and positive; error names `key`.
pub fn positive(key: &str, value: f64) -> Result<(), ParamError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(ParamError::new(key, format!("{value} must be positive")))
    }
}

/// Require `value` in `[lo, hi]`; error names `key`.
pub fn in_range(key: &str, value: f64, lo: f64, hi: f64) -> Result<(), ParamError> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(())
    } else {
        Err(ParamError::new(
            key,
            format!("{value} must be in [{lo}, {hi}]"),
        ))
    }
}

/// Parse a `key=value` command-line parameter; the value is read as a TOML value
/// (`3`, `0.5`, `true`, `"det"`), and a bare word as a string.
pub fn parse_cli_param(text: &str) -> Result<(String, toml::Value), ParamError> {
    let (key, value) = text
        .split_once('=')
        .ok_or_else(|| ParamError::new(text, "expected key=value"))?;
    let key = key.trim().to_string();
    if key.is_empty() {
        return Err(ParamError::new(text, "empty key"));
    }
    let value = value.trim();
    let parsed = toml::from_str::<toml::Table>(&format!("v = {value}"))
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| toml::Value::String(value.to_string()));
    Ok((key, parsed))
}

/// Test helper shared by the registries' tests: for the parameter struct `P` of the
/// method called `name`, an absent table gives its `Default` (the container-level
/// `#[serde(default)]` and the documented defaults agree), and an unknown key is an error
/// naming `params.<name>.<key>`.
#[cfg(test)]
pub(crate) fn assert_default_and_strict<P>(name: &str)
where
    P: serde::de::DeserializeOwned + Default + std::fmt::Debug,
{
    let parsed: P = parse_params(&ParamTables::new(), name).expect("defaults");
    assert_eq!(
        format!("{parsed:?}"),
        format!("{:?}", P::default()),
        "{name}"
    );
    let mut tables = ParamTables::new();
    tables.insert(
        name.into(),
        toml::from_str("no_such_key = 1").expect("a table"),
    );
    let e = parse_params::<P>(&tables, name).expect_err("unknown key");
    assert_eq!(e.key, format!("params.{name}.no_such_key"), "{e}");
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, Deserialize, PartialEq)]
    #[serde(deny_unknown_fields)]
    struct P {
        #[serde(default = "two")]
        k: u32,
    }
    fn two() -> u32 {
        2
    }

    #[test]
    fn defaults_unknown_keys_and_cli_values() {
        let mut t = ParamTables::new();
        assert_eq!(parse_params::<P>(&t, "m").expect("defaults"), P { k: 2 });
        let mut table = toml::Table::new();
        table.insert("kk".into(), toml::Value::Integer(3));
        t.insert("m".into(), table);
        let e = parse_params::<P>(&t, "m").expect_err("unknown key");
        assert!(e.to_string().contains("kk"), "{e}");
        assert_eq!(e.key, "params.m.kk");
        let mut table = toml::Table::new();
        table.insert("k".into(), toml::Value::String("two".into()));
        t.insert("m".into(), table);
        let e = parse_params::<P>(&t, "m").expect_err("wrong type");
        assert_eq!(e.key, "params.m.k", "{e}");
        assert!(e.reason.contains("invalid type"), "{e}");
        assert_eq!(
            parse_cli_param("k=3").expect("int"),
            ("k".into(), toml::Value::Integer(3))
        );
        assert_eq!(
            parse_cli_param("w=det").expect("word"),
            ("w".into(), toml::Value::String("det".into()))
        );
        assert!(parse_cli_param("novalue").is_err());
    }
}
