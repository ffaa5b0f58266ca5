use std::fmt;
use std::path::{Path, PathBuf};

/// Where in an input file a problem is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Location {
    /// 1-based line of a text file.
    Line(usize),
    /// 0-based byte offset of a binary file.
    Byte(u64),
    /// The file as a whole.
    Whole,
}

/// A bad input file: which file, where in it, and what is wrong.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub struct InputError {
    pub path: PathBuf,
    pub location: Location,
    pub message: String,
}

impl InputError {
    pub fn new(path: &Path, location: Location, message: impl Into<String>) -> InputError {
        InputError {
            path: path.to_path_buf(),
            location,
            message: message.into(),
        }
    }
    pub fn line(path: &Path, line: usize, message: impl Into<String>) -> InputError {
        InputError::new(path, Location::Line(line), message)
    }
    pub fn byte(path: &Path, offset: u64, message: impl Into<String>) -> InputError {
        InputError::new(path, Location::Byte(offset), message)
    }
    pub fn whole(path: &Path, message: impl Into<String>) -> InputError {
        InputError::new(path, Location::Whole, message)
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let path = self.path.display();
        match self.location {
            Location::Line(line) => write!(f, "{path}:{line}: {}", self.message),
            Location::Byte(offset) => write!(f, "{path}: at byte {offset}: {}", self.message),
            Location::Whole => write!(f, "{path}: {}", self.message),
        }
    }
}

/// The bytes as UTF-8 text, or an error naming the line of the first invalid byte.
pub fn utf8_text<'a>(bytes: &'a [u8], path: &Path, what: &str) -> Result<&'a str, InputError> {
    std::str::from_utf8(bytes).map_err(|e| {
        let line = 1 + bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        InputError::line(path, line, format!("not valid UTF-8 text: {what}"))
    })
}
