//! Steps 1 and 2 of loading a mission file (see the parent module): TOML syntax with
//! recovery, then a hand-written walk of the spanned tree against the schema that reports
//! every structural problem and records the span of every value by key path.

mod schema;

use super::validate::Issue;
use super::*;
pub(super) use schema::read;
use std::collections::HashMap;
use std::ops::Range;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

pub(super) type Val<'i> = Spanned<DeValue<'i>>;

/// At most this many syntax errors are reported (later ones are mostly consequences).
const MAX_SYNTAX_ERRORS: usize = 20;

/// 1-based line and character column of byte `offset` in `text` (clamped to the text).
pub(super) fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    (line, column)
}

/// Error collection: the file name, its text, the span of every value by key path, and the
/// paths whose values failed to read (poisoned: later problems about them are dropped).
pub(super) struct Ctx<'t> {
    file: String,
    text: &'t str,
    /// False for definitions built in code: no positions.
    located: bool,
    errors: Vec<DefError>,
    spans: HashMap<String, Range<usize>>,
    poisoned: Vec<String>,
}

fn join(parent: &str, key: &str) -> String {
    if parent.is_empty() {
        key.to_string()
    } else {
        format!("{parent}.{key}")
    }
}

/// The path one level up: `a.b[2].c` → `a.b[2]` → `a.b` → `a` → ``.
fn parent_path(path: &str) -> Option<&str> {
    if path.is_empty() {
        return None;
    }
    let cut = path.rfind(['.', '[']).unwrap_or(0);
    Some(&path[..cut])
}

/// Whether `path` is `prefix` or lies below it.
fn is_under(path: &str, prefix: &str) -> bool {
    path == prefix
        || (path.starts_with(prefix)
            && matches!(path.as_bytes().get(prefix.len()), Some(b'.') | Some(b'[')))
}

/// Levenshtein distance, for "did you mean" suggestions.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != *cb);
            cur[j + 1] = sub.min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

/// How a value found in the file is described in messages.
fn describe(v: &DeValue<'_>) -> String {
    match v {
        DeValue::String(s) => {
            let mut s: String = s.chars().take(40).collect();
            if s.len() == 40 {
                s.push('…');
            }
            format!("string {s:?}")
        }
        DeValue::Integer(i) => format!("integer {i}"),
        DeValue::Float(f) => format!("float {f}"),
        DeValue::Boolean(b) => format!("boolean {b}"),
        DeValue::Datetime(d) => format!("datetime {d}"),
        DeValue::Array(a) if a.len() == 1 => "an array of 1 value".into(),
        DeValue::Array(a) => format!("an array of {} values", a.len()),
        DeValue::Table(_) => "a table".into(),
    }
}

/// The value of `key` in table `t`.
pub(super) fn get<'a, 'i>(t: &'a DeTable<'i>, key: &str) -> Option<&'a Val<'i>> {
    t.iter().find(|(k, _)| k.get_ref() == key).map(|(_, v)| v)
}

impl<'t> Ctx<'t> {
    fn new(file: &str, text: &'t str) -> Ctx<'t> {
        Ctx {
            file: file.to_string(),
            text,
            located: true,
            errors: Vec::new(),
            spans: HashMap::new(),
            poisoned: Vec::new(),
        }
    }

    /// A context for a definition that did not come from a file (no positions).
    pub(super) fn detached(file: &str) -> Ctx<'static> {
        Ctx {
            file: file.to_string(),
            text: "",
            located: false,
            errors: Vec::new(),
            spans: HashMap::new(),
            poisoned: Vec::new(),
        }
    }

    pub(super) fn push(&mut self, offset: usize, path: &str, message: String) {
        let (line, column) = if self.located {
            line_col(self.text, offset)
        } else {
            (0, 0)
        };
        self.errors.push(DefError {
            file: self.file.clone(),
            line,
            column,
            path: path.to_string(),
            message,
        });
    }

    pub(super) fn poison(&mut self, path: &str) {
        self.poisoned.push(path.to_string());
    }

    /// Whether a rule about `path` depends on a value that failed to read: `path` lies
    /// under a poisoned path, or a poisoned path lies under `path` (a rule about `vehicles`
    /// depends on every vehicle).
    fn is_poisoned(&self, path: &str) -> bool {
        self.poisoned
            .iter()
            .any(|p| is_under(path, p) || is_under(p, path))
    }

    /// Report a type error at `v` and poison `path`.
    fn wrong(&mut self, path: &str, v: &Val<'_>, expected: &str) {
        let msg = format!("expected {expected}, found {}", describe(v.get_ref()));
        self.push(v.span().start, path, msg);
        self.poison(path);
    }

    /// Report a missing required key of the table at `table_path` and poison it.
    pub(super) fn missing(&mut self, table_path: &str, key: &str, expected: &str) {
        let path = join(table_path, key);
        let offset = self.spans.get(table_path).map_or(0, |s| s.start);
        let msg = if table_path.is_empty() {
            format!("missing (expected {expected})")
        } else {
            format!("missing in [{table_path}] (expected {expected})")
        };
        self.push(offset, &path, msg);
        self.poison(&path);
    }

    /// Turn validation issues into located errors, dropping those about poisoned values.
    pub(super) fn report(&mut self, issues: Vec<Issue>) {
        for issue in issues {
            if self.is_poisoned(&issue.path) || issue.involves.iter().any(|p| self.is_poisoned(p)) {
                continue;
            }
            let mut message = issue.message;
            let mut at = Some(issue.path.as_str());
            let mut offset = 0;
            let mut own = true;
            while let Some(p) = at {
                if let Some(span) = self.spans.get(p) {
                    offset = span.start;
                    break;
                }
                own = false;
                at = parent_path(p);
            }
            if self.located && !own && issue.defaulted_if_absent {
                message.push_str(" (the default value: the key is not in the file)");
            }
            self.push(offset, &issue.path, message);
        }
    }

    /// All errors in file order, or `Ok` when there are none.
    pub(super) fn finish(mut self) -> Result<(), DefErrors> {
        if self.errors.is_empty() {
            return Ok(());
        }
        self.errors.sort_by_key(|e| (e.line, e.column));
        self.errors.dedup();
        Err(DefErrors {
            errors: self.errors,
        })
    }

    // ---- tables -------------------------------------------------------------------

    /// `v` as a table whose keys must be among `known`; unknown keys are reported at the
    /// key, with a suggestion when one is close.
    pub(super) fn table<'a, 'i>(
        &mut self,
        path: &str,
        v: &'a Val<'i>,
        known: &[&str],
    ) -> Option<&'a DeTable<'i>> {
        self.spans.insert(path.to_string(), v.span());
        let DeValue::Table(t) = v.get_ref() else {
            let what = if path.is_empty() {
                "a table".to_string()
            } else {
                format!("a table [{path}]")
            };
            self.wrong(path, v, &what);
            return None;
        };
        for (k, _) in t.iter() {
            let name = k.get_ref().as_ref();
            if known.contains(&name) {
                continue;
            }
            let best = known
                .iter()
                .map(|c| (edit_distance(name, c), *c))
                .min()
                .filter(|(d, c)| *d <= 2.max(c.len() / 3));
            let mut msg = match best {
                Some((_, c)) => format!("unknown key {name:?} (did you mean {c:?}?)"),
                None => format!("unknown key {name:?}"),
            };
            msg.push_str(&format!("; expected one of: {}", known.join(", ")));
            let kpath = join(path, name);
            self.push(k.span().start, &kpath, msg);
        }
        Some(t)
    }

    /// An optional sub-table: `None` when absent or not a table (the latter reported).
    pub(super) fn sub_table<'a, 'i>(
        &mut self,
        t: &'a DeTable<'i>,
        tpath: &str,
        key: &str,
        known: &[&str],
    ) -> Option<&'a DeTable<'i>> {
        let v = get(t, key)?;
        self.table(&join(tpath, key), v, known)
    }

    // ---- leaves ---------------------------------------------------------------------

    fn record(&mut self, path: &str, v: &Val<'_>) {
        self.spans.insert(path.to_string(), v.span());
    }

    pub(super) fn num_of(&mut self, path: &str, v: &Val<'_>) -> Option<f64> {
        self.record(path, v);
        let n = match v.get_ref() {
            DeValue::Integer(i) => i64::from_str_radix(i.as_str(), i.radix())
                .ok()
                .map(|n| n as f64),
            DeValue::Float(f) => f.as_str().parse::<f64>().ok(),
            _ => None,
        };
        if n.is_none() {
            self.wrong(path, v, "a number");
        }
        n
    }

    pub(super) fn int_of<T: TryFrom<i64>>(
        &mut self,
        path: &str,
        v: &Val<'_>,
        expected: &str,
    ) -> Option<T> {
        self.record(path, v);
        let DeValue::Integer(i) = v.get_ref() else {
            self.wrong(path, v, expected);
            return None;
        };
        let n = i64::from_str_radix(i.as_str(), i.radix())
            .ok()
            .and_then(|n| T::try_from(n).ok());
        if n.is_none() {
            self.wrong(path, v, expected);
        }
        n
    }

    fn str_of(&mut self, path: &str, v: &Val<'_>, expected: &str) -> Option<String> {
        self.record(path, v);
        match v.get_ref() {
            DeValue::String(s) => Some(s.to_string()),
            _ => {
                self.wrong(path, v, expected);
                None
            }
        }
    }

    fn bool_of(&mut self, path: &str, v: &Val<'_>) -> Option<bool> {
        self.record(path, v);
        match v.get_ref() {
            DeValue::Boolean(b) => Some(*b),
            _ => {
                self.wrong(path, v, "true or false");
                None
            }
        }
    }

    /// A link budget (`link`): `"unlimited"`, `"radio"` or `"radio:BYTES"`.
    fn link_of(&mut self, path: &str, v: &Val<'_>) -> Option<LinkBudget> {
        let s = self.str_of(
            path,
            v,
            "\"unlimited\", \"radio\" or \"radio:BYTES_PER_SECOND\"",
        )?;
        match s.parse() {
            Ok(b) => Some(b),
            Err(e) => {
                self.push(v.span().start, path, format!("{e}"));
                self.poison(path);
                None
            }
        }
    }

    /// One of the given words (`kind`, `role`).
    pub(super) fn word_of<T: Copy>(
        &mut self,
        path: &str,
        v: &Val<'_>,
        words: &[(&str, T)],
    ) -> Option<T> {
        let list = words
            .iter()
            .map(|(w, _)| format!("{w:?}"))
            .collect::<Vec<_>>()
            .join(" or ");
        let s = self.str_of(path, v, &list)?;
        let found = words.iter().find(|(w, _)| *w == s).map(|(_, t)| *t);
        if found.is_none() {
            self.wrong(path, v, &list);
        }
        found
    }

    fn cell_of(&mut self, path: &str, v: &Val<'_>) -> Option<Cell> {
        const EXPECTED: &str = "a cell [row, col] (two integers)";
        self.record(path, v);
        let a = match v.get_ref() {
            DeValue::Array(a) if a.len() == 2 => a,
            _ => {
                self.wrong(path, v, EXPECTED);
                return None;
            }
        };
        let row = self.int_of::<i32>(&format!("{path}[0]"), &a[0], "an integer row");
        let col = self.int_of::<i32>(&format!("{path}[1]"), &a[1], "an integer column");
        match (row, col) {
            (Some(r), Some(c)) => Some(Cell::new(r, c)),
            _ => {
                self.poison(path);
                None
            }
        }
    }

    fn cells_of(&mut self, path: &str, v: &Val<'_>) -> Option<Vec<Cell>> {
        self.record(path, v);
        let DeValue::Array(a) = v.get_ref() else {
            self.wrong(path, v, "an array of cells [[row, col], …]");
            return None;
        };
        let mut out = Vec::with_capacity(a.len());
        let mut ok = true;
        for (i, item) in a.iter().enumerate() {
            match self.cell_of(&format!("{path}[{i}]"), item) {
                Some(c) => out.push(c),
                None => ok = false,
            }
        }
        if !ok {
            self.poison(path);
        }
        Some(out)
    }

    /// A fixed-length array of numbers (`north_m = [min, max]`).
    pub(super) fn nums_of<const N: usize>(
        &mut self,
        path: &str,
        v: &Val<'_>,
        expected: &str,
    ) -> Option<[f64; N]> {
        self.record(path, v);
        let a = match v.get_ref() {
            DeValue::Array(a) if a.len() == N => a,
            _ => {
                self.wrong(path, v, expected);
                return None;
            }
        };
        let mut out = [0.0; N];
        for (i, item) in a.iter().enumerate() {
            out[i] = self.num_of(&format!("{path}[{i}]"), item)?;
        }
        Some(out)
    }

    /// A fixed-length array of small integers (`hsv_min = [h, s, v]`).
    pub(super) fn u8s_of<const N: usize>(
        &mut self,
        path: &str,
        v: &Val<'_>,
        expected: &str,
    ) -> Option<[u8; N]> {
        self.record(path, v);
        let a = match v.get_ref() {
            DeValue::Array(a) if a.len() == N => a,
            _ => {
                self.wrong(path, v, expected);
                return None;
            }
        };
        let mut out = [0u8; N];
        for (i, item) in a.iter().enumerate() {
            out[i] = self.int_of::<u8>(&format!("{path}[{i}]"), item, "an integer 0–255")?;
        }
        Some(out)
    }

    pub(super) fn latlon_of(&mut self, path: &str, v: &Val<'_>) -> Option<LatLon> {
        let t = self.table(path, v, &["lat", "lon"])?;
        let lat = self.req(t, path, "lat", "a latitude in degrees", Self::num_of);
        let lon = self.req(t, path, "lon", "a longitude in degrees", Self::num_of);
        Some(LatLon {
            lat: lat?,
            lon: lon?,
        })
    }

    // ---- required / optional fields ---------------------------------------------------

    /// A required key read with `f` (which reports its own type errors).
    pub(super) fn req<T>(
        &mut self,
        t: &DeTable<'_>,
        tpath: &str,
        key: &str,
        expected: &str,
        f: impl FnOnce(&mut Self, &str, &Val<'_>) -> Option<T>,
    ) -> Option<T> {
        let path = join(tpath, key);
        match get(t, key) {
            Some(v) => {
                let out = f(self, &path, v);
                if out.is_none() {
                    self.poison(&path);
                }
                out
            }
            None => {
                self.missing(tpath, key, expected);
                None
            }
        }
    }

    /// An optional key read with `f`: `Ok(None)` when absent, `Err(())` when malformed.
    pub(super) fn opt<T>(
        &mut self,
        t: &DeTable<'_>,
        tpath: &str,
        key: &str,
        f: impl FnOnce(&mut Self, &str, &Val<'_>) -> Option<T>,
    ) -> Result<Option<T>, ()> {
        let path = join(tpath, key);
        match get(t, key) {
            Some(v) => match f(self, &path, v) {
                Some(x) => Ok(Some(x)),
                None => {
                    self.poison(&path);
                    Err(())
                }
            },
            None => Ok(None),
        }
    }

    /// An optional key with a default (the default also stands in when it is malformed;
    /// the error is reported and the key poisoned).
    pub(super) fn or<T>(
        &mut self,
        t: &DeTable<'_>,
        tpath: &str,
        key: &str,
        default: T,
        f: impl FnOnce(&mut Self, &str, &Val<'_>) -> Option<T>,
    ) -> T {
        self.opt(t, tpath, key, f).ok().flatten().unwrap_or(default)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_and_column_count_characters() {
        let text = "a = 1\nbé = -4\n";
        assert_eq!(line_col(text, 0), (1, 1));
        assert_eq!(line_col(text, 6), (2, 1));
        let off = text.find("-4").unwrap();
        assert_eq!(line_col(text, off), (2, 6));
        assert_eq!(line_col(text, 10_000), (3, 1));
        // Inside a multi-byte character: clamped to its start.
        assert_eq!(line_col(text, 8), (2, 2));
    }

    #[test]
    fn paths_and_poison_prefixes() {
        assert_eq!(parent_path("a.b[2].c"), Some("a.b[2]"));
        assert_eq!(parent_path("a.b[2]"), Some("a.b"));
        assert_eq!(parent_path("a"), Some(""));
        assert_eq!(parent_path(""), None);
        assert!(is_under("vehicles[1].sysid", "vehicles"));
        assert!(is_under("vehicles", "vehicles"));
        assert!(!is_under("vehicles_x", "vehicles"));
    }

    #[test]
    fn suggestions_use_edit_distance() {
        assert_eq!(edit_distance("cell_size", "cell_size_m"), 2);
        assert_eq!(edit_distance("", "abc"), 3);
    }
}
