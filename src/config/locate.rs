//! Locating a field in the RON text: where the config writes a field that
//! a stage's message names (so the message gives its line and column), and
//! the field a syntax error belongs to. A small tokenizer of RON's own
//! grammar; it never fails, and answers `None` where the text does not
//! write the field.

/// The last `name:` written on line `line` (1-based) before column `col`:
/// the field a syntax error there belongs to, for the message.
pub(super) fn field_before(text: &str, line: usize, col: usize) -> Option<String> {
    let row = text.lines().nth(line.checked_sub(1)?)?;
    let before: String = row.chars().take(col.saturating_sub(1)).collect();
    let bytes = before.as_bytes();
    let mut found = None;
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i].is_ascii_alphabetic() || bytes[i] == b'_' {
            let start = i;
            while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                i += 1;
            }
            let rest = before[i..].trim_start();
            if rest.starts_with(':') && !rest.starts_with("::") {
                found = Some(before[start..i].to_string());
            }
        } else if bytes[i] == b'"' {
            // Skip a string: a `:` inside it is no field.
            i += 1;
            while i < bytes.len() && bytes[i] != b'"' {
                i += if bytes[i] == b'\\' { 2 } else { 1 };
            }
            i += 1;
        } else {
            i += 1;
        }
    }
    found
}

/// The position (line, column, 1-based) of an identifier other than `Auto`
/// given as `voxel_size`, which RON would pass on as a nameless unit (see
/// [`super::VoxelSize`]'s `Deserialize`).
pub(super) fn check_voxel_size_word(text: &str) -> Option<(usize, usize, String)> {
    for (n, line) in text.lines().enumerate() {
        let code = line.split("//").next().unwrap_or("");
        let mut rest = code;
        let mut offset = 0;
        while let Some(i) = rest.find("voxel_size") {
            let after = &rest[i + "voxel_size".len()..];
            let before_ok = rest[..i]
                .chars()
                .last()
                .is_none_or(|c| !(c.is_alphanumeric() || c == '_'));
            let trimmed = after.trim_start();
            if before_ok {
                if let Some(value) = trimmed.strip_prefix(':') {
                    let value = value.trim_start();
                    let word: String = value
                        .chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect();
                    let starts_alpha = word.chars().next().is_some_and(|c| c.is_alphabetic());
                    if starts_alpha && word != "Auto" && word != "inf" && word != "NaN" {
                        let col = offset + code[offset..].len() - value.len() + 1;
                        return Some((n + 1, col, word));
                    }
                }
            }
            let step = i + "voxel_size".len();
            offset += step;
            rest = &rest[step..];
        }
    }
    None
}

/// `text` without the UTF-8 byte-order mark some Windows editors put
/// first. The parser would see it as a stray character before `(`; lines
/// and columns count from after it, as editors show them.
pub fn strip_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

/// One step of a field path: a field's name, the name of a variant (or
/// struct) written before its `(`, or a list index.
#[derive(Debug, Clone, PartialEq)]
enum Step {
    Name(String),
    Variant(String),
    Index(usize),
}

/// What [`locate`] reads RON as: names, punctuation, and values (numbers,
/// strings, chars) it only steps over.
#[derive(Debug, PartialEq)]
enum Tok {
    Ident(String),
    Punct(char),
    Value,
}

/// The tokens of `text` with their line and column (1-based, in
/// characters, as RON's own errors count), comments left out.
fn tokens(text: &str) -> Vec<(Tok, usize, usize)> {
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let (mut i, mut line, mut col) = (0, 1, 1);
    // Moves past `n` characters, counting lines.
    let advance = |i: &mut usize, line: &mut usize, col: &mut usize, n: usize| {
        for _ in 0..n {
            if *i >= chars.len() {
                return;
            }
            if chars[*i] == '\n' {
                *line += 1;
                *col = 1;
            } else {
                *col += 1;
            }
            *i += 1;
        }
    };
    let at = |k: usize| chars.get(k).copied();
    while i < chars.len() {
        let c = chars[i];
        let (l0, c0) = (line, col);
        if c.is_whitespace() {
            advance(&mut i, &mut line, &mut col, 1);
        } else if c == '/' && at(i + 1) == Some('/') {
            while i < chars.len() && chars[i] != '\n' {
                advance(&mut i, &mut line, &mut col, 1);
            }
        } else if c == '/' && at(i + 1) == Some('*') {
            // RON's block comments nest.
            let mut depth = 0;
            while i < chars.len() {
                if chars[i] == '/' && at(i + 1) == Some('*') {
                    depth += 1;
                    advance(&mut i, &mut line, &mut col, 2);
                } else if chars[i] == '*' && at(i + 1) == Some('/') {
                    depth -= 1;
                    advance(&mut i, &mut line, &mut col, 2);
                    if depth == 0 {
                        break;
                    }
                } else {
                    advance(&mut i, &mut line, &mut col, 1);
                }
            }
        } else if c == '"' || c == '\'' || (c == 'b' && matches!(at(i + 1), Some('"' | '\''))) {
            // A string or char, escapes stepped over.
            let quote = if c == 'b' {
                advance(&mut i, &mut line, &mut col, 1);
                chars[i]
            } else {
                c
            };
            advance(&mut i, &mut line, &mut col, 1);
            while i < chars.len() && chars[i] != quote {
                let n = if chars[i] == '\\' { 2 } else { 1 };
                advance(&mut i, &mut line, &mut col, n);
            }
            advance(&mut i, &mut line, &mut col, 1);
            out.push((Tok::Value, l0, c0));
        } else if let Some(skip) = raw_string_start(&chars, i) {
            // `r"…"`, `r#"…"#`, `br"…"`: ends at `"` and as many `#`.
            let hashes = skip - if c == 'b' { 3 } else { 2 };
            advance(&mut i, &mut line, &mut col, skip);
            while i < chars.len() {
                let closes = chars[i] == '"' && (1..=hashes).all(|k| at(i + k) == Some('#'));
                if closes {
                    advance(&mut i, &mut line, &mut col, 1 + hashes);
                    break;
                }
                advance(&mut i, &mut line, &mut col, 1);
            }
            out.push((Tok::Value, l0, c0));
        } else if c.is_alphabetic() || c == '_' {
            // A name; `r#name` is a raw identifier.
            if c == 'r' && at(i + 1) == Some('#') {
                advance(&mut i, &mut line, &mut col, 2);
            }
            let start = i;
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                advance(&mut i, &mut line, &mut col, 1);
            }
            out.push((Tok::Ident(chars[start..i].iter().collect()), l0, c0));
        } else if c.is_ascii_digit() || c == '-' || c == '+' || c == '.' {
            // A number: digits, `.`, `_`, an exponent and its sign, `inf`.
            advance(&mut i, &mut line, &mut col, 1);
            while i < chars.len() {
                let d = chars[i];
                let sign_of_exponent = matches!(d, '+' | '-') && matches!(chars[i - 1], 'e' | 'E');
                if d.is_alphanumeric() || d == '.' || d == '_' || sign_of_exponent {
                    advance(&mut i, &mut line, &mut col, 1);
                } else {
                    break;
                }
            }
            out.push((Tok::Value, l0, c0));
        } else {
            advance(&mut i, &mut line, &mut col, 1);
            out.push((Tok::Punct(c), l0, c0));
        }
    }
    out
}

/// When a raw string starts at `chars[i]`, how many characters its opening
/// (`r`, `b`, the `#`s and `"`) takes.
fn raw_string_start(chars: &[char], i: usize) -> Option<usize> {
    let mut k = i;
    if chars.get(k) == Some(&'b') {
        k += 1;
    }
    if chars.get(k) != Some(&'r') {
        return None;
    }
    k += 1;
    while chars.get(k) == Some(&'#') {
        k += 1;
    }
    (chars.get(k) == Some(&'"')).then_some(k + 1 - i)
}

/// `path` as messages write it (`placement.Grid.cells`, `lights[2]`,
/// `compare.cameras[0].fov_degrees`) in steps; `None` when it is not one.
fn path_steps(path: &str) -> Option<Vec<Step>> {
    let mut steps = Vec::new();
    for part in path.split('.') {
        let (name, mut rest) = part.split_at(part.find('[').unwrap_or(part.len()));
        let ident = |s: &str| {
            s.chars()
                .next()
                .is_some_and(|c| c.is_alphabetic() || c == '_')
                && s.chars().all(|c| c.is_alphanumeric() || c == '_')
        };
        if !ident(name) {
            return None;
        }
        steps.push(Step::Name(name.to_string()));
        while !rest.is_empty() {
            let close = rest.find(']')?;
            steps.push(Step::Index(rest.get(1..close)?.parse().ok()?));
            rest = &rest[close + 1..];
            if !rest.is_empty() && !rest.starts_with('[') {
                return None;
            }
        }
    }
    Some(steps)
}

/// Whether the path `written` in the text is the one `wanted` names. A
/// variant may be left out of `wanted`: messages name `placement.min_radius`
/// for `placement: MedialAxis((min_radius: …))`, and `Some(…)` is a variant
/// too.
fn same_path(wanted: &[Step], written: &[Step]) -> bool {
    let mut w = wanted.iter().peekable();
    for step in written {
        let matched = match (w.peek(), step) {
            (Some(Step::Name(a)), Step::Name(b) | Step::Variant(b)) => a == b,
            (Some(Step::Index(a)), Step::Index(b)) => a == b,
            _ => false,
        };
        if matched {
            w.next();
        } else if !matches!(step, Step::Variant(_)) {
            return false;
        }
    }
    w.next().is_none()
}

/// An open `(`, `[` or `{` of the text [`locate`] walks.
struct Frame {
    /// The path of what the brackets hold.
    base: Vec<Step>,
    /// A list: its elements are indexed.
    list: bool,
    /// The element under way (lists).
    index: usize,
    /// Whether the element under way has begun (lists).
    started: bool,
    /// The path of the field whose value is under way (structs).
    key: Option<Vec<Step>>,
}

impl Frame {
    fn new(base: Vec<Step>, list: bool) -> Frame {
        Frame {
            base,
            list,
            index: 0,
            started: false,
            key: None,
        }
    }
}

/// Where the RON `text` writes the field `path`, as the messages of the
/// stages name it (`voxel_size`, `placement.min_distance`,
/// `placement.Grid.cells`, `reference.camera`, `lights[2]`): the line and
/// column (1-based, in characters) of the field's name, or of a list
/// element's first character. `None` when the text does not write it (its
/// default is in force), so that a message points only at what the user
/// wrote. Comments and strings are skipped; a leading byte-order mark is
/// not counted ([`strip_bom`]).
pub fn locate(text: &str, path: &str) -> Option<(usize, usize)> {
    let wanted = path_steps(path)?;
    let toks = tokens(strip_bom(text));
    let mut stack: Vec<Frame> = Vec::new();
    // The path of a value starting now, in the innermost frame.
    let value_path = |stack: &[Frame]| match stack.last() {
        None => Vec::new(),
        Some(f) if f.list => {
            let mut p = f.base.clone();
            p.push(Step::Index(f.index));
            p
        }
        Some(f) => f.key.clone().unwrap_or_else(|| f.base.clone()),
    };
    let mut i = 0;
    while i < toks.len() {
        let (tok, line, col) = &toks[i];
        let next = toks.get(i + 1).map(|t| &t.0);
        if let Some(f) = stack.last_mut() {
            if f.list && !f.started && !matches!(tok, Tok::Punct(',' | ']')) {
                f.started = true;
                let mut p = f.base.clone();
                p.push(Step::Index(f.index));
                if same_path(&wanted, &p) {
                    return Some((*line, *col));
                }
            }
        }
        match tok {
            Tok::Ident(name) if next == Some(&Tok::Punct(':')) => {
                if let Some(f) = stack.last_mut().filter(|f| !f.list) {
                    let mut p = f.base.clone();
                    p.push(Step::Name(name.clone()));
                    if same_path(&wanted, &p) {
                        return Some((*line, *col));
                    }
                    f.key = Some(p);
                }
                i += 1;
            }
            Tok::Ident(name) if next == Some(&Tok::Punct('(')) => {
                let mut base = value_path(&stack);
                // At the top, a name before `(` is the config struct's own.
                if !stack.is_empty() {
                    base.push(Step::Variant(name.clone()));
                }
                stack.push(Frame::new(base, false));
                i += 1;
            }
            Tok::Punct('(' | '{') => stack.push(Frame::new(value_path(&stack), false)),
            Tok::Punct('[') => stack.push(Frame::new(value_path(&stack), true)),
            Tok::Punct(')' | ']' | '}') => {
                stack.pop()?;
            }
            Tok::Punct(',') => {
                if let Some(f) = stack.last_mut() {
                    if f.list {
                        f.index += 1;
                        f.started = false;
                    } else {
                        f.key = None;
                    }
                }
            }
            _ => {}
        }
        i += 1;
    }
    None
}
