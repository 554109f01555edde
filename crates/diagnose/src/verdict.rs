//! The verdict: one word of the documented vocabulary (docs/diagnosis.md, "Vocabulary").

use std::fmt;

use serde::{Serialize, Serializer};

/// What the diagnosis concludes. The report's `verdict` is [`Verdict::word`]: one effect word for
/// every effect family (both forms of `asymmetry` are `asymmetry`; a pair is named by its first
/// member: the single effect it was built around, or the better-scoring of two that failed alone), or
/// `none` / `unexplained`. Which form or pair it was is in the report's `effects` and candidate names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Verdict {
    /// Model and recordings agree within the recordings' noise and the model's own level.
    None,
    Current,
    Wind,
    RudderLag,
    Asymmetry,
    ShallowWater,
    /// The mismatch is real, but no candidate (or pair) accounts for it.
    Unexplained,
}

impl Verdict {
    /// Every verdict, in the order of the vocabulary's table.
    pub const ALL: [Verdict; 7] = [
        Verdict::None,
        Verdict::Current,
        Verdict::Wind,
        Verdict::RudderLag,
        Verdict::Asymmetry,
        Verdict::ShallowWater,
        Verdict::Unexplained,
    ];

    /// The word in reports, tables and the command's output.
    pub const fn word(self) -> &'static str {
        match self {
            Verdict::None => "none",
            Verdict::Current => "current",
            Verdict::Wind => "wind",
            Verdict::RudderLag => "rudder_lag",
            Verdict::Asymmetry => "asymmetry",
            Verdict::ShallowWater => "shallow_water",
            Verdict::Unexplained => "unexplained",
        }
    }

    /// Whether the verdict names an effect (so that a fitted model with it exists).
    pub fn names_effect(self) -> bool {
        !matches!(self, Verdict::None | Verdict::Unexplained)
    }
}

/// As its word, so that the report's `verdict` stays the plain string of the data format.
impl Serialize for Verdict {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.word())
    }
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.word())
    }
}

/// Callers and tests that hold the word (from a JSON report, a table, a command line) compare with it
/// directly.
impl PartialEq<str> for Verdict {
    fn eq(&self, other: &str) -> bool {
        self.word() == other
    }
}

impl PartialEq<&str> for Verdict {
    fn eq(&self, other: &&str) -> bool {
        self.word() == *other
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_verdict_serialises_to_its_word_of_the_vocabulary() {
        let words: Vec<String> = Verdict::ALL
            .iter()
            .map(|v| serde_json::to_string(v).unwrap())
            .collect();
        assert_eq!(
            words,
            [
                "\"none\"",
                "\"current\"",
                "\"wind\"",
                "\"rudder_lag\"",
                "\"asymmetry\"",
                "\"shallow_water\"",
                "\"unexplained\"",
            ]
        );
        for v in Verdict::ALL {
            assert_eq!(v.to_string(), v.word());
            assert_eq!(v, v.word());
        }
    }
}
