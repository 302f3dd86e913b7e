//! Key bindings: one table of actions (name, context, description, default keys) that both
//! the key handling ([`KeyMap::lookup`]) and the help overlay read, so the help always lists
//! exactly the keys that work.
//!
//! Follows gitui's split (`extrawurst/gitui`, `src/keys/key_list.rs`: a struct of named
//! bindings with built-in defaults, overridable from a file), with two differences: the table
//! is a list of [`Action`]s rather than struct fields, so tests and the help can iterate it,
//! and the override file is TOML (`[keys]` section of the UI config, see [`crate::tui::config`]).
//!
//! Key syntax in the file: a single character (`"q"`, `"T"`, `"?"`, `"+"`), or a name —
//! `space tab backtab enter esc backspace delete insert up down left right home end pageup
//! pagedown f1 … f12` — optionally prefixed by `ctrl-`, `alt-`, `shift-` (e.g. `"ctrl-c"`,
//! `"shift-up"`). Upper-case letters already mean Shift; `"shift-t"` is written `"T"`.

mod action;
mod key;

pub use action::{ALL_ACTIONS, Action, Context};
pub use key::Key;

use serde::Deserialize;
use std::collections::BTreeMap;

/// A problem with a key map file.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum KeyMapError {
    /// Not a key in the file syntax.
    #[error(
        "{0:?} is not a key (expected one character, or a name such as space, tab, esc, enter, up, pageup, f1, with optional ctrl-/alt-/shift- prefixes)"
    )]
    BadKey(String),
    /// Not an action name.
    #[error("{0:?} is not an action (run `fleetmap tui --print-config` for the list)")]
    UnknownAction(String),
    /// Two actions that can be active at the same time share a key.
    #[error("key {key} is bound to both {first} and {second} ({context})")]
    Conflict {
        /// The key.
        key: String,
        /// One action.
        first: String,
        /// The other.
        second: String,
        /// Where they collide.
        context: String,
    },
    /// An action that must have a key was left without one.
    #[error("{0} must keep at least one key")]
    Unbound(String),
}

/// The key map: for every action in [`ALL_ACTIONS`], its keys.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KeyMap {
    bindings: Vec<(Action, Vec<Key>)>,
}

impl Default for KeyMap {
    fn default() -> Self {
        KeyMap {
            bindings: ALL_ACTIONS.iter().map(|&a| (a, a.default_keys())).collect(),
        }
    }
}

/// One action's keys in the file: a key or a list of keys.
#[derive(Debug, Deserialize)]
#[serde(untagged)]
pub(crate) enum KeysValue {
    One(String),
    Many(Vec<String>),
}

impl KeyMap {
    /// The defaults with the file's `[keys]` entries replacing those actions' keys.
    pub(crate) fn with_overrides(
        overrides: &BTreeMap<String, KeysValue>,
    ) -> Result<KeyMap, KeyMapError> {
        let mut map = KeyMap::default();
        for (name, value) in overrides {
            let action =
                Action::from_name(name).ok_or_else(|| KeyMapError::UnknownAction(name.clone()))?;
            let texts = match value {
                KeysValue::One(s) => vec![s.as_str()],
                KeysValue::Many(v) => v.iter().map(String::as_str).collect(),
            };
            let keys = texts
                .into_iter()
                .map(Key::parse)
                .collect::<Result<Vec<_>, _>>()?;
            map.set(action, keys);
        }
        map.validate()?;
        Ok(map)
    }

    /// Replace the keys of `action` (call [`KeyMap::validate`] afterwards).
    pub fn set(&mut self, action: Action, keys: Vec<Key>) {
        if let Some(b) = self.bindings.iter_mut().find(|(a, _)| *a == action) {
            b.1 = keys;
        }
    }

    /// Check that no key is ambiguous: within one context, and between a pane context and
    /// the global keys that stay active under it only where the pane binding would hide a
    /// required action. Required actions must keep a key.
    pub fn validate(&self) -> Result<(), KeyMapError> {
        for (a, keys) in &self.bindings {
            if a.required() && keys.is_empty() {
                return Err(KeyMapError::Unbound(a.name()));
            }
        }
        let mut seen: BTreeMap<(Context, String), Action> = BTreeMap::new();
        for (a, keys) in &self.bindings {
            for k in keys {
                let slot = (a.context(), k.to_string());
                if let Some(prev) = seen.get(&slot)
                    && prev != a
                {
                    return Err(KeyMapError::Conflict {
                        key: k.to_string(),
                        first: prev.name(),
                        second: a.name(),
                        context: a.context().heading().to_string(),
                    });
                }
                seen.insert(slot, *a);
            }
        }
        // quit_now works everywhere, so nothing may shadow it.
        for k in self.keys(Action::QuitNow) {
            for (a, keys) in &self.bindings {
                if *a != Action::QuitNow && keys.contains(k) {
                    return Err(KeyMapError::Conflict {
                        key: k.to_string(),
                        first: Action::QuitNow.name(),
                        second: a.name(),
                        context: "quit_now works everywhere".to_string(),
                    });
                }
            }
        }
        Ok(())
    }

    /// The keys bound to `action`.
    pub fn keys(&self, action: Action) -> &[Key] {
        self.bindings
            .iter()
            .find(|(a, _)| *a == action)
            .map(|(_, k)| k.as_slice())
            .unwrap_or(&[])
    }

    /// Every binding, in table order.
    pub fn bindings(&self) -> impl Iterator<Item = (Action, &[Key])> {
        self.bindings.iter().map(|(a, k)| (*a, k.as_slice()))
    }

    /// The action bound to `key` in `context` (only that context; see [`Context`] for the
    /// order in which the app consults them).
    pub(crate) fn lookup(&self, context: Context, key: Key) -> Option<Action> {
        self.bindings
            .iter()
            .find(|(a, keys)| a.context() == context && keys.contains(&key))
            .map(|(a, _)| *a)
    }

    /// The keys of `action` as the help shows them (`"j n"`), or `"(unbound)"`.
    pub(crate) fn keys_label(&self, action: Action) -> String {
        let keys = self.keys(action);
        if keys.is_empty() {
            "(unbound)".to_string()
        } else {
            keys.iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(" ")
        }
    }

    /// The `[keys]` section of a config file listing every binding, with its description as
    /// a comment (what `fleetmap tui --print-config` prints).
    pub(crate) fn to_toml(&self) -> String {
        let mut out = String::from("[keys]\n");
        let mut context = None;
        for (a, keys) in &self.bindings {
            if context != Some(a.context()) {
                context = Some(a.context());
                out.push_str(&format!("# -- {} --\n", a.context().heading()));
            }
            let list = keys
                .iter()
                .map(|k| toml_string(&k.to_string()))
                .collect::<Vec<_>>()
                .join(", ");
            out.push_str(&format!(
                "{} = [{}]  # {}\n",
                a.name(),
                list,
                a.description()
            ));
        }
        out
    }
}

fn toml_string(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests;
