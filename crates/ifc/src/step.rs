//! The STEP physical file (ISO 10303-21) reader: the header's schema and
//! an index of the DATA section's entities by id (byte ranges), whose
//! arguments are decoded on demand.
//!
//! Indexing checks every record's syntax and every reference, so a file
//! that indexes has no broken record and no dangling reference; what an
//! argument means is checked later, where it is read.

use std::collections::HashMap;

use crate::error::IfcError;

/// The IFC schema a file declares (FILE_SCHEMA).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Schema {
    Ifc2x3,
    Ifc4,
    Ifc4x3,
}

/// One argument of an entity, decoded.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// `$`: unset.
    Null,
    /// `*`: derived by the schema.
    Derived,
    Int(i64),
    Real(f64),
    /// A string, its escapes decoded to UTF-8.
    Str(String),
    /// `.NAME.`, without the dots (`T`, `F`, `U` for logicals).
    Enum(String),
    Ref(u32),
    List(Vec<Value>),
    /// `IFCLABEL('x')`: a defined type's name (upper case) and its value.
    Typed(String, Box<Value>),
    /// `"0AB..."`: hex digits, kept as written.
    Binary(String),
}

impl Value {
    /// A number as f64 (integers too; typed numbers unwrapped).
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Value::Real(r) => Some(*r),
            Value::Int(i) => Some(*i as f64),
            Value::Typed(_, v) => v.as_f64(),
            _ => None,
        }
    }

    pub fn as_ref_id(&self) -> Option<u32> {
        match self {
            Value::Ref(r) => Some(*r),
            _ => None,
        }
    }

    pub fn as_str(&self) -> Option<&str> {
        match self {
            Value::Str(s) => Some(s),
            Value::Typed(_, v) => v.as_str(),
            _ => None,
        }
    }

    pub fn as_list(&self) -> Option<&[Value]> {
        match self {
            Value::List(l) => Some(l),
            _ => None,
        }
    }

    pub fn as_enum(&self) -> Option<&str> {
        match self {
            Value::Enum(e) => Some(e),
            _ => None,
        }
    }

    pub fn is_null(&self) -> bool {
        matches!(self, Value::Null | Value::Derived)
    }

    /// The value as JSON (a typed value as its inner value; a reference
    /// as `"#id"`).
    pub fn to_json(&self) -> serde_json::Value {
        use serde_json::Value as J;
        match self {
            Value::Null | Value::Derived => J::Null,
            Value::Int(i) => J::from(*i),
            Value::Real(r) => serde_json::Number::from_f64(*r).map_or(J::Null, J::Number),
            Value::Str(s) | Value::Binary(s) => J::String(s.clone()),
            Value::Enum(e) => match e.as_str() {
                "T" => J::Bool(true),
                "F" => J::Bool(false),
                "U" => J::Null,
                _ => J::String(e.clone()),
            },
            Value::Ref(r) => J::String(format!("#{r}")),
            Value::List(l) => J::Array(l.iter().map(Value::to_json).collect()),
            Value::Typed(_, v) => v.to_json(),
        }
    }
}

/// Ids below this are tracked in a bitset while indexing (32 MiB at
/// most), so backward references need no list; larger ids, rare, wait
/// for the whole index.
const DEFINED_IDS: usize = 1 << 28;

/// Where one entity's record lies in the file.
#[derive(Clone, Copy, Debug)]
struct Record {
    id: u32,
    line: u32,
    /// Byte offset of the type name; the arguments start after it.
    start: usize,
    type_len: u16,
    /// Offset of the arguments' `(` from `start`.
    args_off: u32,
    /// Bytes from the `(` after the type name to its matching `)`, both
    /// included.
    args_len: u32,
}

/// An indexed STEP file: its bytes and where each entity is.
pub struct StepFile {
    /// The file's name in messages.
    pub file: String,
    pub schema: Schema,
    bytes: Vec<u8>,
    records: Vec<Record>,
    by_id: Index,
    by_type: HashMap<Box<str>, Vec<u32>>,
}

enum Index {
    /// Record index + 1 per id (0: none), for the usual dense numbering.
    Dense(Vec<u32>),
    Sparse(HashMap<u32, u32>),
}

/// One entity, its arguments decoded.
pub struct Entity<'a> {
    pub id: u32,
    pub line: usize,
    /// Its type as written (upper case), e.g. `IFCWALL`.
    pub ty: &'a str,
    pub args: Vec<Value>,
    step: &'a StepFile,
}

impl StepFile {
    /// Indexes `bytes`, the file `file` (its name in messages).
    pub fn parse(bytes: Vec<u8>, file: &str) -> Result<StepFile, IfcError> {
        let mut s = Scanner {
            b: &bytes,
            pos: 0,
            line: 1,
            file,
        };
        s.skip_ws()?;
        if s.pos == bytes.len() {
            return Err(IfcError::Empty { file: file.into() });
        }
        if !s.eat_keyword(b"ISO-10303-21") {
            return Err(IfcError::NotStep { file: file.into() });
        }
        s.skip_ws()?;
        s.expect(b';', "after ISO-10303-21")?;
        let schema = s.header()?;
        let mut records = Vec::new();
        let mut refs: Vec<(u32, u32)> = Vec::new();
        s.data(&mut records, &mut refs)?;
        let max_id = records.iter().map(|r| r.id).max().unwrap_or(0) as usize;
        let mut by_id = if max_id <= 4 * records.len() + (1 << 20) {
            Index::Dense(vec![0; max_id + 1])
        } else {
            Index::Sparse(HashMap::with_capacity(records.len()))
        };
        let mut by_type: HashMap<Box<str>, Vec<u32>> = HashMap::new();
        for (i, r) in records.iter().enumerate() {
            let previous = match &mut by_id {
                Index::Dense(v) => std::mem::replace(&mut v[r.id as usize], i as u32 + 1),
                Index::Sparse(m) => m.insert(r.id, i as u32 + 1).unwrap_or(0),
            };
            if previous != 0 {
                return Err(IfcError::DuplicateEntity {
                    file: file.into(),
                    line: r.line as usize,
                    entity: r.id,
                });
            }
            let ty = &bytes[r.start..r.start + r.type_len as usize];
            // Type names are checked ASCII by the scanner.
            let ty = std::str::from_utf8(ty).unwrap_or_default();
            match by_type.get_mut(ty) {
                Some(v) => v.push(i as u32),
                None => {
                    by_type.insert(ty.into(), vec![i as u32]);
                }
            }
        }
        let mut step = StepFile {
            file: file.into(),
            schema,
            bytes: Vec::new(),
            records,
            by_id,
            by_type,
        };
        for (target, from) in refs {
            if step.record(target).is_none() {
                let r = step.records[from as usize];
                return Err(IfcError::DanglingReference {
                    file: file.into(),
                    line: r.line as usize,
                    entity: r.id,
                    target,
                });
            }
        }
        step.bytes = bytes;
        Ok(step)
    }

    fn record(&self, id: u32) -> Option<&Record> {
        let i = match &self.by_id {
            Index::Dense(v) => *v.get(id as usize)?,
            Index::Sparse(m) => *m.get(&id)?,
        };
        (i != 0).then(|| &self.records[i as usize - 1])
    }

    /// How many entities the file defines.
    pub fn len(&self) -> usize {
        self.records.len()
    }

    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// The type of entity `id` (upper case), without decoding it.
    pub fn type_of(&self, id: u32) -> Option<&str> {
        let r = self.record(id)?;
        std::str::from_utf8(&self.bytes[r.start..r.start + r.type_len as usize]).ok()
    }

    /// The ids of the entities of type `ty` (upper case, exact type), in
    /// file order.
    pub fn ids_of_type(&self, ty: &str) -> impl Iterator<Item = u32> + '_ {
        self.by_type
            .get(ty)
            .into_iter()
            .flatten()
            .map(|&i| self.records[i as usize].id)
    }

    /// Every type the file uses and how many entities have it.
    pub fn types(&self) -> impl Iterator<Item = (&str, usize)> {
        self.by_type.iter().map(|(k, v)| (&**k, v.len()))
    }

    /// Entity `id`, decoded.
    pub fn get(&self, id: u32) -> Result<Entity<'_>, IfcError> {
        let Some(r) = self.record(id) else {
            return Err(IfcError::BadEntity {
                file: self.file.clone(),
                line: 0,
                entity: id,
                class: "?".into(),
                reason: "no such entity".into(),
            });
        };
        let ty = std::str::from_utf8(&self.bytes[r.start..r.start + r.type_len as usize])
            .unwrap_or_default();
        let a = r.start + r.args_off as usize;
        let text = &self.bytes[a..a + r.args_len as usize];
        let mut d = Decoder { b: text, pos: 1 };
        let args = d.list_items().map_err(|reason| IfcError::BrokenRecord {
            file: self.file.clone(),
            line: r.line as usize,
            entity: format!("#{id}"),
            reason,
        })?;
        Ok(Entity {
            id,
            line: r.line as usize,
            ty,
            args,
            step: self,
        })
    }

    /// The line entity `id` is on (0 when there is none).
    pub fn line_of(&self, id: u32) -> usize {
        self.record(id).map_or(0, |r| r.line as usize)
    }
}

impl<'a> Entity<'a> {
    /// An error about this entity.
    pub fn error(&self, reason: impl Into<String>) -> IfcError {
        IfcError::BadEntity {
            file: self.step.file.clone(),
            line: self.line,
            entity: self.id,
            class: self.ty.into(),
            reason: reason.into(),
        }
    }

    /// Argument `i` (`Null` past the end: later schemas add optional
    /// attributes at the end).
    pub fn arg(&self, i: usize) -> &Value {
        self.args.get(i).unwrap_or(&Value::Null)
    }

    pub fn real(&self, i: usize) -> Result<f64, IfcError> {
        self.arg(i)
            .as_f64()
            .ok_or_else(|| self.error(format!("argument {} is not a number", i + 1)))
    }

    pub fn opt_real(&self, i: usize) -> Option<f64> {
        self.arg(i).as_f64()
    }

    pub fn reference(&self, i: usize) -> Result<u32, IfcError> {
        self.arg(i)
            .as_ref_id()
            .ok_or_else(|| self.error(format!("argument {} is not a reference", i + 1)))
    }

    pub fn opt_ref(&self, i: usize) -> Option<u32> {
        self.arg(i).as_ref_id()
    }

    pub fn list(&self, i: usize) -> Result<&[Value], IfcError> {
        self.arg(i)
            .as_list()
            .ok_or_else(|| self.error(format!("argument {} is not a list", i + 1)))
    }

    /// Argument `i` as a list of references.
    pub fn refs(&self, i: usize) -> Result<Vec<u32>, IfcError> {
        self.list(i)?
            .iter()
            .map(|v| {
                v.as_ref_id()
                    .ok_or_else(|| self.error(format!("argument {} holds a non-reference", i + 1)))
            })
            .collect()
    }

    /// Argument `i` as a list of numbers.
    pub fn reals(&self, i: usize) -> Result<Vec<f64>, IfcError> {
        self.list(i)?
            .iter()
            .map(|v| {
                v.as_f64()
                    .ok_or_else(|| self.error(format!("argument {} holds a non-number", i + 1)))
            })
            .collect()
    }

    pub fn opt_str(&self, i: usize) -> Option<&str> {
        self.arg(i).as_str()
    }

    /// A boolean or logical argument (`.T.`).
    pub fn flag(&self, i: usize) -> Option<bool> {
        match self.arg(i).as_enum()? {
            "T" => Some(true),
            "F" => Some(false),
            _ => None,
        }
    }
}

/// The byte scanner that indexes a file.
struct Scanner<'a> {
    b: &'a [u8],
    pos: usize,
    line: usize,
    file: &'a str,
}

impl Scanner<'_> {
    fn truncated(&self, what: &str) -> IfcError {
        IfcError::Truncated {
            file: self.file.into(),
            line: self.line,
            what: what.into(),
        }
    }

    fn broken(&self, entity: String, reason: impl Into<String>) -> IfcError {
        IfcError::BrokenRecord {
            file: self.file.into(),
            line: self.line,
            entity,
            reason: reason.into(),
        }
    }

    /// Skips white space and `/* comments */`.
    fn skip_ws(&mut self) -> Result<(), IfcError> {
        while let Some(&c) = self.b.get(self.pos) {
            match c {
                b'\n' => {
                    self.line += 1;
                    self.pos += 1;
                }
                b' ' | b'\t' | b'\r' => self.pos += 1,
                b'/' if self.b.get(self.pos + 1) == Some(&b'*') => {
                    self.pos += 2;
                    loop {
                        match self.b.get(self.pos) {
                            None => return Err(self.truncated("inside a comment")),
                            Some(b'*') if self.b.get(self.pos + 1) == Some(&b'/') => {
                                self.pos += 2;
                                break;
                            }
                            Some(b'\n') => {
                                self.line += 1;
                                self.pos += 1;
                            }
                            Some(_) => self.pos += 1,
                        }
                    }
                }
                _ => break,
            }
        }
        Ok(())
    }

    fn eat_keyword(&mut self, k: &[u8]) -> bool {
        if self.b[self.pos..].starts_with(k) {
            self.pos += k.len();
            true
        } else {
            false
        }
    }

    fn expect(&mut self, c: u8, context: &str) -> Result<(), IfcError> {
        match self.b.get(self.pos) {
            Some(&x) if x == c => {
                self.pos += 1;
                Ok(())
            }
            Some(&x) => Err(self.broken(
                "header".into(),
                format!("expected '{}' {context}, found '{}'", c as char, x as char),
            )),
            None => Err(self.truncated(context)),
        }
    }

    /// A keyword (type name): letters, digits, `_`, `-`.
    fn keyword(&mut self) -> &[u8] {
        let start = self.pos;
        while let Some(&c) = self.b.get(self.pos) {
            if c.is_ascii_alphanumeric() || c == b'_' || c == b'-' {
                self.pos += 1;
            } else {
                break;
            }
        }
        &self.b[start..self.pos]
    }

    /// From `(` to its matching `)`, both included; returns the `#id`s
    /// referenced inside. Strings and comments may hold anything.
    fn parens(&mut self, entity: &str, refs: &mut dyn FnMut(u32)) -> Result<(), IfcError> {
        debug_assert_eq!(self.b.get(self.pos), Some(&b'('));
        let mut depth = 0usize;
        loop {
            let Some(&c) = self.b.get(self.pos) else {
                return Err(self.truncated(&format!("inside {entity}")));
            };
            self.pos += 1;
            match c {
                b'(' => depth += 1,
                b')' => {
                    depth -= 1;
                    if depth == 0 {
                        return Ok(());
                    }
                }
                b'\'' => loop {
                    match self.b.get(self.pos) {
                        None => return Err(self.truncated(&format!("inside a string of {entity}"))),
                        Some(b'\'') if self.b.get(self.pos + 1) == Some(&b'\'') => self.pos += 2,
                        Some(b'\'') => {
                            self.pos += 1;
                            break;
                        }
                        Some(b'\n') => {
                            self.line += 1;
                            self.pos += 1;
                        }
                        Some(_) => self.pos += 1,
                    }
                },
                b'#' => {
                    let start = self.pos;
                    let mut id: u64 = 0;
                    while let Some(&d) = self.b.get(self.pos) {
                        if d.is_ascii_digit() {
                            id = id * 10 + (d - b'0') as u64;
                            if id > u32::MAX as u64 {
                                return Err(self.broken(entity.into(), "reference id too large"));
                            }
                            self.pos += 1;
                        } else {
                            break;
                        }
                    }
                    if self.pos == self.b.len() {
                        return Err(self.truncated(&format!("inside {entity}")));
                    }
                    if self.pos == start {
                        return Err(self.broken(entity.into(), "'#' without an id"));
                    }
                    refs(id as u32);
                }
                b';' => {
                    return Err(self.broken(
                        entity.into(),
                        format!("';' before the arguments' closing ')' ({depth} open)"),
                    ))
                }
                b'\n' => self.line += 1,
                b'/' if self.b.get(self.pos) == Some(&b'*') => {
                    self.pos -= 1;
                    self.skip_ws()?;
                }
                _ => {}
            }
        }
    }

    /// The HEADER section; returns the schema FILE_SCHEMA names.
    fn header(&mut self) -> Result<Schema, IfcError> {
        self.skip_ws()?;
        if !self.eat_keyword(b"HEADER") {
            return Err(self.broken("header".into(), "expected HEADER;"));
        }
        self.skip_ws()?;
        self.expect(b';', "after HEADER")?;
        let mut schema = None;
        loop {
            self.skip_ws()?;
            if self.pos == self.b.len() {
                return Err(self.truncated("in the header"));
            }
            let name = self.keyword().to_vec();
            if name.is_empty() {
                return Err(self.broken("header".into(), "expected a header record"));
            }
            self.skip_ws()?;
            if name == b"ENDSEC" {
                self.expect(b';', "after ENDSEC")?;
                break;
            }
            if self.b.get(self.pos) != Some(&b'(') {
                return Err(self.broken(
                    "header".into(),
                    format!("expected '(' after {}", String::from_utf8_lossy(&name)),
                ));
            }
            let start = self.pos;
            self.parens("the header", &mut |_| {})?;
            if name == b"FILE_SCHEMA" {
                let mut d = Decoder {
                    b: &self.b[start..self.pos],
                    pos: 1,
                };
                let args = d
                    .list_items()
                    .map_err(|r| self.broken("FILE_SCHEMA".into(), r))?;
                let first = args
                    .first()
                    .and_then(Value::as_list)
                    .and_then(|l| l.first())
                    .and_then(Value::as_str)
                    .unwrap_or_default()
                    .to_string();
                schema = Some(first);
            }
            self.skip_ws()?;
            self.expect(b';', "after a header record")?;
        }
        let Some(name) = schema else {
            return Err(self.broken("header".into(), "no FILE_SCHEMA"));
        };
        let upper = name.to_ascii_uppercase();
        // IFC4X3_ADD2, IFC4_ADD2_TC1, IFC2X3_TC1 and the like name
        // editions of the three schemas.
        if upper.starts_with("IFC2X3") {
            Ok(Schema::Ifc2x3)
        } else if upper.starts_with("IFC4X3") {
            Ok(Schema::Ifc4x3)
        } else if upper == "IFC4" || upper.starts_with("IFC4_") {
            Ok(Schema::Ifc4)
        } else {
            Err(IfcError::UnsupportedSchema {
                file: self.file.into(),
                schema: name,
            })
        }
    }

    /// The DATA section's records, and the references to ids not defined
    /// before them as (target, record).
    fn data(
        &mut self,
        records: &mut Vec<Record>,
        refs: &mut Vec<(u32, u32)>,
    ) -> Result<(), IfcError> {
        // Ids defined so far, a bit each, below DEFINED_IDS.
        let mut defined: Vec<u64> = Vec::new();
        self.skip_ws()?;
        if !self.eat_keyword(b"DATA") {
            if self.pos == self.b.len() {
                return Err(self.truncated("no DATA section"));
            }
            return Err(self.broken("header".into(), "expected DATA;"));
        }
        self.skip_ws()?;
        // DATA may name its schema: DATA('name', ('IFC4'));
        if self.b.get(self.pos) == Some(&b'(') {
            self.parens("DATA", &mut |_| {})?;
            self.skip_ws()?;
        }
        self.expect(b';', "after DATA")?;
        loop {
            self.skip_ws()?;
            match self.b.get(self.pos) {
                None => return Err(self.truncated("no ENDSEC after the DATA section")),
                Some(b'#') => {}
                Some(_) => {
                    if self.eat_keyword(b"ENDSEC") {
                        self.skip_ws()?;
                        self.expect(b';', "after ENDSEC")?;
                        return Ok(());
                    }
                    if b"ENDSEC".starts_with(&self.b[self.pos..]) {
                        return Err(self.truncated("no ENDSEC after the DATA section"));
                    }
                    let at = self.b.len().min(self.pos + 20);
                    return Err(self.broken(
                        "record".into(),
                        format!(
                            "expected '#id=' or ENDSEC, found {:?}",
                            String::from_utf8_lossy(&self.b[self.pos..at])
                        ),
                    ));
                }
            }
            self.pos += 1;
            let digits = self.keyword().to_vec();
            if self.pos == self.b.len() {
                return Err(self.truncated("in an entity id"));
            }
            let id: u32 = std::str::from_utf8(&digits)
                .ok()
                .and_then(|d| d.parse().ok())
                .ok_or_else(|| {
                    self.broken(
                        "record".into(),
                        format!("bad entity id #{}", String::from_utf8_lossy(&digits)),
                    )
                })?;
            let name = format!("#{id}");
            self.skip_ws()?;
            match self.b.get(self.pos) {
                Some(b'=') => self.pos += 1,
                None => return Err(self.truncated(&format!("in {name}"))),
                Some(_) => return Err(self.broken(name, "expected '=' after the id")),
            }
            self.skip_ws()?;
            let line = self.line;
            let start = self.pos;
            let ty = self.keyword();
            let type_len = ty.len();
            if type_len == 0 {
                return match self.b.get(self.pos) {
                    None => Err(self.truncated(&format!("in {name}"))),
                    // A complex entity instance (several types at once);
                    // IFC files use none for geometry or identity.
                    Some(b'(') => Err(self.broken(name, "complex entity instances are not read")),
                    Some(_) => Err(self.broken(name, "expected a type name")),
                };
            }
            if type_len > u16::MAX as usize || !ty[0].is_ascii_alphabetic() {
                return Err(self.broken(name, "bad type name"));
            }
            self.skip_ws()?;
            if self.b.get(self.pos) != Some(&b'(') {
                return match self.b.get(self.pos) {
                    None => Err(self.truncated(&format!("in {name}"))),
                    Some(_) => Err(self.broken(name, "expected '(' after the type name")),
                };
            }
            let args_start = self.pos;
            let index = records.len() as u32;
            // Writers define what a record refers to before it, mostly:
            // a reference to an id already defined is settled here, and
            // only the others wait for the whole index.
            let seen = &defined;
            self.parens(&name, &mut |t| {
                let known =
                    (t as usize) < seen.len() * 64 && seen[t as usize / 64] & (1 << (t % 64)) != 0;
                if !known {
                    refs.push((t, index));
                }
            })?;
            let args_len = self.pos - args_start;
            self.skip_ws()?;
            match self.b.get(self.pos) {
                Some(b';') => self.pos += 1,
                None => return Err(self.truncated(&format!("after {name}"))),
                Some(_) => return Err(self.broken(name, "expected ';' after the arguments")),
            }
            if args_len > u32::MAX as usize || args_start - start > u32::MAX as usize {
                return Err(self.broken(name, "record longer than 4 GiB"));
            }
            if (id as usize) < DEFINED_IDS {
                let word = id as usize / 64;
                if word >= defined.len() {
                    defined.resize(word + 1, 0);
                }
                defined[word] |= 1 << (id % 64);
            }
            records.push(Record {
                id,
                line: line as u32,
                start,
                type_len: type_len as u16,
                args_off: (args_start - start) as u32,
                args_len: args_len as u32,
            });
        }
    }
}

/// Decodes one record's arguments (already checked to balance).
struct Decoder<'a> {
    b: &'a [u8],
    pos: usize,
}

impl Decoder<'_> {
    fn skip_ws(&mut self) {
        while let Some(&c) = self.b.get(self.pos) {
            if c.is_ascii_whitespace() {
                self.pos += 1;
            } else if c == b'/' && self.b.get(self.pos + 1) == Some(&b'*') {
                match self.b[self.pos + 2..].windows(2).position(|w| w == b"*/") {
                    Some(p) => self.pos += p + 4,
                    None => self.pos = self.b.len(),
                }
            } else {
                break;
            }
        }
    }

    /// Items up to the `)` closing a list whose `(` is just behind.
    fn list_items(&mut self) -> Result<Vec<Value>, String> {
        let mut out = Vec::new();
        self.skip_ws();
        if self.b.get(self.pos) == Some(&b')') {
            self.pos += 1;
            return Ok(out);
        }
        loop {
            out.push(self.value()?);
            self.skip_ws();
            match self.b.get(self.pos) {
                Some(b',') => self.pos += 1,
                Some(b')') => {
                    self.pos += 1;
                    return Ok(out);
                }
                Some(&c) => return Err(format!("expected ',' or ')', found '{}'", c as char)),
                None => return Err("unclosed list".into()),
            }
        }
    }

    fn value(&mut self) -> Result<Value, String> {
        self.skip_ws();
        let Some(&c) = self.b.get(self.pos) else {
            return Err("missing value".into());
        };
        match c {
            b'$' => {
                self.pos += 1;
                Ok(Value::Null)
            }
            b'*' => {
                self.pos += 1;
                Ok(Value::Derived)
            }
            b'#' => {
                self.pos += 1;
                let start = self.pos;
                while self.b.get(self.pos).is_some_and(u8::is_ascii_digit) {
                    self.pos += 1;
                }
                std::str::from_utf8(&self.b[start..self.pos])
                    .ok()
                    .and_then(|s| s.parse().ok())
                    .map(Value::Ref)
                    .ok_or_else(|| "bad reference".into())
            }
            b'\'' => self.string().map(Value::Str),
            b'"' => {
                self.pos += 1;
                let start = self.pos;
                while self.b.get(self.pos).is_some_and(|&c| c != b'"') {
                    self.pos += 1;
                }
                let s = String::from_utf8_lossy(&self.b[start..self.pos]).into_owned();
                self.pos += 1;
                Ok(Value::Binary(s))
            }
            b'.' => {
                self.pos += 1;
                let start = self.pos;
                while self.b.get(self.pos).is_some_and(|&c| c != b'.') {
                    self.pos += 1;
                }
                if self.pos >= self.b.len() {
                    return Err("unclosed enumeration".into());
                }
                let s = String::from_utf8_lossy(&self.b[start..self.pos]).into_owned();
                self.pos += 1;
                Ok(Value::Enum(s))
            }
            b'(' => {
                self.pos += 1;
                self.list_items().map(Value::List)
            }
            b'+' | b'-' | b'0'..=b'9' => {
                let start = self.pos;
                let mut real = false;
                self.pos += 1;
                while let Some(&d) = self.b.get(self.pos) {
                    match d {
                        b'0'..=b'9' => {}
                        b'.' | b'E' | b'e' => real = true,
                        b'+' | b'-' if matches!(self.b[self.pos - 1], b'E' | b'e') => {}
                        _ => break,
                    }
                    self.pos += 1;
                }
                let text = std::str::from_utf8(&self.b[start..self.pos]).unwrap_or_default();
                if real {
                    text.parse()
                        .map(Value::Real)
                        .map_err(|_| format!("bad number {text:?}"))
                } else {
                    match text.parse() {
                        Ok(i) => Ok(Value::Int(i)),
                        Err(_) => text
                            .parse()
                            .map(Value::Real)
                            .map_err(|_| format!("bad number {text:?}")),
                    }
                }
            }
            c if c.is_ascii_alphabetic() => {
                let start = self.pos;
                while self
                    .b
                    .get(self.pos)
                    .is_some_and(|&c| c.is_ascii_alphanumeric() || c == b'_')
                {
                    self.pos += 1;
                }
                let name = String::from_utf8_lossy(&self.b[start..self.pos]).into_owned();
                self.skip_ws();
                if self.b.get(self.pos) != Some(&b'(') {
                    return Err(format!("expected '(' after {name}"));
                }
                self.pos += 1;
                let mut inner = self.list_items()?;
                let v = if inner.len() == 1 {
                    inner.pop().unwrap_or(Value::Null)
                } else {
                    Value::List(inner)
                };
                Ok(Value::Typed(name, Box::new(v)))
            }
            c => Err(format!("unexpected '{}'", c as char)),
        }
    }

    /// A quoted string from its opening quote, escapes decoded.
    fn string(&mut self) -> Result<String, String> {
        self.pos += 1;
        let start = self.pos;
        loop {
            match self.b.get(self.pos) {
                None => return Err("unclosed string".into()),
                Some(b'\'') if self.b.get(self.pos + 1) == Some(&b'\'') => self.pos += 2,
                Some(b'\'') => break,
                Some(_) => self.pos += 1,
            }
        }
        let raw = &self.b[start..self.pos];
        self.pos += 1;
        Ok(decode_string(raw))
    }
}

/// Decodes a STEP string's body (between the quotes): `''`, `\\`,
/// `\X2\..\X0\` (UTF-16), `\X4\..\X0\` (UTF-32), `\X\hh` (ISO 8859-1),
/// `\S\c` (upper half of ISO 8859-1), `\P?\` (code page, ignored). Bytes
/// that are not ASCII are taken as UTF-8 (what many writers emit),
/// replaced where invalid.
pub fn decode_string(raw: &[u8]) -> String {
    if !raw.contains(&b'\\') && !raw.contains(&b'\'') {
        return String::from_utf8_lossy(raw).into_owned();
    }
    let mut out: Vec<u8> = Vec::with_capacity(raw.len());
    let push = |out: &mut Vec<u8>, c: char| {
        let mut buf = [0u8; 4];
        out.extend_from_slice(c.encode_utf8(&mut buf).as_bytes());
    };
    let hex =
        |s: &[u8]| -> Option<u32> { u32::from_str_radix(std::str::from_utf8(s).ok()?, 16).ok() };
    let mut i = 0;
    while i < raw.len() {
        let c = raw[i];
        if c == b'\'' && raw.get(i + 1) == Some(&b'\'') {
            out.push(b'\'');
            i += 2;
        } else if c == b'\\' {
            let rest = &raw[i..];
            if rest.starts_with(b"\\\\") {
                out.push(b'\\');
                i += 2;
            } else if rest.starts_with(b"\\X2\\") || rest.starts_with(b"\\X4\\") {
                let width = if rest[2] == b'2' { 4 } else { 8 };
                let body_start = i + 4;
                let end = raw[body_start..]
                    .windows(4)
                    .position(|w| w == b"\\X0\\")
                    .map_or(raw.len(), |p| body_start + p);
                let units: Vec<u32> = raw[body_start..end].chunks(width).filter_map(hex).collect();
                if width == 4 {
                    let units: Vec<u16> = units.iter().map(|&u| u as u16).collect();
                    for ch in char::decode_utf16(units) {
                        push(&mut out, ch.unwrap_or(char::REPLACEMENT_CHARACTER));
                    }
                } else {
                    for u in units {
                        push(
                            &mut out,
                            char::from_u32(u).unwrap_or(char::REPLACEMENT_CHARACTER),
                        );
                    }
                }
                i = (end + 4).min(raw.len());
            } else if rest.starts_with(b"\\X\\") && rest.len() >= 5 {
                match hex(&rest[3..5]).and_then(char::from_u32) {
                    Some(ch) => push(&mut out, ch),
                    None => push(&mut out, char::REPLACEMENT_CHARACTER),
                }
                i += 5;
            } else if rest.starts_with(b"\\S\\") && rest.len() >= 4 {
                push(
                    &mut out,
                    char::from_u32(rest[3] as u32 + 128).unwrap_or('?'),
                );
                i += 4;
            } else if rest.len() >= 4 && rest[1] == b'P' && rest[3] == b'\\' {
                i += 4;
            } else {
                out.push(c);
                i += 1;
            }
        } else {
            out.push(c);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}
