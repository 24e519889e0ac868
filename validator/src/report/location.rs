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

#[cfg(test)]
mod tests {
    use super::*;

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
