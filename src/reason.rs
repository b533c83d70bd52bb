//! A decision the program made about a photo or a fish (why it was skipped, refused or
//! withheld), carried together with the sentence people read for it.
//!
//! The decision is an enum of the module that makes it (`laser::outcome::SkipReason`,
//! `fish::measure::GeometryFailure`, ...); its `Display` is the sentence. [`Reason`] renders
//! that sentence once, so the summary, the HTML report and the JSON say the same words, and
//! derefs to it, so it reads like the text it replaced.
//!
//! In JSON a reason is its sentence, as it always was. Read back from a document, the
//! sentence is all there is ([`Reason::kind`] is `None`): nothing decides on a reason read
//! from a file, and files from other versions may word it differently.

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::fmt;

/// A decision `K` and its sentence.
#[derive(Clone, Debug, PartialEq)]
pub struct Reason<K> {
    kind: Option<K>,
    text: String,
}

impl<K: fmt::Display> From<K> for Reason<K> {
    fn from(kind: K) -> Self {
        let text = kind.to_string();
        Reason { kind: Some(kind), text }
    }
}

impl<K> Reason<K> {
    /// The decision; `None` for a reason read back from a document.
    pub fn kind(&self) -> Option<&K> {
        self.kind.as_ref()
    }

    /// The sentence.
    pub fn as_str(&self) -> &str {
        &self.text
    }

    /// The same reason as a wider decision (`SkipReason::Target(miss)`), its sentence
    /// rendered anew; a reason read back from a document keeps its text.
    pub fn map<L: fmt::Display>(self, wider: impl FnOnce(K) -> L) -> Reason<L> {
        match self.kind {
            Some(kind) => Reason::from(wider(kind)),
            None => Reason { kind: None, text: self.text },
        }
    }
}

impl<K> std::ops::Deref for Reason<K> {
    type Target = str;
    fn deref(&self) -> &str {
        &self.text
    }
}

impl<K> fmt::Display for Reason<K> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(&self.text)
    }
}

impl<K> Serialize for Reason<K> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.text)
    }
}

impl<'de, K> Deserialize<'de> for Reason<K> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Ok(Reason { kind: None, text: String::deserialize(d)? })
    }
}

/// `Display` and `serde` for a fieldless status enum by its name as the JSON writes it, and
/// comparison with that name (`status == "used"`), which is how scripts and tests spell it.
macro_rules! named_status {
    ($ty:ty { $($variant:ident => $name:literal),+ $(,)? }) => {
        impl $ty {
            /// The name as the JSON and the tables write it.
            pub fn as_str(self) -> &'static str {
                match self { $(Self::$variant => $name),+ }
            }
        }

        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.pad(self.as_str())
            }
        }

        impl PartialEq<&str> for $ty {
            fn eq(&self, other: &&str) -> bool {
                self.as_str() == *other
            }
        }

        impl serde::Serialize for $ty {
            fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                s.serialize_str(self.as_str())
            }
        }

        impl<'de> serde::Deserialize<'de> for $ty {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let name = String::deserialize(d)?;
                match name.as_str() {
                    $($name => Ok(Self::$variant),)+
                    other => Err(serde::de::Error::unknown_variant(other, &[$($name),+])),
                }
            }
        }
    };
}
pub(crate) use named_status;

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Clone, Debug, PartialEq)]
    enum Why {
        Far { m: f64 },
    }

    impl fmt::Display for Why {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            match self {
                Why::Far { m } => write!(f, "too far ({m:.1} m)"),
            }
        }
    }

    #[derive(Clone, Copy, Debug, PartialEq)]
    enum Status {
        Used,
        NoBoard,
    }
    named_status!(Status { Used => "used", NoBoard => "no board" });

    #[test]
    fn a_reason_is_its_sentence_in_json_and_reads_back_as_text() {
        let r = Reason::from(Why::Far { m: 6.25 });
        assert_eq!(&*r, "too far (6.2 m)");
        assert_eq!(r.kind(), Some(&Why::Far { m: 6.25 }));
        let json = serde_json::to_string(&r).unwrap();
        assert_eq!(json, "\"too far (6.2 m)\"");
        let back: Reason<Why> = serde_json::from_str(&json).unwrap();
        assert_eq!(back.as_str(), r.as_str());
        assert_eq!(back.kind(), None);
        assert_eq!(format!("[{r:>18}]"), "[   too far (6.2 m)]");
    }

    #[test]
    fn a_status_is_its_name() {
        assert_eq!(serde_json::to_string(&Status::NoBoard).unwrap(), "\"no board\"");
        assert_eq!(serde_json::from_str::<Status>("\"used\"").unwrap(), Status::Used);
        assert!(serde_json::from_str::<Status>("\"maybe\"").is_err());
        assert!(Status::Used == "used" && Status::NoBoard != "used");
        assert_eq!(format!("{:9}|", Status::Used), "used     |");
    }
}
