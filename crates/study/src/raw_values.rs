//! Study-file values that take more than one shape (a number or a list, a list or a range, a word or a
//! list). Their deserializers say which shapes they accept and name the offending one: serde's
//! untagged enums only say "data did not match any variant", and a range written with an extra key
//! (`{ from = 1, to = 8, by = 2 }`) was taken as the whole range.

use std::fmt;

use serde::Deserialize;
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};

/// One value of a grid axis, or several (`lambda = 1e-3` or `lambda = [1e-4, 1e-3]`).
#[derive(Debug, Clone, PartialEq)]
pub enum OneOrMany {
    One(f64),
    Many(Vec<f64>),
}

impl OneOrMany {
    pub fn values(&self) -> Vec<f64> {
        match self {
            OneOrMany::One(x) => vec![*x],
            OneOrMany::Many(v) => v.clone(),
        }
    }
}

/// Overshoot counts after which each training zig-zag is cut: a list (`[1, 4]`), one count (`3`) or
/// a range (`{ from = 1, to = 8 }`, both ends included).
#[derive(Debug, Clone, PartialEq)]
pub enum OvershootSpec {
    List(Vec<u32>),
    Range { from: u32, to: u32 },
}

/// The test recordings of a study: `"all"` or a list of file names.
#[derive(Debug, Clone, PartialEq)]
pub enum TestRecordings {
    /// "all" (any other word is refused when the study is checked, naming it).
    Word(String),
    List(Vec<String>),
}

/// A TOML number, integer or float; `-0.0` is read as `0.0`, since it labels cases and ids as
/// `-0` while fitting exactly as `0`, so two of them would pass the grid's repeat check as two
/// values and give one case twice.
struct Number(f64);

/// `x` with a negative zero made positive (every other value unchanged).
pub fn unsigned_zero(x: f64) -> f64 {
    if x == 0.0 { 0.0 } else { x }
}

impl<'de> Deserialize<'de> for Number {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Number;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number")
            }
            fn visit_f64<E: de::Error>(self, x: f64) -> Result<Number, E> {
                Ok(Number(unsigned_zero(x)))
            }
            fn visit_i64<E: de::Error>(self, x: i64) -> Result<Number, E> {
                Ok(Number(x as f64))
            }
            fn visit_u64<E: de::Error>(self, x: u64) -> Result<Number, E> {
                Ok(Number(x as f64))
            }
        }
        d.deserialize_any(V)
    }
}

impl<'de> Deserialize<'de> for OneOrMany {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = OneOrMany;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or a list of numbers (e.g. 1e-3 or [1e-4, 1e-3])")
            }
            fn visit_f64<E: de::Error>(self, x: f64) -> Result<OneOrMany, E> {
                Ok(OneOrMany::One(unsigned_zero(x)))
            }
            fn visit_i64<E: de::Error>(self, x: i64) -> Result<OneOrMany, E> {
                Ok(OneOrMany::One(x as f64))
            }
            fn visit_u64<E: de::Error>(self, x: u64) -> Result<OneOrMany, E> {
                Ok(OneOrMany::One(x as f64))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<OneOrMany, A::Error> {
                let mut values = Vec::new();
                while let Some(Number(x)) = seq.next_element()? {
                    values.push(x);
                }
                Ok(OneOrMany::Many(values))
            }
        }
        d.deserialize_any(V)
    }
}

/// A training time window `[start, end]` in seconds. Exactly two numbers: a third one (`[0, 120,
/// 5]`, perhaps meant as a step or a third window's start) was dropped without a word.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeWindow(pub [f64; 2]);

impl<'de> Deserialize<'de> for TimeWindow {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = TimeWindow;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a time window [start, end] in seconds (two numbers, e.g. [0, 120])")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<TimeWindow, A::Error> {
                let mut ends = Vec::with_capacity(2);
                while ends.len() < 2 {
                    match seq.next_element::<Number>()? {
                        Some(Number(x)) => ends.push(x),
                        None => break,
                    }
                }
                let mut extra = 0;
                while seq.next_element::<de::IgnoredAny>()?.is_some() {
                    extra += 1;
                }
                let given = ends.len() + extra;
                if given != 2 {
                    let s = if given == 1 { "" } else { "s" };
                    return Err(de::Error::custom(format!(
                        "a time window is [start, end] in seconds (two numbers, e.g. [0, 120]), \
                         not {given} value{s}"
                    )));
                }
                Ok(TimeWindow([ends[0], ends[1]]))
            }
        }
        d.deserialize_any(V)
    }
}

/// An overshoot count: a whole number of 1 or more.
struct Count(u32);

fn count<E: de::Error>(x: i128) -> Result<u32, E> {
    match u32::try_from(x) {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(E::custom(format!(
            "an overshoot count is a whole number of 1 or more, not {x}"
        ))),
    }
}

impl<'de> Deserialize<'de> for Count {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Count;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an overshoot count (a whole number of 1 or more)")
            }
            fn visit_i64<E: de::Error>(self, x: i64) -> Result<Count, E> {
                count(x.into()).map(Count)
            }
            fn visit_u64<E: de::Error>(self, x: u64) -> Result<Count, E> {
                count(x.into()).map(Count)
            }
        }
        d.deserialize_any(V)
    }
}

impl<'de> Deserialize<'de> for OvershootSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = OvershootSpec;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(
                    "overshoot counts: a list such as [1, 4], one count such as 3, or a range { from = 1, to = 8 }",
                )
            }
            fn visit_i64<E: de::Error>(self, x: i64) -> Result<OvershootSpec, E> {
                count(x.into()).map(|n| OvershootSpec::List(vec![n]))
            }
            fn visit_u64<E: de::Error>(self, x: u64) -> Result<OvershootSpec, E> {
                count(x.into()).map(|n| OvershootSpec::List(vec![n]))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<OvershootSpec, A::Error> {
                let mut counts = Vec::new();
                while let Some(Count(n)) = seq.next_element()? {
                    counts.push(n);
                }
                Ok(OvershootSpec::List(counts))
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<OvershootSpec, A::Error> {
                let (mut from, mut to) = (None, None);
                while let Some(key) = map.next_key::<String>()? {
                    let slot = match key.as_str() {
                        "from" => &mut from,
                        "to" => &mut to,
                        _ => {
                            return Err(de::Error::custom(format!(
                                "unknown key `{key}` in an overshoot range: it has `from` and `to` (both included) only"
                            )));
                        }
                    };
                    if slot.is_some() {
                        return Err(de::Error::custom(format!(
                            "`{key}` given twice in an overshoot range"
                        )));
                    }
                    *slot = Some(map.next_value::<Count>()?.0);
                }
                match (from, to) {
                    (Some(from), Some(to)) => Ok(OvershootSpec::Range { from, to }),
                    _ => Err(de::Error::custom(
                        "an overshoot range needs both `from` and `to`, e.g. { from = 1, to = 8 }",
                    )),
                }
            }
        }
        d.deserialize_any(V)
    }
}

impl<'de> Deserialize<'de> for TestRecordings {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = TestRecordings;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("\"all\" or a list of recording file names")
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<TestRecordings, E> {
                Ok(TestRecordings::Word(s.to_string()))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<TestRecordings, A::Error> {
                let mut names = Vec::new();
                while let Some(name) = seq.next_element::<FileName>()? {
                    names.push(name.0);
                }
                Ok(TestRecordings::List(names))
            }
        }
        d.deserialize_any(V)
    }
}

/// A recording's file name in a list.
struct FileName(String);

impl<'de> Deserialize<'de> for FileName {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = FileName;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a recording's file name (a string)")
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<FileName, E> {
                Ok(FileName(s.to_string()))
            }
        }
        d.deserialize_any(V)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Deserialize)]
    struct Doc<T> {
        value: T,
    }

    /// Parses `value = <text>` and gives the value or the message.
    fn check<T: for<'de> Deserialize<'de> + PartialEq + fmt::Debug>(
        text: &str,
        expected: Result<T, &str>,
    ) {
        let got = toml::from_str::<Doc<T>>(&format!("value = {text}")).map(|d| d.value);
        match (got, expected) {
            (Ok(v), Ok(e)) => assert_eq!(v, e, "{text}"),
            (Err(err), Err(e)) => {
                assert!(err.message().contains(e), "{text}: {}", err.message())
            }
            (got, e) => panic!("{text}: got {got:?}, expected {e:?}"),
        }
    }

    #[test]
    fn overshoot_counts_in_every_shape_and_what_is_refused() {
        use OvershootSpec::*;
        check("[1, 4]", Ok(List(vec![1, 4])));
        check("3", Ok(List(vec![3])));
        check("{ from = 1, to = 8 }", Ok(Range { from: 1, to: 8 }));
        check::<OvershootSpec>("{ from = 1, to = 8, by = 2 }", Err("unknown key `by`"));
        check::<OvershootSpec>("{ from = 1 }", Err("needs both `from` and `to`"));
        check::<OvershootSpec>("-1", Err("1 or more, not -1"));
        check::<OvershootSpec>("0", Err("1 or more, not 0"));
        check::<OvershootSpec>("[1, -2]", Err("1 or more, not -2"));
        check::<OvershootSpec>("[1.5]", Err("expected an overshoot count"));
        check::<OvershootSpec>("\"x\"", Err("expected overshoot counts: a list"));
    }

    #[test]
    fn grid_values_are_one_number_or_a_list_of_numbers() {
        use OneOrMany::*;
        check("1e-3", Ok(One(1e-3)));
        check("2", Ok(One(2.0)));
        check("[1e-4, 1]", Ok(Many(vec![1e-4, 1.0])));
        check::<OneOrMany>("\"x\"", Err("expected a number or a list of numbers"));
        check::<OneOrMany>("[1, \"a\"]", Err("expected a number"));
    }

    #[test]
    fn time_window_with_extra_elements_is_refused_not_cut_to_two() {
        check("[0, 120]", Ok(TimeWindow([0.0, 120.0])));
        check::<TimeWindow>("[0, 120, 5]", Err("not 3 values"));
        check::<TimeWindow>("[0, 120, 5, 6, 7]", Err("not 5 values"));
        check::<TimeWindow>("[0, 120, \"x\"]", Err("not 3 values"));
        check::<TimeWindow>("[120]", Err("not 1 value"));
        check::<TimeWindow>("[]", Err("not 0 values"));
        check::<TimeWindow>("[0, \"x\"]", Err("expected a number"));
        check::<TimeWindow>("120", Err("expected a time window [start, end]"));
    }

    #[test]
    fn negative_zero_is_read_as_zero_so_repeats_are_seen() {
        let bits = |v: OneOrMany| v.values().iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let got = toml::from_str::<Doc<OneOrMany>>("value = [0.0, -0.0]").unwrap();
        assert_eq!(bits(got.value), vec![0u64, 0]);
        let got = toml::from_str::<Doc<OneOrMany>>("value = -0.0").unwrap();
        assert_eq!(bits(got.value), vec![0u64]);
        let got = toml::from_str::<Doc<TimeWindow>>("value = [-0.0, 120]").unwrap();
        assert_eq!(got.value.0[0].to_bits(), 0);
    }

    #[test]
    fn test_recordings_are_a_word_or_a_list_of_names() {
        use TestRecordings::*;
        check("\"all\"", Ok(Word("all".into())));
        check("[\"a.csv\"]", Ok(List(vec!["a.csv".into()])));
        check::<TestRecordings>(
            "5",
            Err("expected \"all\" or a list of recording file names"),
        );
        check::<TestRecordings>("[1]", Err("expected a recording's file name"));
    }
}
