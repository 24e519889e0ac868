//! Where a finding points in a call's arguments (`pInfos[2].pGeometries[0]
//! .geometry.triangles.pNext<VkAccelerationStructureTrianglesOpacityMicromapEXT>.indexBuffer`),
//! as one type for every check and reader.
//!
//! A location is a value that is written out only when a finding names
//! it: most calls have no finding, and building every location string was
//! most of a valid call's cost. Locations nest by value, one step at a
//! time, from any root that is `Display + Copy` (a parameter name, or an
//! enum of the spellings a root may take):
//!
//! ```
//! use ommcheck::report::location::Locate;
//!
//! let info = "pInfos".index(2);
//! let index_buffer = info.member("pGeometries").index(0).text(".geometry.triangles").member("indexBuffer");
//! assert_eq!(index_buffer.to_string(), "pInfos[2].pGeometries[0].geometry.triangles.indexBuffer");
//! ```

use std::fmt::{self, Display};

/// A place in a call's arguments: `parent` followed by one step `S`
/// ([`Member`], [`Index`] or [`Text`]). Each step is its own type, so a
/// location is as small as its parts and writes itself out without a
/// branch.
#[derive(Clone, Copy, Debug)]
pub struct Location<P, S> {
    parent: P,
    step: S,
}

/// `.name`: a member.
#[derive(Clone, Copy, Debug)]
pub struct Member<'n>(&'n str);

/// `[i]`: an element.
#[derive(Clone, Copy, Debug)]
pub struct Index(u64);

/// Text as it is: members with their own separators
/// (`.pNext<VkAccelerationStructureGeometryMicromapDataKHR>`).
#[derive(Clone, Copy, Debug)]
pub struct Text<'n>(&'n str);

impl<P: Display, S: Display> Display for Location<P, S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.parent.fmt(f)?;
        self.step.fmt(f)
    }
}

impl Display for Member<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, ".{}", self.0)
    }
}

impl Display for Index {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "[{}]", self.0)
    }
}

impl Display for Text<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.0)
    }
}

/// The steps from any location (or root) to the next.
pub trait Locate: Display + Copy + Sized {
    /// The member `name`: `{self}.{name}`.
    fn member(self, name: &str) -> Location<Self, Member<'_>> {
        Location {
            parent: self,
            step: Member(name),
        }
    }

    /// Element `i`: `{self}[{i}]`.
    fn index(self, i: impl TryInto<u64>) -> Location<Self, Index> {
        Location {
            parent: self,
            step: Index(i.try_into().unwrap_or(u64::MAX)),
        }
    }

    /// `text` as it is: `{self}{text}`.
    fn text(self, text: &str) -> Location<Self, Text<'_>> {
        Location {
            parent: self,
            step: Text(text),
        }
    }
}

impl<T: Display + Copy> Locate for T {}

/// One step of a written location: `.name` (or a whole `pNext<...>`) or
/// `[i]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step<'a> {
    Member(&'a str),
    Index(u64),
}

/// A written location read back (for the report's objects and the HTML
/// report's pictures): the call it is in where it starts with `calls[i]: `
/// (a scene's), and its steps: `calls[1]: pInfos[0].triangleArray[3]` is
/// call 1 with `pInfos`, `[0]`, `triangleArray`, `[3]`. Steps stop at the
/// first that is neither a member, an index nor a `pNext<...>` (`->`, a
/// space, a handle).
pub fn steps(location: &str) -> (Option<usize>, Vec<Step<'_>>) {
    let (call, mut path) = match location
        .strip_prefix("calls[")
        .and_then(|rest| rest.split_once(']'))
        .and_then(|(n, rest)| Some((n.parse().ok()?, rest)))
    {
        Some((call, rest)) => (Some(call), rest.strip_prefix(": ").unwrap_or("")),
        None => (None, location),
    };
    let mut steps = Vec::new();
    while !path.is_empty() {
        path = path.strip_prefix('.').unwrap_or(path);
        if let Some(inner) = path.strip_prefix('[') {
            let Some(close) = inner.find(']') else { break };
            let Ok(i) = inner[..close].parse() else { break };
            steps.push(Step::Index(i));
            path = &inner[close + 1..];
            continue;
        }
        let name_end = path
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .unwrap_or(path.len());
        if name_end == 0 {
            break;
        }
        // `pNext<VkAccelerationStructureGeometryMicromapDataKHR>` is one step.
        let end = match path[name_end..].strip_prefix('<') {
            Some(inner) => match inner.find('>') {
                Some(close) => name_end + close + 2,
                None => break,
            },
            None => name_end,
        };
        steps.push(Step::Member(&path[..end]));
        path = &path[end..];
    }
    (call, steps)
}

/// The index after member `name` among `steps`: `triangleArray[3]` is 3.
pub fn index_after(steps: &[Step<'_>], name: &str) -> Option<u64> {
    steps.windows(2).find_map(|pair| match pair {
        [Step::Member(m), Step::Index(i)] if *m == name => Some(*i),
        _ => None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locations_split_into_steps_up_to_what_is_no_step() {
        let (call, s) = steps("calls[3]: pInfos[0].pGeometries[2].geometry.triangles.pNext<VkAccelerationStructureTrianglesOpacityMicromapEXT>.indexBuffer[4]");
        assert_eq!(call, Some(3));
        assert_eq!(
            s,
            [
                Step::Member("pInfos"),
                Step::Index(0),
                Step::Member("pGeometries"),
                Step::Index(2),
                Step::Member("geometry"),
                Step::Member("triangles"),
                Step::Member("pNext<VkAccelerationStructureTrianglesOpacityMicromapEXT>"),
                Step::Member("indexBuffer"),
                Step::Index(4),
            ]
        );
        assert_eq!(steps("calls[2]"), (Some(2), Vec::new()));
        let (_, s) = steps("calls[0]: pInfo->src");
        assert_eq!(s, [Step::Member("pInfo")]);
        // A location of the static API has no call.
        assert_eq!(
            steps("pInfos[0]"),
            (None, vec![Step::Member("pInfos"), Step::Index(0)])
        );
    }

    #[test]
    fn steps_write_out_in_order() {
        let entry = "pInfos".index(0).member("triangleArray").index(7_u64);
        assert_eq!(entry.to_string(), "pInfos[0].triangleArray[7]");
        assert_eq!(
            entry.member("dataOffset").to_string(),
            "pInfos[0].triangleArray[7].dataOffset"
        );
        let chained = "pInfos"
            .index(1_usize)
            .text(".pNext<VkAccelerationStructureGeometryMicromapDataKHR>")
            .member("pUsageCounts")
            .index(2);
        assert_eq!(
            chained.to_string(),
            "pInfos[1].pNext<VkAccelerationStructureGeometryMicromapDataKHR>.pUsageCounts[2]"
        );
    }
}
