//! Line and number helpers shared by the hand-written text parsers
//! (`.tetmesh`, Gmsh MSH 1, 2 and 4.1 ASCII).

use crate::error::MeshError;

/// Iterates over the non-blank lines of a text, remembering 1-based line numbers.
pub(crate) struct LineReader<'a> {
    file: &'a str,
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
    /// Number of the last line returned (0 before the first).
    last: usize,
}

impl<'a> LineReader<'a> {
    /// Reads `text`, reporting errors against `file`.
    pub(crate) fn new(text: &'a str, file: &'a str) -> Self {
        LineReader {
            file,
            lines: text.lines().enumerate(),
            last: 0,
        }
    }

    /// The file name errors are reported against.
    pub(crate) fn file(&self) -> &'a str {
        self.file
    }

    /// The next non-blank line as `(line number, trimmed text)`, or `None` at the end.
    pub(crate) fn next_line(&mut self) -> Option<(usize, &'a str)> {
        for (i, line) in self.lines.by_ref() {
            self.last = i + 1;
            let line = line.trim();
            if !line.is_empty() {
                return Some((i + 1, line));
            }
        }
        None
    }

    /// The next non-blank line, or [`MeshError::Truncated`] saying `expected()` was
    /// expected.
    pub(crate) fn expect_line(
        &mut self,
        expected: impl FnOnce() -> String,
    ) -> Result<(usize, &'a str), MeshError> {
        match self.next_line() {
            Some(l) => Ok(l),
            None => Err(MeshError::Truncated {
                file: self.file.to_owned(),
                line: self.last + 1,
                expected: expected(),
            }),
        }
    }

    /// Returns a [`MeshError::Malformed`] for `line`.
    pub(crate) fn malformed(&self, line: usize, expected: String, found: String) -> MeshError {
        MeshError::Malformed {
            file: self.file.to_owned(),
            line: Some(line),
            expected,
            found,
        }
    }

    /// Parses a finite `f64`, or returns [`MeshError::BadNumber`].
    pub(crate) fn f64(
        &self,
        line: usize,
        token: &str,
        what: impl FnOnce() -> String,
    ) -> Result<f64, MeshError> {
        match token.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.bad_number(line, token, format!("{} (a finite number)", what()))),
        }
    }

    /// Parses a non-negative integer, or returns [`MeshError::BadNumber`].
    pub(crate) fn u64(
        &self,
        line: usize,
        token: &str,
        what: impl FnOnce() -> String,
    ) -> Result<u64, MeshError> {
        token.parse::<u64>().map_err(|_| {
            self.bad_number(line, token, format!("{} (a non-negative integer)", what()))
        })
    }

    /// Parses an integer of either sign, or returns [`MeshError::BadNumber`].
    pub(crate) fn i64(
        &self,
        line: usize,
        token: &str,
        what: impl FnOnce() -> String,
    ) -> Result<i64, MeshError> {
        token
            .parse::<i64>()
            .map_err(|_| self.bad_number(line, token, format!("{} (an integer)", what())))
    }

    fn bad_number(&self, line: usize, token: &str, expected: String) -> MeshError {
        MeshError::BadNumber {
            file: self.file.to_owned(),
            line,
            expected,
            token: shorten(token),
        }
    }
}

/// Splits a line into whitespace-separated tokens.
pub(crate) fn tokens(line: &str) -> Vec<&str> {
    line.split_ascii_whitespace().collect()
}

/// A token or line cut to at most 60 characters for an error message.
pub(crate) fn shorten(s: &str) -> String {
    const MAX: usize = 60;
    match s.char_indices().nth(MAX) {
        Some((i, _)) => format!("{}...", &s[..i]),
        None => s.to_owned(),
    }
}

/// `"1 value"` / `"3 values"`.
pub(crate) fn plural(n: usize, word: &str) -> String {
    if n == 1 {
        format!("{n} {word}")
    } else {
        format!("{n} {word}s")
    }
}

/// `bytes` as UTF-8 text, or the error that names the file and the line of
/// the first invalid byte.
pub(crate) fn utf8<'a>(bytes: &'a [u8], file: &str) -> Result<&'a str, MeshError> {
    std::str::from_utf8(bytes).map_err(|e| MeshError::Malformed {
        file: file.to_owned(),
        line: Some(
            1 + bytes[..e.valid_up_to()]
                .iter()
                .filter(|&&b| b == b'\n')
                .count(),
        ),
        expected: "UTF-8 text".to_owned(),
        found: "invalid bytes".to_owned(),
    })
}
